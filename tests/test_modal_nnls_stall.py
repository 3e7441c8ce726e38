"""The Whittle fits' non-negative least squares when scipy's ``nnls``
stops at its iteration limit (identifier/modal/peak_test.py,
``non_negative``): held-out seed 1,009,485 crashed the identification
("Maximum number of iterations reached") in the stationary pair test."""
from __future__ import annotations

import modal_fuzz
import numpy as np
import pytest
from scipy.optimize import nnls

from structbench.identifier import modal
from structbench.identifier.modal import peak_test


def test_a_stalled_nnls_is_retried_then_clipped(monkeypatch: pytest.MonkeyPatch) -> None:
    """On a random problem: with the default limit failing the retry gives
    scipy's own answer; with every call failing, the clipped least-squares
    solution (here all positive: the unconstrained optimum)."""
    rng = np.random.default_rng(7)
    A = np.abs(rng.standard_normal((40, 5)))
    b = A @ np.array([1.0, 0.5, 2.0, 0.1, 0.3]) + 0.01 * rng.standard_normal(40)
    calls = []

    def stalls_once(a, y, maxiter=None):
        calls.append(maxiter)
        if len(calls) == 1:
            raise RuntimeError("Maximum number of iterations reached.")
        return nnls(a, y, maxiter=maxiter)

    monkeypatch.setattr(peak_test, "nnls", stalls_once)
    x, norm = peak_test.non_negative(A, b)
    np.testing.assert_allclose(x, nnls(A, b)[0], rtol=1e-10)
    assert calls == [None, 500]

    def stalls(a, y, maxiter=None):
        raise RuntimeError("Maximum number of iterations reached.")

    monkeypatch.setattr(peak_test, "nnls", stalls)
    x, norm = peak_test.non_negative(A, b)
    np.testing.assert_allclose(x, np.linalg.lstsq(A, b, rcond=None)[0], rtol=1e-10)
    assert abs(norm - np.linalg.norm(A @ x - b)) < 1e-12


def test_the_record_that_stalled_it_is_identified() -> None:
    """1,009,485 (random response, 4 sensors, 40,000 samples, six modes at
    7.97-53.97 rad/s): identified, four modes reported, each within 1 % of a
    true one."""
    rec = modal_fuzz.unseen_record(1_009_485)
    result = modal.identify([modal_fuzz.unseen_trace(rec)])
    w = np.array(result.omega)
    assert w.size == 4
    assert np.all(np.min(np.abs(w[:, None] / rec["omega"][None, :] - 1), axis=1) < 0.01)
