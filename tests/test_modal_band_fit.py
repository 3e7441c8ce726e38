"""A stationary record's reported poles against their bands' one-term
Whittle fits (identifier/modal/band_fit.py): the likelihood ratio's null
law, and a biased SSI pole's errors widened."""
from __future__ import annotations

import modal_fuzz
import numpy as np
from modal_synth import forced
from scipy.stats import chi2

from structbench.identifier import modal
from structbench.identifier.modal import band_fit, peak_test


def _response(seed: int, omega: float, zeta: float, dt: float, n: int) -> np.ndarray:
    """(1, n): one mode's displacement under white force, 2,000 samples run
    in and dropped, plus 5 % white sensor noise."""
    rng = np.random.default_rng(seed)
    q, _ = forced(omega, zeta, dt, rng.standard_normal(n + 2000))
    q = q[2000:]
    return (q + 0.05 * q.std() * rng.standard_normal(n))[None, :]


def test_at_the_true_pole_the_likelihood_ratio_follows_chi2_2() -> None:
    """200 seeds of one mode (10 rad/s, zeta 0.02, 4,096 samples at 0.05
    s: 326 periods, 41 decay times), the band fit's ``LR`` against the
    true pole: over ``chi2_2``'s 1 % point in at most 6 (binomial(200,
    0.01): P(> 6) = 0.005), and its median near ``chi2_2``'s (1.39)."""
    omega, zeta, dt, n = 10.0, 0.02, 0.05, 4096
    lines = 2 * np.pi * np.arange(n // 2 + 1) / (n * dt)
    lr = np.array([band_fit.band_pole(peak_test.summed_periodogram([_response(s, omega, zeta, dt, n)]), lines,
                                      n * dt, np.array([omega]), np.array([zeta]), 0)[2] for s in range(200)])
    assert np.sum(lr > chi2.isf(band_fit.ALPHA, 2)) <= 6
    assert 0.8 < np.median(lr) < 2.2


def test_a_biased_broad_pole_gets_errors_that_reach_its_mode() -> None:
    """Tuning seed 1,004,835 (looked at after the check of 34e0f1d): one
    acceleration sensor, 40,000 samples; true mode 16.92 rad/s, zeta 0.083,
    that SSI reports at 17.98 +- 0.063 rad/s, zeta 0.020 +- 0.0045 (6 %
    and 17 standard errors off: invented). The band fit puts it at 16.7
    rad/s, zeta 0.08; the widened interval reaches the true mode, the
    value stays SSI's, and the three other modes of the first pass (1.84,
    4.62, 21.91 rad/s) are unchanged, as are the two the short-lag pass adds
    (32.95 and 54.55 rad/s, found at 33.13 and 54.87 within their
    intervals)."""
    trace = modal_fuzz.unseen_trace(modal_fuzz.unseen_record(1_004_835))
    result = modal.identify([trace])
    w, se = np.array(result.omega), np.array(result.omega_std)
    z, sz = np.array(result.damping), np.array(result.damping_std)
    i = int(np.argmin(np.abs(w - 17.98)))
    assert abs(w[i] - 17.981) < 0.005 and "widened" in result.details["band_fit"][i]
    assert abs(w[i] - 16.916) <= 1.96 * se[i] and abs(z[i] - 0.083) <= 1.96 * sz[i]
    assert se[i] > 10 * 0.063
    others = [j for j in range(w.size) if j != i and not result.details["short_lags"]["added"][j]]
    assert [result.details["band_fit"][j] for j in range(w.size) if j != i] == [""] * 5
    assert np.all(se[others] < 0.03) and len(others) == 3
    assert len(modal_fuzz.match(w, se, modal_fuzz.unseen_record(1_004_835)["omega"])) == w.size


def test_the_band_fits_curvature_gives_the_scatter_of_its_pole() -> None:
    """The band fit's covariance (``band_fit.curvature``) against the
    scatter of its pole over 100 seeds of one mode (10 rad/s, zeta 0.02,
    4,096 samples at 0.05 s): the median stated standard error of omega
    and of zeta within 25 % of the seeds' standard deviation (whose own
    sampling error is about 7 %)."""
    omega, zeta, dt, n = 10.0, 0.02, 0.05, 4096
    lines = 2 * np.pi * np.arange(n // 2 + 1) / (n * dt)
    fits = [band_fit.band_pole(peak_test.summed_periodogram([_response(s, omega, zeta, dt, n)]), lines,
                               n * dt, np.array([omega]), np.array([zeta]), 0) for s in range(100)]
    poles = np.array([f[:2] for f in fits])
    stated = np.median(np.sqrt([np.diag(f[3]) for f in fits]), axis=0)
    assert np.all(np.abs(stated / poles.std(axis=0) - 1) < 0.25)


def test_a_biased_broad_pole_under_move_errors_is_widened_against_both_fits_errors() -> None:
    """Held-out profile seed 1,011,930 (fresh for the seventeenth round's
    check, a tuning seed since): 13 sensors of three quantities, 22,221
    samples; SSI reports the true 2.870 rad/s, zeta 0.072, at 3.303 +-
    0.076, zeta 0.097 (invented: 15 % and 5.7 errors off). The band fit puts
    the pole at 3.008, 3.9 SSI errors away (under ``MOVE``) but 11.9 in
    chi2_2 against both fits' errors: the errors widen to reach the true
    mode, the value stays SSI's, the five other modes are unchanged."""
    result = modal.identify([modal_fuzz.unseen_trace(modal_fuzz.unseen_record(1_011_930))])
    w, se = np.array(result.omega), np.array(result.omega_std)
    i = int(np.argmin(np.abs(w - 3.303)))
    assert abs(w[i] - 3.303) < 0.001 and "widened" in result.details["band_fit"][i]
    assert abs(w[i] - 2.870) <= 1.96 * se[i] and se[i] > 3 * 0.076
    assert [result.details["band_fit"][j] for j in range(w.size) if j != i] == [""] * 5


def test_a_widened_mode_no_longer_resolved_from_a_more_coherent_one_is_dropped(monkeypatch) -> None:
    """Held-out profile seed 1,022,207 (fresh for the twentieth round's
    check, a tuning seed since): six sensors, 40,000 samples; true modes
    1.196 and 41.341 rad/s (zeta 0.054). The first pass reports the broad
    mode twice: 41.18 rad/s (coherence 0.82) and 39.81 (coherence 0.04,
    zeta 0.008, kept for being stable at most model orders), resolved from
    each other at its first errors. The band fit of 39.81 puts its pole on
    41.2 and widens its error to 1.4 rad/s: at its final errors the record
    no longer resolves the two, and it is dropped as the other's
    duplicate. Without the check after the widening it is reported (and
    matches no true mode)."""
    trace = modal_fuzz.unseen_trace(modal_fuzz.unseen_record(1_022_207))
    truth = modal_fuzz.unseen_record(1_022_207)["omega"]
    result = modal.identify([trace])
    w, se = np.array(result.omega), np.array(result.omega_std)
    assert w.size == 2 and len(modal_fuzz.match(w, se, truth)) == 2
    dropped = [r for r in result.details["rejected"] if abs(r["omega"] - 39.81) < 0.01]
    assert len(dropped) == 1 and dropped[0]["reason"].startswith("duplicate of the mode at 41.1")
    monkeypatch.setattr(band_fit, "less_coherent_after",
                        lambda omega, *args: (np.ones(omega.size, dtype=bool), []))
    w, se = np.array((result := modal.identify([trace])).omega), np.array(result.omega_std)
    assert w.size == 3 and len(modal_fuzz.match(w, se, truth)) == 2
    assert "widened" in result.details["band_fit"][int(np.argmin(np.abs(w - 39.81)))]
