"""A record band-pass filtered in the frequency domain (every line outside the
band set to zero, as an FFT filter leaves it) is identified, not crashed on.

The harmonic screen whitens each line by the channels' spectral matrix over
its neighbours (identifier/modal/harmonics_spatial.py); in the emptied band
that matrix is zero, up to the running sums' rounding, and the solve raised
``LinAlgError`` out of ``modal.identify``. Such lines hold nothing to whiten:
they are left out of the screen (NaN)."""
from __future__ import annotations

import modal_fuzz
import numpy as np
from modal_synth import forced

from structbench.identifier import modal
from structbench.identifier.modal import harmonics_spatial

OMEGA, ZETA, DT, N, LEAD = np.array([3.0, 7.0, 16.0]), 0.02, 0.05, 12_000, 2_000
BAND = (5.0, 10.0)  # rad/s: only the 7 rad/s mode is left


def _filtered(seed: int) -> np.ndarray:
    """(4, N) displacements of three modes under white forces, band-passed to ``BAND``."""
    rng = np.random.default_rng(seed)
    q = np.array([forced(w, ZETA, DT, rng.standard_normal(N + LEAD))[0][LEAD:] for w in OMEGA])
    y = rng.uniform(0.5, 1.0, (4, 3)) @ q
    y += 1e-3 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    Y = np.fft.rfft(y, axis=1)
    w = 2 * np.pi * np.fft.rfftfreq(N, DT)
    Y[:, (w < BAND[0]) | (w > BAND[1])] = 0.0
    return np.fft.irfft(Y, N, axis=1)


def _trace(y: np.ndarray):
    rec = {"y": y, "dt": DT, "quantities": np.array(["displacement"] * y.shape[0]), "noise": np.zeros(y.shape[0])}
    return modal_fuzz.unseen_trace(rec)


def test_whitening_leaves_out_the_empty_lines():
    """The whitened lines: finite where the record holds signal, NaN in the emptied band."""
    X = np.fft.rfft(_filtered(0), axis=1)
    w = 2 * np.pi * np.fft.rfftfreq(N, DT)
    T = harmonics_spatial.whitened(X, 24)
    inside = (w > BAND[0] + 0.2) & (w < BAND[1] - 0.2)
    outside = (w < BAND[0] - 0.5) | (w > BAND[1] + 0.5)  # the 24 lines either side reach 0.25 rad/s
    assert np.isfinite(T[inside]).all()
    assert np.isnan(T[outside]).all()
    left, right = harmonics_spatial.sided(X, 24)
    assert np.isfinite(left[inside][-50:]).all() and np.isfinite(right[inside][:50]).all()


def test_a_band_passed_record_gives_its_mode():
    """Three seeds: the 7 rad/s mode is reported within 1 %; the ones filtered out are not."""
    for seed in range(3):
        result = modal.identify([_trace(_filtered(seed))])
        omega = np.array(result.omega)
        assert np.min(np.abs(omega - 7.0)) < 0.07, (seed, omega)
        assert not np.any(np.abs(omega - 3.0) < 0.3) and not np.any(np.abs(omega - 16.0) < 0.8), (seed, omega)
