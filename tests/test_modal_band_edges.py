"""The band a filtered or resampled record holds (identifier/modal/band_edges.py): found at the filter's
edge, never in a structure's own response, and the pole SSI fits to the edge not reported."""
from __future__ import annotations

import numpy as np
import pytest
from modal_fuzz import unseen_trace
from modal_odd_records import daq, upsample
from modal_synth import forced

from structbench.identifier import modal
from structbench.identifier.modal import band_edges

DT = 0.01
NYQUIST = np.pi / DT


def response(seed: int, n: int = 8_000, free: bool | None = None) -> np.ndarray:
    """1-8 modes up to 0.97 of the Nyquist frequency (damping 0.05-10 %), read by 1-6 sensors as
    displacement, velocity or acceleration, with white noise of 0-1 % of the RMS (none in a third)."""
    rng = np.random.default_rng(seed)
    k, m = int(rng.integers(1, 9)), int(rng.integers(1, 7))
    omega = np.sort(rng.uniform(0.02, 0.97, k)) * NYQUIST
    zeta = np.exp(rng.uniform(np.log(5e-4), np.log(0.1), k))
    t = np.arange(n) * DT
    if rng.random() < 0.5 if free is None else free:
        q = np.exp(-zeta[:, None] * omega[:, None] * t) * np.cos(omega[:, None] * t + rng.uniform(0, 6, (k, 1)))
        q = q * (omega[:, None] ** int(rng.integers(0, 3)))
    else:
        force = rng.standard_normal((k, n + 2_000))
        q = np.array([forced(w, z, DT, f)[int(rng.integers(0, 2))][2_000:] * w ** int(rng.integers(0, 2))
                      for w, z, f in zip(omega, zeta, force)])
    y = rng.uniform(-1, 1, (m, k)) @ q
    ratio = 0.0 if rng.random() < 1 / 3 else rng.uniform(0, 0.01)
    return y + ratio * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


@pytest.mark.parametrize("seed", range(30))
def test_a_response_has_no_edge(seed):
    low, high, fall_low, fall_high = band_edges.band([response(seed)], DT)
    assert (low, high) == (0.0, pytest.approx(NYQUIST))
    assert max(fall_low, fall_high) < band_edges.CLIFF


def test_one_light_mode_falls_under_the_lorentzian_bound():
    t = np.arange(20_000) * DT  # a noise-free decay of damping 0.01 %: a peak 8 decades high
    y = (np.exp(-1e-4 * 200 * t) * np.cos(200 * t))[None]
    _, _, fall_low, fall_high = band_edges.band([y], DT)
    assert max(fall_low, fall_high) < np.log10(36)


@pytest.mark.parametrize("seed", range(3))
def test_the_edges_of_a_filter_are_found(seed):
    y, rng = response(seed, free=False), np.random.default_rng(seed)
    (low_pass, _), = daq(y, DT, rng)  # a 255-tap FIR: 0.825-0.875 of the Nyquist frequency from 0 to -200 dB
    low, high, _, fall = band_edges.band([low_pass], DT)
    assert low == 0.0 and 0.82 * NYQUIST <= high <= 0.875 * NYQUIST and fall > 5
    (twice, half), = upsample(y, DT, rng)  # nothing past the first rate's Nyquist frequency
    assert band_edges.band([twice], half)[:2] == (0.0, pytest.approx(NYQUIST, rel=0.03))
    Y = np.fft.rfft(y, axis=1)
    lines = np.arange(Y.shape[1]) / (Y.shape[1] - 1)
    Y[:, (lines < 0.3) | (lines > 0.6)] = 0
    low, high, _, _ = band_edges.band([np.fft.irfft(Y, y.shape[1], axis=1)], DT)
    assert (low, high) == (pytest.approx(0.3 * NYQUIST, rel=0.03), pytest.approx(0.6 * NYQUIST, rel=0.03))


def test_a_filter_pole_is_not_reported():
    """A free decay of three modes through an anti-alias filter: the filter rings at its edge after the
    start, SSI fits the ringing, and it is listed apart, the three modes reported."""
    rng = np.random.default_rng(5)
    omega, zeta = np.array([20.0, 55.0, 110.0]), np.array([0.01, 0.02, 0.015])
    t = np.arange(6_000) * DT
    q = np.exp(-zeta[:, None] * omega[:, None] * t) * np.cos(omega[:, None] * t)
    y = rng.uniform(0.5, 1, (4, 3)) @ q
    y = y + 0.001 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    (filtered, _), = daq(y, DT, rng)
    result = modal.identify([unseen_trace({"y": filtered, "dt": DT, "quantities": ["acceleration"] * 4,
                                           "noise": np.zeros(4)})])
    assert np.sort(result.omega) == pytest.approx(omega, rel=1e-3)
    edge = [r for r in result.details["rejected"] if "band edge" in r["reason"]]
    assert edge and all(r["omega"] > 0.7 * NYQUIST for r in edge)
    assert [w for w in result.details["warnings"] if "band ends at" in w]
