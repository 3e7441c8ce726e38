"""A free decay's modes tested against the sensor noise again at their
refined poles (identifier/modal/decay_snr.py, ``retest``; issue 21, eighth
round). The record is built here: a strong, heavily damped mode (34.07
rad/s, ``zeta`` 0.0801) beside a slow one (4.585 rad/s, 0.0159) on three
channels (acceleration-, velocity- and displacement-like, noise 13 %, 0.2 %
and 0.3 % of their RMS). SSI's pole of the strong mode a little off
(34.074 rad/s, 0.08005) leaves a misfit that a lightly damped noise pole at
29.53 rad/s takes up above the noise's threshold (chi-square(6) at 0.01 over
the record's n / 2 frequencies, 39.0); at the true poles (the refinement's)
it holds 4.2. A lightly damped pole on the strong mode's flank (36.59 rad/s)
is within its half-power band, but their damped exponentials correlate at
0.036 only (the record resolves them): the noise test applies to it."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from structbench.identifier.modal.decay_snr import correlation, retest, screen, statistics
from structbench.identifier.modal.refine import PoleRefinement
from structbench.identifier.modal.support import Verdict

DT, N = 0.03, 28000
SLOW, STRONG, FLANK, NOISE_POLE = (4.585, 0.0159), (34.07, 0.0801), (36.585, 4e-4), (29.53, 0.0009)


def _record(weak: float = 0.0, seed: int = 0) -> np.ndarray:
    """Three channels (3, N): the slow and strong modes, and ``weak`` times a
    lightly damped mode at ``FLANK``."""
    t = np.arange(N) * DT
    w, z = np.array([SLOW[0], STRONG[0], FLANK[0]]), np.array([SLOW[1], STRONG[1], FLANK[1]])
    q = np.exp(-np.outer(z * w, t)) * np.cos(np.outer(w * np.sqrt(1 - z**2), t) + np.array([[0.3], [1.1], [0.0]]))
    amplitude = np.array([[1.0, 0.6, weak], [0.5, -1.0, weak], [-0.8, 0.3, weak]]) * np.array([w**2, w, np.ones(3)])
    clean = amplitude @ q
    noise = np.array([0.13, 0.002, 0.003]) * np.sqrt(np.mean(clean**2, axis=1))
    return clean + noise[:, None] * np.random.default_rng(seed).standard_normal(clean.shape)


def _refined(omega: list[float], zeta: list[float]) -> PoleRefinement:
    k = len(omega)
    return PoleRefinement(np.array(omega), np.array(zeta), np.full(k, 1e-4), np.full(k, 1e-5), np.ones(k, bool),
                          np.arange(k), {"applied": True})


def test_correlation_is_the_sampled_exponentials():
    """Against the sampled exponentials' inner products (dt 0.03 s, 840 s):
    the flank pair 0.0356, two poles of equal ``sigma`` 2 ``sigma`` apart
    1 / sqrt 2 (the bandwidth rule's edge), two undamped poles ``2 pi / T``
    apart 0."""
    t = np.arange(N) * DT
    for w, z, expected in (([STRONG[0], FLANK[0]], [STRONG[1], 4e-5], 0.0356), ([10.0, 10.2], [0.01, 0.01], 0.707),
                           ([10.0, 10.0 + 2 * np.pi / (N * DT)], [0.0, 0.0], 0.0)):
        lam = -np.array(z) * np.array(w) + 1j * np.array(w)
        e = np.exp(np.outer(t, lam))
        gram = e.conj().T @ e
        sampled = abs(gram[0, 1]) / np.sqrt(abs(gram[0, 0] * gram[1, 1]))
        assert abs(correlation(np.array(w), np.array(z), N * DT)[0, 1] - sampled) < 0.002
        assert abs(sampled - expected) < 0.005  # the continuous closed form; sampling adds under 0.004


def test_a_strong_modes_misfit_at_ssis_pole_passes_a_noise_pole_the_refined_poles_refuse():
    """SSI-like poles: the noise pole's statistic is over the threshold
    and the flank pole is crowded (left to pair tests a single record does
    not have): both kept by ``screen``. At the refined poles ``retest``
    lists both apart, keeps the two modes and their arrays in step."""
    y = [_record()]
    ssi_w = np.array([SLOW[0], NOISE_POLE[0], 34.074, 36.59])
    ssi_z = np.array([SLOW[1], NOISE_POLE[1], 0.08005, 1.1e-4])
    value, needed = statistics(y, DT, ssi_w, ssi_z)
    assert value[1] > needed[1] > 38
    assert screen(y, DT, ssi_w, ssi_z, Verdict(np.ones(4, bool), [""] * 4), []).keep.all()
    ml = _refined([SLOW[0], NOISE_POLE[0], STRONG[0], 36.59], [SLOW[1], NOISE_POLE[1], STRONG[1], 1.1e-4])
    assert statistics(y, DT, ml.omega, ml.zeta)[0][1] < 10
    kept, gone = retest(y, DT, ml, [])
    assert kept.omega.tolist() == [SLOW[0], STRONG[0]]
    assert kept.source.tolist() == [0, 2] and kept.applied.tolist() == [True, True] and kept.zeta_std.size == 2
    assert [g["omega"] for g in gone] == [NOISE_POLE[0], 36.59]
    assert all("at the refined poles" in g["reason"] for g in gone)


def test_a_weak_true_mode_on_the_flank_stays_and_nothing_changes_without_refinement():
    """A true lightly damped mode at the flank (statistic about 500) is kept
    by ``retest``; an unrefined run (``applied`` False) is returned as is."""
    y = [_record(weak=2e-5)]
    ml = _refined([SLOW[0], STRONG[0], FLANK[0]], [SLOW[1], STRONG[1], FLANK[1]])
    value, needed = statistics(y, DT, ml.omega, ml.zeta)
    assert 200 < value[2] < 2000
    kept, gone = retest(y, DT, ml, [])
    assert kept.omega.size == 3 and gone == []
    unrefined = PoleRefinement(ml.omega, ml.zeta, ml.omega_std, ml.zeta_std, np.zeros(3, bool), np.arange(3),
                               {"applied": False})
    assert retest([_record()], DT, unrefined, [])[0] is unrefined


def _pair_record(weak: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three channels (3, 27000 at 0.028 s): 2.5145 rad/s (``zeta`` 0.0011),
    11.27 (0.0062) and ``weak`` times a mode at 11.39 (0.0165), whose damped
    exponentials correlate with 11.27's at 0.81; and the three poles."""
    dt, n = 0.028, 27000
    t = np.arange(n) * dt
    w, z = np.array([2.5145, 11.27, 11.39]), np.array([0.0011, 0.0062, 0.0165])
    q = np.exp(-np.outer(z * w, t)) * np.cos(np.outer(w * np.sqrt(1 - z**2), t) + np.array([[0.2], [0.9], [0.4]]))
    clean = np.array([[1.0, 0.5, weak], [0.7, -0.4, -weak], [-0.3, 0.8, weak]]) @ q
    noise = np.array([0.03, 0.19, 0.02]) * np.sqrt(np.mean(clean**2, axis=1))
    return clean + noise[:, None] * np.random.default_rng(seed).standard_normal(clean.shape), w, z


def test_a_pole_in_a_resolved_neighbours_band_is_tested_at_that_bands_look_elsewhere_factor():
    """A pole at 11.39 rad/s (``zeta`` 0.0165) within the band of a mode at
    11.27 (0.0062), correlating at 0.81 (over 1 / sqrt 2) and 0.12 rad/s
    apart (over ``2 pi / T`` = 0.0083): no longer left untested. Its
    threshold is chi-square(6)'s at 0.01 over the ``1 + 2 (sigma_a +
    sigma_b) T / 2 pi`` = 63 frequencies of their band (26.8), not the
    record's 13,500 (39.0). Noise alone there (statistic 9.4): listed
    apart; a true mode there (statistic about 300): kept."""
    y, w, z = _pair_record(0.0)
    length = 27000 * 0.028
    assert correlation(w[1:], z[1:], length)[0, 1] == pytest.approx(0.806, abs=0.002)
    needed = chi2.isf(0.01 / (1 + 2 * (z[1] * w[1] + z[2] * w[2]) * length / (2 * np.pi)), 6)
    ml = PoleRefinement(w, z, np.full(3, 1e-4), np.full(3, 1e-5), np.ones(3, bool), np.arange(3), {"applied": True})
    kept, gone = retest([y], 0.028, ml, [])
    assert kept.omega.tolist() == [2.5145, 11.27]
    assert f"sensor noise's {needed:.3g}" in gone[0]["reason"] and needed == pytest.approx(26.8, abs=0.1)
    y, *_ = _pair_record(0.01)
    assert 200 < statistics([y], 0.028, w, z)[0][2] < 500
    assert retest([y], 0.028, ml, [])[0].omega.size == 3


def test_a_noise_free_record_gives_an_infinite_statistic_without_a_warning():
    """A channel the poles fit exactly (no noise, residual 0,
    amplitude 1000): each mode's statistic is inf (kept), and no overflow
    warning reaches the user."""
    t = np.arange(2000) * DT
    y = (1e3 * np.exp(-STRONG[0] * STRONG[1] * t) * np.cos(STRONG[0] * np.sqrt(1 - STRONG[1] ** 2) * t))[None, :]
    with np.errstate(all="raise"):
        value, needed = statistics([y], DT, np.array([STRONG[0]]), np.array([STRONG[1]]))
    assert value[0] == np.inf and np.isfinite(needed[0])
