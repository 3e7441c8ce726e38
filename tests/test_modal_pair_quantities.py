"""The pair test's oscillator terms hold a mode's response as displacement,
velocity or acceleration (identifier/modal/peak_pairs.py, ``pair_lr``):
in unit-RMS channels of several quantities a broad mode's summed
periodogram is ``L (a + b omega^2 + c omega^4)``, skewed against a
displacement's ``L``, and with one ``L`` term per mode two poles fitted
the skew better than one: a heavily damped mode's second SSI pole was
reported as a mode."""
from __future__ import annotations

import modal_fuzz
import numpy as np
from modal_synth import forced

from structbench.identifier import modal
from structbench.identifier.modal import peak_pairs, peak_test

N, LEAD = 40_000, 4_000
W0, Z0 = 28.7, 0.037  # the broad mode (rad/s, damping ratio)
DT = np.pi / (4.0 * W0)
POLES = np.array([28.216, 29.113]), np.array([0.0118, 0.0355])  # SSI's two poles for it (seed 1,001,169)


def _channels(rng: np.random.Generator, modes: list[tuple[float, float]]) -> np.ndarray:
    """(2, N): displacement and acceleration at one point of modes (omega, zeta) of unit shape under one white force, 1 % noise."""
    f = rng.standard_normal(N + LEAD)
    q, a = np.zeros(N), np.zeros(N)
    for omega, zeta in modes:
        qm, vm = forced(omega, zeta, DT, f)
        q += qm[LEAD:]
        a += (f - 2 * zeta * omega * vm - omega**2 * qm)[LEAD:]
    y = np.vstack([q, a])
    return y + 0.01 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


def _p(y: np.ndarray) -> float:
    summed = peak_test.summed_periodogram([y])
    T = N * DT
    lines = 2 * np.pi * np.arange(N // 2 + 1) / T
    return float(peak_pairs.pair_lr(summed, lines, T, *POLES, 0, 1, set())[1])


def test_one_broad_mode_needs_one_term_and_two_modes_two(monkeypatch):
    records = [_channels(np.random.default_rng(seed), [(W0, Z0)]) for seed in range(6)]
    assert all(_p(y) >= peak_test.ALPHA for y in records)
    for seed in range(3):  # two modes at the poles' places: both needed
        assert _p(_channels(np.random.default_rng(seed), [(28.216, 0.0118), (29.113, 0.0118)])) < 1e-6
    monkeypatch.setattr(peak_test, "NEIGHBOUR_QUANTITIES", (0,))  # a displacement term per mode:
    assert sum(_p(y) < peak_test.ALPHA for y in records) >= 5  # the skew takes a second pole (5 of 6 seeds)


def test_a_broad_mode_is_reported_once(monkeypatch):
    """Held-out profile seed 1,001,169 (a tuning seed, looked at after its
    check): 10 sensors of three quantities, 40,000 samples, true modes at
    4.2, 14.3, 15.5, 28.70 (``zeta`` 0.037) and 97.5 rad/s; SSI's poles at
    28.22 (coherence 0.996) and 29.11 rad/s were both reported."""
    rec = modal_fuzz.unseen_record(1_001_169)

    def near(result: modal.Identification) -> list[float]:
        return [w for w in result.omega if 27.0 < w < 30.5]

    kept = near(modal.identify([modal_fuzz.unseen_trace(rec)]))
    assert len(kept) == 1 and abs(kept[0] / 28.697 - 1) < 0.02
    monkeypatch.setattr(peak_test, "NEIGHBOUR_QUANTITIES", (0,))
    assert len(near(modal.identify([modal_fuzz.unseen_trace(rec)]))) == 2
