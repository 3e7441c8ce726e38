"""The ML fit's covariance (identifier/modal/ml_fit.py,
``inverse_information``): the inverse of the Fisher information, NaN for
parameters the record leaves undetermined, and no LinAlgWarning."""
from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as la

from structbench.identifier.modal.ml_fit import inverse_information


def test_a_well_conditioned_information_is_inverted_exactly() -> None:
    """Against ``scipy.linalg.inv`` on a random SPD matrix of parameters
    of very different units (diagonal from 1e-6 to 1e6)."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal((6, 6))
    units = np.logspace(-3, 3, 6)
    h = (a @ a.T + 6 * np.eye(6)) * units[:, None] * units[None, :]
    np.testing.assert_allclose(inverse_information(h), la.inv(h), rtol=1e-10)


def test_an_undetermined_parameter_gets_nan_and_the_rest_its_inverse() -> None:
    """Two poles on one mode: their parameters' information is a rank-one
    block (two equal columns of the Jacobian), decoupled from two
    well-determined parameters. The determined pair's covariance is the
    inverse of its own block; the undetermined pair's NaN; scipy's solver
    warned (rcond ~ 1e-17) where this says so in its answer."""
    jac = np.random.default_rng(5).standard_normal((50, 3))
    jac = np.column_stack([jac, jac[:, 2]])  # parameter 3 repeats parameter 2
    h = jac.T @ jac
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cov = inverse_information(h)
    assert np.all(np.isnan(cov[2:, :])) and np.all(np.isnan(cov[:, 2:]))
    schur = h[:2, :2] - h[:2, 2:3] @ h[2:3, :2] / h[2, 2]  # the pair's information, the repeated one profiled out
    np.testing.assert_allclose(cov[:2, :2], la.inv(schur), rtol=1e-6)
