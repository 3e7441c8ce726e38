"""The shadow and pair tests of identifier/modal/peak_pairs.py compare
shapes in unit-RMS channels: with sensors of mixed quantities one channel
of a large quantity (an acceleration beside displacements) made unlike
shapes score MAC near 1, and the pair test took two modes for one; and of
two alike candidates in one band both must show a spectral peak, the
better supported one too (issue 21, fifth round: tuning seed 400043
reported a narrow pole beside a true mode of its shape). The duplicate
rule (identifier/modal/support.py) takes shapes alike in either units
(issue 21, tenth round: tuning seed 800695's free decay)."""
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


def test_a_free_decays_duplicate_is_told_by_its_shape_in_unit_rms_channels():
    """A free decay's one mode (17.7 rad/s, zeta 2.5 %) seen twice by SSI,
    0.001 rad/s apart (unresolved; as tuning seed 800695's 17.698 / 17.699
    on 22 sensors of mixed quantities), the copies differing only in an
    acceleration channel whose RMS (1000, another mode's) dwarfs this
    mode's part of it: MAC 0.998 in unit-RMS channels but 0.0006 in
    physical units, where the duplicate rule (MAC over 0.8) kept both; in
    unit-RMS channels the weaker copy is dropped."""
    rng = np.random.default_rng(14)
    t = np.arange(20000) * 0.01
    y = np.outer(np.r_[A[:3], 0.0], np.exp(-0.025 * 17.7 * t) * np.cos(17.7 * t))
    y[3] = 1000.0 * rng.standard_normal(t.size)
    y += 0.01 * rng.standard_normal(y.shape)
    shapes = np.column_stack([np.r_[A[:3], 50.0], np.r_[A[:3], 0.0]]).astype(complex)
    unit = shapes / y.std(axis=1)[:, None]
    assert mac(shapes, shapes)[0, 1] < 0.01 and mac(unit, unit)[0, 1] > 0.99
    args = (np.array([17.6988, 17.6978]), np.array([0.02526, 0.02525]), np.array([0.0026, 0.013]),
            np.array([0.00025, 0.00027]), np.zeros(2), np.array([14, 13]), np.array([0.35, 0.33]), shapes,
            200.0, True, 8)
    assert judge(*args).keep.tolist() == [True, True]
    verdict = judge(*args, spectrum=([y], 0.01))
    assert verdict.keep.tolist() == [True, False], verdict.reasons
    assert "duplicate" in verdict.reasons[1]
