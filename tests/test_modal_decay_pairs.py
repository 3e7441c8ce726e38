"""A free decay's reported mode tested as needed beside its neighbours
(identifier/modal/decay_pairs.py; issue 21, fourteenth round).

The record is built here from its closed form: three channels, a slow mode
(1.183 rad/s, ``zeta`` 0.0375) and a heavily damped one (89.66 rad/s,
0.0297: its decay time is 17 samples of 0.0215 s) in 2,646 samples, noise 1
% of each channel's RMS. The reported poles are those SSI gave for tuning
seed 1,003,401 of ``benchmarks/modal_fuzz.py --kind unseen``, whose record
is of this kind: the heavily damped mode as two poles, 98.49 rad/s
(``zeta`` 0.0055) and 142.42 rad/s (0.0069), both lightly damped, tens of
half-widths apart. One pole fitted freely explains both (the record has no
mode at 142.42 rad/s): the one nearer the one-pole fit is kept. With a true
third mode at 142.42 rad/s the same test keeps all three."""
from __future__ import annotations

from pathlib import Path

import modal_fuzz
import numpy as np
import pytest

from structbench.identifier.io.traces import Channel, Trace
from structbench.identifier.modal import decay_pairs
from structbench.identifier.modal.close_pairs.free_decay_fit import basis, omega_zeta
from structbench.identifier.modal.ml_fit import fit_poles, noise_levels
from structbench.identifier.modal.refine import PoleRefinement

DT, N = 0.0215, 2646
SLOW, BROAD, THIRD = (1.183, 0.0375), (89.66, 0.0297), (142.42, 0.0069)
REPORTED = np.array([1.1834, 98.49, 142.42]), np.array([0.0377, 0.0055, 0.0069])  # SSI's, seed 1,003,401


def _record(third: float, seed: int) -> np.ndarray:
    """Three channels (3, N): the slow and heavily damped modes, and ``third``
    times a mode at ``THIRD``; white noise of 1 % of each channel's RMS."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    shapes = np.array([[1.0, 0.6, -0.8], [0.5, -1.0, 0.7], [0.3, 0.9, 0.4]])
    y = np.zeros((3, N))
    for (w, z), phi, size in zip((SLOW, BROAD, THIRD), shapes.T, (1.0, 1.0, third)):
        y += size * phi[:, None] * (np.exp(-z * w * t) * np.cos(w * np.sqrt(1 - z * z) * t + 0.3))[None, :]
    return y + 0.01 * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(y.shape)


def _screen(y: np.ndarray) -> tuple[PoleRefinement, list[dict]]:
    channels = {f"displacement_{i + 1}_w": Channel(f"displacement_{i + 1}_w", row, "displacement", "m", i + 1, "w",
                                                   np.full(3, np.nan), 0.0) for i, row in enumerate(y)}
    trace = Trace(Path("pair.h5"), np.arange(N) * DT, DT, DT, channels, {},
                  {"test": "pair", "repetition": 0, "structure": "s"}, {"kind": "initial"})
    w, z = REPORTED  # labelled a free response: unlabelled, its slow mode's 2.5 decay times show in no channel's F test
    ml = PoleRefinement(w, z, np.full(3, 1e-3), np.full(3, 1e-4), np.zeros(3, bool), np.arange(3),
                        {"applied": False})
    return decay_pairs.screen([trace], [y], DT, ml, [], "auto")


@pytest.mark.parametrize("seed", range(3))
def test_one_heavily_damped_mode_fitted_with_two_poles_keeps_one(seed):
    ml, gone = _screen(_record(0.0, seed))
    assert ml.omega.tolist() == [1.1834, 98.49]  # 98.49 is nearer the one-pole fit (the true 89.66) than 142.42
    assert [g["omega"] for g in gone] == [142.42]
    assert "free-decay pair test" in gone[0]["reason"]


def test_the_one_pole_fit_is_the_true_mode_nearer_the_kept_pole():
    """The reference for which pole is kept: one pole fitted from 98.49 rad/s
    (1.183 held) lands on the closed form's 89.66 rad/s, ``zeta`` 0.0297."""
    y = _record(0.0, 0)
    t = np.arange(N) * DT
    slow = np.array([complex(-SLOW[0] * SLOW[1], SLOW[0])])
    z = y.T / noise_levels(t, y.T, basis(t, np.r_[slow, -0.5 + 98.49j]))
    start = np.array([complex(-0.0055 * 98.49, 98.49)])
    pole, cov, ok, _ = fit_poles([t], [z], slow, start, np.array([-200.0, 10.0]), np.array([-1e-6, np.pi / DT]))
    w, zeta, _, _ = omega_zeta(pole, cov)
    assert ok and abs(w[0] - BROAD[0]) < 0.005 * BROAD[0] and abs(zeta[0] - BROAD[1]) < 0.1 * BROAD[1]
    assert abs(pole[0] - complex(-0.0055 * 98.49, 98.49)) < abs(pole[0] - complex(-0.0069 * 142.42, 142.42))


@pytest.mark.parametrize("seed", range(3))
def test_a_true_third_mode_is_kept(seed):
    ml, gone = _screen(_record(0.2, seed))  # its energy 4 % of the heavily damped mode's, far above the noise
    assert ml.omega.size == 3 and not gone


@pytest.mark.parametrize("seed, lost, found", [(1_003_401, 142.42, 1), (1_003_257, 109.75, 3)])
def test_the_tuning_seeds_second_pole_of_a_broad_mode_is_rejected(seed, lost, found):
    row = modal_fuzz.unseen(seed)  # 1,003,257's 90.86 rad/s, missed before, found by the residual search since
    # the fifteenth round (identifier/modal/decay_search.py)
    assert row["invented"] == 0 and row["found"] == found
    result = modal_fuzz.modal.identify([modal_fuzz.unseen_trace(modal_fuzz.unseen_record(seed))],
                                       **modal_fuzz.OPTIONS)
    hit = [r for r in result.details["rejected"] if abs(r["omega"] - lost) < 0.01]
    assert len(hit) == 1 and "free-decay pair test" in hit[0]["reason"]
