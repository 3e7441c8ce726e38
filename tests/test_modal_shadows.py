"""The shadow test both ways (identifier/modal/peak_pairs.py, ``shadows``):
of two candidates of one shape (MAC over ``SHADOW_MAC``), the better
supported must show a spectral peak of its own too. On one sensor every
shape is alike, and SSI can fit the flank of a heavily damped mode's
acceleration spectrum with a pole better supported than the mode's own
(tuning seed 900897, issue 21's eleventh round)."""
from __future__ import annotations

import numpy as np
from modal_synth import forced

from structbench.identifier.modal.support import judge

DT, N = 0.0273, 15000


def _acceleration(rng: np.random.Generator, modes: list[tuple[float, float, float]], noise: float) -> np.ndarray:
    """One acceleration channel (1, N) of modes (omega rad/s, zeta, force
    scale) under white forces (zero-order hold, started 5 decay times
    early), ``noise`` x its RMS of white sensor noise."""
    y = np.zeros(N)
    for omega, zeta, size in modes:
        lead = int(5 / (zeta * omega) / DT)
        f = size * rng.standard_normal(lead + N)
        q, v = forced(omega, zeta, DT, f)
        y += (f - 2 * zeta * omega * v - omega**2 * q)[lead:]
    return (y + noise * y.std() * rng.standard_normal(N))[None, :]


def _judge(y: np.ndarray, omega: list[float], zeta: list[float], support: list[int]):
    """support.judge on candidates of the one channel's shape (omega_std 1 %
    of omega, zeta_std 0.2 zeta, stable at 87 % of the orders)."""
    k = len(omega)
    w, z = np.array(omega), np.array(zeta)
    return judge(w, z, 0.01 * w, 0.2 * z, np.zeros(k), np.array(support), np.full(k, 0.87),
                 np.ones((1, k), complex), N * DT, False, 8, spectrum=([y], DT))


def test_the_better_supported_of_two_alike_poles_needs_a_peak_too():
    """A 900897-like record (seeds 0-4 of its own generator): one acceleration
    channel of a mode at 37.86 rad/s, zeta 5.2 %, 17 % sensor noise; SSI-like
    candidates 36.33 rad/s (zeta 0.030, 34 stable poles) and 48.47 rad/s
    (zeta 0.0215, 45 poles: 5 half-widths above the mode, on its flank).
    Before the change only 36.33 was asked for a peak, and 48.47 was
    reported; now 48.47 is listed apart for want of a peak and 36.33 kept."""
    for seed in range(5):
        y = _acceleration(np.random.default_rng(seed), [(37.86, 0.052, 1.0)], 0.17)
        verdict = _judge(y, [36.33, 48.47], [0.030, 0.0215], [34, 45])
        assert verdict.keep.tolist() == [True, False], seed
        assert "no spectral peak of its own" in verdict.reasons[1]


def test_two_true_modes_on_one_sensor_stay_two():
    """Two modes on one acceleration channel (12 rad/s, zeta 1 %, and 30
    rad/s, zeta 2 %, the second's force 5 times weaker): both hold a peak,
    so both are reported whichever is the better supported."""
    for seed in range(5):
        y = _acceleration(np.random.default_rng(seed), [(12.0, 0.01, 1.0), (30.0, 0.02, 0.2)], 0.05)
        assert _judge(y, [12.0, 30.0], [0.01, 0.02], [30, 40]).keep.all(), seed
        assert _judge(y, [12.0, 30.0], [0.01, 0.02], [40, 30]).keep.all(), seed


def test_a_better_supported_mode_of_undetermined_damping_is_left_to_the_weak_test():
    """A 900714-like record (seeds 0-4): one acceleration channel of modes at
    7.78, 9.94 and 95.31 rad/s (zeta 0.16, 0.48, 0.8 %), SSI-like candidates
    with 95.65 rad/s the best supported (81 stable poles) at zeta 0.0013 +-
    0.0048, not told from zero: at SSI's damping its band shows too little
    of the true peak (0.34 rad/s off, 6 times too narrow), and the shadow
    test asked of it rejected it in 4 of the 5 records; the weak-candidate
    test, which tries the upper end of its damping interval too, keeps it,
    and so all three are reported."""
    w, z, zs = np.array([7.783, 9.952, 95.65]), np.array([0.0022, 0.0042, 0.0013]), np.array([0.0009, 0.0008, 0.0048])
    for seed in range(5):
        y = _acceleration(np.random.default_rng(seed), [(7.78, 0.0016, 1.0), (9.94, 0.0048, 1.0), (95.31, 0.008, 1.0)],
                          0.05)
        verdict = judge(w, z, np.array([0.013, 0.019, 0.62]), zs, np.zeros(3), np.array([40, 39, 81]),
                        np.array([1.0, 0.92, 0.92]), np.ones((1, 3), complex), N * DT, False, 8, spectrum=([y], DT))
        assert verdict.keep.all(), seed
