"""Modes of a free decay that SSI missed, found in the residual
(identifier/modal/decay_search.py; issue 21 item 3, fifteenth round).

The first record is built here from its closed form, with the values of
tuning seed 1,000,005 of ``benchmarks/modal_fuzz.py --kind unseen`` (two
acceleration channels, 31,664 samples of 0.01871 s): six modes, among them
a weak, heavily damped one at 1.5641 rad/s (``zeta`` 0.0964, amplitude 16
against white noise of 18 and 57 and modes of amplitude 190-92,500 on the
channels), which SSI does not report (no candidate) and the search finds.
The second gives the search the true poles of a closed-form decay (its
residual is white noise) and a spurious candidate: a mode is added there
with chance at most ``ALPHA`` per record."""
from __future__ import annotations

from pathlib import Path

import modal_fuzz
import numpy as np
import pytest

from structbench.identifier import modal
from structbench.identifier.io.traces import Channel, Trace
from structbench.identifier.modal import decay_search
from structbench.identifier.modal.refine import PoleRefinement
from structbench.identifier.modal.ssi.covariance import decay_shown, is_free_decay

DT, N = 0.0187104959903441, 31664
OMEGA = np.array([1.1758131, 1.5641039, 4.3715638, 6.5788637, 76.228565, 79.891953])  # rad/s, seed 1,000,005
ZETA = np.array([0.0062807, 0.0963506, 0.0242412, 0.0125765, 0.0011311, 0.0011390])
AMPLITUDE = np.array([2.2032669, 16.447751, 186.94486, 155.25427, 17697.600, 92514.119])  # m/s^2
PHASE = np.array([-0.4249158, -2.6601097, 0.9398732, 2.8557677, 1.3127466, 0.7020431])  # rad
SHAPES = np.array([[0.0418, 0.9666, -0.5665, 0.9866, 0.8724, -0.3586],
                   [0.9991, 0.2564, 0.8240, 0.1631, 0.4887, -0.9335]])
NOISE = np.array([18.231846, 57.468142])  # m/s^2 per channel
WEAK = 1


