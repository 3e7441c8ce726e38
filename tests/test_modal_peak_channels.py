"""The spectral-peak test in the summed periodogram or in one channel's
(identifier/modal/peak_test.py ``peak_in_any``; the short-lag pass's guard,
identifier/modal/short_lags.py; issue 21 item 3, twenty-second round).

A weak mode that one low-noise sensor sees is lost in the unit-RMS sum of
the channels when the others' noise fills its band: the summed test finds no
peak, the channel's own periodogram a clear one. Without any peak, the test
keeps its level whatever the channels' correlation (Bonferroni over the
channels and the two tests)."""
from __future__ import annotations

import modal_fuzz
import numpy as np
from modal_synth import forced
from scipy.stats import chi2

from structbench.identifier import modal
from structbench.identifier.modal import peak_test, short_lags

STRONG, WEAK, ZETA, N, LEAD, NOISY = (6.0, 0.01), 15.0, 0.02, 8_192, 2_000, 0.5
DT = np.pi / (3.0 * WEAK)


def _modes(rng: np.random.Generator, sizes: tuple[float, float]) -> np.ndarray:
    """(2, N) displacements of the strong mode and the weak one under white forces of RMS ``sizes``."""
    out = []
    for (omega, zeta), size in zip((STRONG, (WEAK, ZETA)), sizes):
        out.append(forced(omega, zeta, DT, size * rng.standard_normal(N + LEAD))[0][LEAD:])
    return np.array(out)


def _records(rng: np.random.Generator, weak: float) -> np.ndarray:
    """(6, N): six sensors read both modes; sensor 0 is quiet (noise 1e-4 of
    its RMS), the others carry noise of 50 % of theirs, which buries a weak
    mode of ``weak`` times the strong one's force."""
    q = _modes(rng, (1.0, weak))
    clean = rng.uniform(0.5, 1.0, (6, 2)) @ q
    noise = np.r_[1e-4, np.full(5, NOISY)] * clean.std(axis=1)
    return clean + noise[:, None] * rng.standard_normal(clean.shape)


def _p(y: np.ndarray) -> tuple[float, float]:
    """p-values of a candidate at the weak mode's pole: summed test alone, and in the sum or any channel."""
    omega, zeta = np.array([STRONG[0], WEAK]), np.array([STRONG[1], ZETA])
    summed = peak_test.peak_lr([y], DT, omega, zeta, [1])[1][1]
    return float(summed), float(peak_test.peak_in_any([y], DT, omega, zeta, [1])[1])


def test_a_mode_one_quiet_channel_sees_has_a_peak_in_that_channel():
    """A weak mode (force 20 % of the strong one's; 55 lines per half-power
    band): found by the quiet channel on every seed (in both halves of the
    record), by the sum on none."""
    found = [_p(_records(np.random.default_rng(seed), 0.2)) for seed in range(5)]
    assert all(summed >= peak_test.ALPHA for summed, _ in found)
    assert all(anywhere < 1e-10 for _, anywhere in found)


