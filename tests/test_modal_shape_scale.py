"""The shadow and pair tests of identifier/modal/peak_pairs.py compare
shapes in unit-RMS channels: with sensors of mixed quantities one channel
of a large quantity (an acceleration beside displacements) made unlike
shapes score MAC near 1, and the pair test took two modes for one; and of
two alike candidates in one band both must show a spectral peak, the
better supported one too (issue 21, fifth round: tuning seed 400043
reported a narrow pole beside a true mode of its shape)."""
from __future__ import annotations

import numpy as np
from test_modal_peak_pairs import DT, N, SHAPE, _mode

from structbench.identifier.modal.support import judge
from structbench.models.mac import mac

SCALE = np.array([1.0, 1.0, 1.0, 1000.0])  # channel RMS: three displacements and an acceleration
A = np.array([1.0, -0.6, 0.3, 0.5])  # two modes' shapes in unit-RMS channels (MAC 0.04)
B = np.array([0.2, 0.7, 0.9, 0.5])


def test_unlike_shapes_on_mixed_quantities_are_no_pair():
    """Random responses (seeds 11, 12) of two modes of shapes A and B (10
    and 10.5 rad/s, zeta 4 %: 1.25 half-widths apart, resolved for the
    duplicate rule with omega_std 0.05; MAC 0.04 in unit-RMS channels)
    read by three displacements and an acceleration 1000 times larger (MAC
    over 0.99 in physical units): the pair test took them for one broad
    mode and dropped the second (both seeds); compared in unit-RMS
    channels they are no pair and both stay."""
    shapes = (np.column_stack([A, B]) * SCALE[:, None]).astype(complex)
    assert mac(shapes, shapes)[0, 1] > 0.99 and mac(shapes / SCALE[:, None], shapes / SCALE[:, None])[0, 1] < 0.05
    for seed in (11, 12):
        rng = np.random.default_rng(seed)
        y = (np.outer(A, _mode(rng, 10.0, 0.04)) + np.outer(B, _mode(rng, 10.5, 0.04))) * SCALE[:, None]
        y += 0.05 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
        verdict = judge(np.array([10.0, 10.5]), np.array([0.04, 0.04]), np.full(2, 0.05), np.full(2, 0.005),
                        np.zeros(2), np.array([30, 20]), np.full(2, 0.8), shapes, N * DT, False, 8,
                        spectrum=([y], DT))
        assert verdict.keep.tolist() == [True, True], verdict.reasons


def test_a_better_supported_pole_beside_a_true_mode_of_its_shape_needs_its_own_peak():
    """One mode (10 rad/s, zeta 2 %: band +-2 rad/s) and a narrow pole of
    its shape at 11.5 rad/s (zeta 0.2 %, 7.5 half-widths away: no pair),
    better supported: only the weaker, true one was tested for a peak, and
    the pole was reported; now both are tested, the pole is rejected and
    the mode stays."""
    rng = np.random.default_rng(13)
    y = np.outer(SHAPE, _mode(rng, 10.0, 0.02))
    y += 0.05 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    shapes = np.column_stack([SHAPE, SHAPE * 1.01]).astype(complex)
    verdict = judge(np.array([10.0, 11.5]), np.array([0.02, 0.002]), np.full(2, 0.02), np.full(2, 0.002),
                    np.zeros(2), np.array([20, 30]), np.full(2, 0.8), shapes, N * DT, False, 8,
                    spectrum=([y], DT))
    assert verdict.keep.tolist() == [True, False], verdict.reasons
    assert "no spectral peak of its own" in verdict.reasons[1]