def _decay(omega: np.ndarray, zeta: np.ndarray, amplitude: np.ndarray, phase: np.ndarray, shapes: np.ndarray,
           noise: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``y_c(t) = sum_j shapes[c, j] a_j e^(-zeta_j omega_j t) cos(omega_d,j t + phase_j)`` plus white noise (c, n)."""
    t = np.arange(n) * DT
    wave = amplitude[:, None] * np.exp(-(zeta * omega)[:, None] * t) * np.cos(
        (omega * np.sqrt(1 - zeta**2))[:, None] * t + phase[:, None])
    return shapes @ wave + noise[:, None] * np.random.default_rng(seed).standard_normal((shapes.shape[0], n))


def _trace(y: np.ndarray, excitation: dict | None = None) -> Trace:
    channels = {f"acceleration_{i + 1}_w": Channel(f"acceleration_{i + 1}_w", row, "acceleration", "m/s^2", i + 1,
                                                   "w", np.full(3, np.nan), 0.0) for i, row in enumerate(y)}
    return Trace(Path("decay.h5"), np.arange(y.shape[1]) * DT, DT, DT, channels, {},
                 {"test": "decay", "repetition": 0, "structure": "s"}, excitation or {})


@pytest.mark.parametrize("seed", range(3))
def test_a_weak_heavily_damped_mode_ssi_misses_is_found_in_the_residual(seed, monkeypatch):
    trace = _trace(_decay(OMEGA, ZETA, AMPLITUDE, PHASE, SHAPES, NOISE, N, seed))
    result = modal.identify([trace])
    w, se = np.array(result.omega), np.array(result.omega_std)
    z, sz = np.array(result.damping), np.array(result.damping_std)
    hit = np.flatnonzero(np.abs(w - OMEGA[WEAK]) < 0.05 * OMEGA[WEAK])
    assert hit.size == 1, w
    i = hit[0]
    assert abs(w[i] - OMEGA[WEAK]) < 3 * se[i] and abs(z[i] - ZETA[WEAK]) < 3 * sz[i]
    assert [round(a["omega"], 3) for a in result.details["ml_refinement"]["search"]] == [round(w[i], 3)]
    assert np.isfinite(result.mode_shapes[i]).all()
    monkeypatch.setattr(modal.decay_search, "search", lambda traces, records, dt, ml, rejected, refine, edges: (ml, []))
    without = np.array(modal.identify([trace]).omega)  # SSI and the earlier steps alone miss it
    assert not np.any(np.abs(without - OMEGA[WEAK]) < 0.05 * OMEGA[WEAK])
    assert without.size == w.size - 1


def test_a_spurious_candidate_on_a_white_residual_is_added_at_most_at_the_level(monkeypatch):
    """The search given a closed-form decay's true poles (two modes, three
    channels, 2,000 samples: its residual is white noise) and a spurious
    nuisance pole at a random frequency in 15-60 rad/s (``zeta`` 0.02), which
    the F test must judge. Over 300 noise seeds (0-299; frequencies from
    seeds 10,000-10,299) a mode is added with chance at most ``ALPHA``
    (1e-4) per record: 0.03 expected, at most 1 allowed (binomial tail
    4e-4). Every record reaches the F test (labelled a free response from
    initial conditions: with 2 decay times of its slower mode no channel's
    F test shows the decay, so unlabelled it would not be searched)."""
    omega, zeta = np.array([3.0, 11.0]), np.array([0.02, 0.03])
    shapes = np.array([[1.0, 0.5], [0.6, -1.0], [-0.8, 0.7]])
    tested = []
    pvalues = decay_search.pvalues
    monkeypatch.setattr(decay_search, "pvalues", lambda *a: tested.append(1) or pvalues(*a))
    added = 0
    for seed in range(300):
        y = _decay(omega, zeta, np.array([10.0, 5.0]), np.array([0.3, 1.1]), shapes, np.full(3, 0.05), 2000, seed)
        w = np.random.default_rng(10_000 + seed).uniform(15, 60)
        ml = PoleRefinement(omega, zeta, np.full(2, 1e-3), np.full(2, 1e-4), np.ones(2, bool), np.arange(2),
                            {"applied": True}, np.array([complex(-0.02 * w, w)]))
        out, gone = decay_search.search([_trace(y, {"kind": "initial"})], [y], DT, ml, [], "auto")
        added += out.omega.size - 2 + len(gone)
    assert len(tested) == 300 and added <= 1


def test_a_random_response_taken_for_a_decay_by_its_pooled_ratio_is_not_searched() -> None:
    """Tuning seed 1,001,037 (random response, 3 sensors, 9,014 samples;
    its strong mode at 4.047 rad/s, ``zeta`` 0.0016, holds 1.1 decay times
    of the record): the first tenth's mean square is 10.1 times the last's,
    so :func:`is_free_decay` takes it for a decay, but no channel's F test
    (:func:`decaying_channel`) does. The search found 3.835 and 3.947 rad/s
    in its residual (the ongoing response around the mode, p 0), both
    invented; now the record is neither refined nor searched (the fits
    that assume a free response) and the mode stays alone."""
    rec = modal_fuzz.unseen_record(1_001_037)
    trace = modal_fuzz.unseen_trace(rec)
    assert is_free_decay(rec["y"]) and not decay_shown(rec["y"])
    result = modal.identify([trace])
    assert "search" not in result.details["ml_refinement"] and not result.details["ml_refinement"]["applied"]
    assert not any(abs(w - 3.835) < 0.02 or abs(w - 3.947) < 0.02 for w in result.omega)
    assert any(abs(w - 4.047) < 0.01 for w in result.omega)


def test_a_short_decay_with_no_reported_mode_is_searched_from_an_empty_model(monkeypatch):
    """One channel, 164 samples of 0.059 s, one mode (33.5 rad/s, ``zeta``
    0.051, 52 periods and 16 decay times; the values of tuning seed
    1,012,232): the block rows the record allows give SSI the single order
    2, so no pole is stable and nothing is reported. The search from an
    empty model (:func:`decay_search.alone`: the candidate against offset and
    drift alone) finds it, its interval covering the closed form's pole."""
    dt, n = 0.0590127297, 164
    t = np.arange(n) * dt
    omega, zeta = 33.51183, 0.05100
    found = []
    for seed in range(3):
        y = 100 * np.exp(-zeta * omega * t) * np.cos(omega * np.sqrt(1 - zeta**2) * t + 0.4) \
            + np.random.default_rng(seed).standard_normal(n)
        trace = Trace(Path("decay.h5"), t, dt, dt, {"acceleration_1_w": Channel(
            "acceleration_1_w", y, "acceleration", "m/s^2", 1, "w", np.full(3, np.nan), 0.0)}, {},
            {"test": "decay", "repetition": 0, "structure": "s"}, {"kind": "impulse"})
        result = modal.identify([trace])
        assert len(result.omega) == 1
        assert abs(result.omega[0] - omega) < 3 * result.omega_std[0] and \
            abs(result.damping[0] - zeta) < 3 * result.damping_std[0]
        found.append(result.details["ml_refinement"]["search"][0]["p"])
        with monkeypatch.context() as patched:
            patched.setattr(decay_search, "alone", lambda *a: np.full(len(a[3]), np.nan))
            assert modal.identify([trace]).omega == []  # the earlier steps alone report nothing
    assert max(found) < 1e-20


def test_noise_alone_adds_a_mode_from_the_empty_model_at_most_at_the_level(monkeypatch):
    """White noise of one or two channels (300-2,000 samples, labelled a free
    response from initial conditions), no mode in it, and a rejected SSI
    candidate at a random frequency in 15-60 rad/s (``zeta`` 0.02) that the
    F test must judge (seeds 20,000-20,199). The look-elsewhere-corrected
    p-values of :func:`decay_search.alone` must be at least uniform: at
    levels 0.1 and 0.5 the share under the level at most the level plus
    three binomial standard deviations (33 and 121 of 200; without the
    ``n / 2`` factor nearly all 200 fall under 0.1), and no mode is added."""
    ps: list[float] = []
    alone = decay_search.alone
    monkeypatch.setattr(decay_search, "alone", lambda *a: (p := alone(*a), ps.extend(p.tolist()))[0])
    added = 0
    for seed in range(200):
        rng = np.random.default_rng(20_000 + seed)
        y = rng.standard_normal((1 + seed % 2, int(rng.integers(300, 2001))))
        ml = PoleRefinement(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, bool),
                            np.zeros(0, int), {"applied": False}, np.zeros(0, complex))
        spurious = [{"omega": rng.uniform(15, 60), "zeta": 0.02, "reason": "stable at"}]
        out, _ = decay_search.search([_trace(y, {"kind": "initial"})], [y], DT, ml, spurious, "auto")
        added += out.omega.size
    p = np.array(ps)
    assert p.size == 200 and np.isfinite(p).all()
    assert np.sum(p < 0.1) <= 33 and np.sum(p < 0.5) <= 121 and added == 0