def test_without_a_peak_the_level_holds():
    """No weak mode at all (the same records without it), 150 noise seeds.
    At the candidate's pole each half's channel likelihood ratio exceeds the
    chi-square bound's 10 % point (with the damping steps' Bonferroni factor;
    without the places' factor, which makes every p-value 1 here) in at
    most 10 % of the channels, and the chance ``in_one_channel`` gives (both
    halves, the best of six channels, times 6) falls under 0.1 in at most
    10 % of the records: correlated channels (both modes on every sensor)
    keep the level."""
    omega, zeta = np.array([STRONG[0], WEAK]), np.array([STRONG[1], ZETA])

    def unadjusted(part, row):
        stat = peak_test.peak_lr(part, DT, omega, zeta, [1], summed=row)[0][1:]
        return np.minimum(1.0, 0.5 * len(peak_test.ZETA_STEPS) * chi2.sf(stat, 1))
    records = [_records(np.random.default_rng(1000 + seed), 0.0) for seed in range(150)]
    halves = np.array([[unadjusted([y[:, part]], row) for part in (slice(0, N // 2), slice(N // 2, N))
                        for row in peak_test.channel_periodograms([y[:, part]])] for y in records])
    assert np.mean(halves < 0.1) <= 0.1
    assert np.mean([peak_test.in_one_channel([y], unadjusted)[0] < 0.1 for y in records]) <= 0.1


def test_the_short_lag_pass_adds_a_mode_one_channel_sees(monkeypatch):
    """Tuning seed 1,015,106 (a velocity sensor of noise 2.2 % of its RMS
    and an acceleration sensor, 24,752 samples): the short-lag pass finds
    the 39.67 rad/s mode (``zeta`` 0.0078); the summed periodogram, which
    the acceleration channel's high modes fill, shows no peak (p-value 1),
    the velocity channel a clear one in both halves (p-value 6e-21 with
    the factors). Added within its interval; with the summed test alone,
    dropped."""
    rec = modal_fuzz.unseen_record(1015106)
    trace = modal_fuzz.unseen_trace(rec)
    result = modal.identify([trace])
    w, se = np.array(result.omega), np.array(result.omega_std)
    i = int(np.argmin(np.abs(w - rec["omega"][4])))
    assert result.details["short_lags"]["added"][i]
    assert abs(w[i] - rec["omega"][4]) <= 1.96 * se[i]
    assert len(modal_fuzz.match(w, se, rec["omega"])) == w.size  # every reported mode is a true one

    def summed_only(records, dt, omega, zeta, which):
        return peak_test.peak_lr(records, dt, omega, zeta, which)[1]
    monkeypatch.setattr(short_lags, "peak_in_any", summed_only)
    summed = modal.identify([trace])
    assert np.abs(np.array(summed.omega) - rec["omega"][4]).min() > 0.01 * rec["omega"][4]
    assert any(r["reason"].startswith("short-lag pass: no spectral peak") and abs(r["omega"] - w[i]) < 1e-9
               for r in summed.details["rejected"])


def test_a_channel_peak_must_hold_in_both_halves(monkeypatch):
    """Tuning seed 1,013,201 (a free decay of 23 sensors taken for
    stationary; tests/test_modal_short_lags.py): one acceleration channel
    gives the short-lag pass's covariance-noise pole at 112.0 rad/s a
    "peak" over the whole record (the dying 82.5 rad/s mode's skirt,
    distorted by that channel's cross terms, fitted by a broad term: p-value
    3e-5, 0.0013 with the factors), none in both halves. With the whole
    record's channel test it would be added, matching no true mode."""
    rec = modal_fuzz.unseen_record(1013201)
    trace = modal_fuzz.unseen_trace(rec)
    result = modal.identify([trace])
    assert not any(result.details["short_lags"]["added"])

    def whole(records, pvalue, halves=None):
        rows = peak_test.channel_periodograms(records)
        return np.minimum(1.0, len(rows) * np.min([pvalue(records, row) for row in rows], axis=0))
    monkeypatch.setattr(peak_test, "in_one_channel", whole)
    added = modal.identify([trace])
    w, se = np.array(added.omega), np.array(added.omega_std)
    assert sum(added.details["short_lags"]["added"]) == 1
    assert len(modal_fuzz.match(w, se, rec["omega"])) == w.size - 1  # the added mode is invented


def test_one_channel_is_the_summed_test():
    """One channel: the summed test's p-value itself, not doubled (the two tests are one)."""
    y = _records(np.random.default_rng(7), 0.1)[:1]
    omega, zeta = np.array([STRONG[0], WEAK]), np.array([STRONG[1], ZETA])
    summed = peak_test.peak_lr([y], DT, omega, zeta, [1])[1][1]
    assert 0 < summed < 1e-3
    assert peak_test.peak_in_any([y], DT, omega, zeta, [1])[1] == summed
