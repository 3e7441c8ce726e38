"""Scoring functions against hand computations."""
import numpy as np
import pytest

from structbench.evaluation.metrics import frequency_error_pct, normalized_rms, relative_errors
from structbench.models.mac import mac


def test_normalized_rms_of_the_ch4_postulated_case1_model():
    actual = [0.92, 1.28, 1.17, 0.63, 1.11, 0.98, 1.38, 0.68, 1.24, 0.56, 0.76, 1.12]
    postulated = [0.90, 1.15, 1.20, 0.50, 1.20, 0.90, 1.30, 0.60, 1.00, 0.50, 0.90, 1.00]
    # the reference file: 12.2 % initial error
    assert normalized_rms(postulated, actual) == pytest.approx(0.122, abs=5e-4)
    assert normalized_rms(actual, actual) == 0.0
    assert normalized_rms([1.1, 0.0], [1.0, 0.0]) == pytest.approx(0.1)


def test_relative_and_frequency_errors():
    np.testing.assert_allclose(relative_errors([2.0, 3.0], [1.0, 4.0]), [1.0, -0.25])
    np.testing.assert_allclose(frequency_error_pct([0.0, 0.09834], [0.0, 0.09870]), [0.0, -0.3647], atol=1e-4)


def test_mac_of_sine_shapes():
    x = np.linspace(0, 1, 11)[1:-1]
    phi = np.sin(np.outer(x, [1, 2, 3]) * np.pi)
    m = mac(phi, 2.5 * phi)
    np.testing.assert_allclose(np.diag(m), 1.0)
    np.testing.assert_allclose(m - np.diag(np.diag(m)), 0.0, atol=1e-12)
    assert mac(phi[:, :1], phi[:, :1] + [[0.1]] * 9)[0, 0] < 1.0
