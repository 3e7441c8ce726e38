"""The short-lag pass of stationary records (identifier/modal/short_lags.py,
on by default, ``short_lags="off"`` skips it; issue 21 item 3, nineteenth
and twentieth rounds).

Record 1,015,094 is a tuning seed of ``benchmarks/modal_fuzz.py --kind
unseen`` (2 sensors, displacement and velocity, 15,706 samples): a light
21.56 rad/s mode (``zeta`` 0.0012) sets lags of 628 block rows, over which
the broad 49.17 rad/s mode (``zeta`` 0.018, 69 % of the mean square) is
fitted as several light noise poles that fail the support tests; with 157
block rows it is one mode. Record 1,015,050 (2 sensors): the strong light
86.47 rad/s mode's cluster took in noise poles of negative damping and was
dropped as a harmonic by its damping; the short-lag pass reports it.
"""
from __future__ import annotations

import modal_fuzz
import numpy as np
import pytest

from structbench.identifier import modal
from structbench.identifier.modal import harmonics, short_lags


@pytest.mark.parametrize("seed, mode", [(1015094, 1), (1015050, 1)])
def test_a_mode_long_lags_hide_is_found_within_its_intervals(seed, mode, monkeypatch):
    rec = modal_fuzz.unseen_record(seed)
    trace = modal_fuzz.unseen_trace(rec)
    result = modal.identify([trace])
    w, se = np.array(result.omega), np.array(result.omega_std)
    z, sz = np.array(result.damping), np.array(result.damping_std)
    i = int(np.argmin(np.abs(w - rec["omega"][mode])))
    assert result.details["short_lags"]["added"][i]
    assert abs(w[i] - rec["omega"][mode]) <= 1.96 * se[i] and abs(z[i] - rec["zeta"][mode]) <= 1.96 * sz[i]
    assert np.all(np.isfinite(result.mode_shapes_std[i]))
    assert len(w) == len(rec["omega"])  # every true mode once, nothing else
    assert len(modal_fuzz.match(w, se, rec["omega"])) == w.size
    off = modal.identify([trace], short_lags="off")  # without the pass the mode is missed
    assert "short_lags" not in off.details
    assert np.abs(np.array(off.omega) - rec["omega"][mode]).min() > 0.01 * rec["omega"][mode]
    monkeypatch.setattr(short_lags, "MIN_ROWS", 10**6)  # the pass skipped: missed as well
    skipped = modal.identify([trace])
    assert "skipped" in skipped.details["short_lags"] and skipped.omega == off.omega


def test_no_pass_when_the_block_rows_are_given_or_for_a_free_decay():
    rec = modal_fuzz.unseen_record(1015094)
    given = modal.identify([modal_fuzz.unseen_trace(rec)], block_rows=200)
    assert "short_lags" not in given.details
    decay = modal_fuzz.unseen_record(1015003)  # a free decay of 49 sensors
    assert decay["kind"] == "decay"
    assert "short_lags" not in modal.identify([modal_fuzz.unseen_trace(decay)]).details
    with pytest.raises(modal.IdentificationError, match="short_lags"):
        modal.identify([modal_fuzz.unseen_trace(rec)], short_lags="auto")


def test_an_added_mode_needs_a_spectral_peak_of_its_own(monkeypatch):
    """Tuning seed 1,013,201: a free decay of 8.7 periods (23 sensors) that
    the identifier takes for stationary. Its higher modes die out at the
    record's start, and the pass fits covariance-noise poles there
    (coherence 0.75-0.84) that have no peak in the record's spectrum: the
    peak test drops them (p-value 1 each); without it they are added and
    match no true mode."""
    rec = modal_fuzz.unseen_record(1013201)
    trace = modal_fuzz.unseen_trace(rec)
    result = modal.identify([trace])
    dropped = [r for r in result.details["rejected"] if r["reason"].startswith("short-lag pass: no spectral peak")]
    assert len(dropped) >= 1 and not any(result.details["short_lags"]["added"])
    w, se = np.array(result.omega), np.array(result.omega_std)
    assert len(modal_fuzz.match(w, se, rec["omega"])) == w.size  # every reported mode is a true one
    monkeypatch.setattr(short_lags, "ALPHA", 1.1)  # every p-value passes: the test off
    unguarded = modal.identify([trace])
    assert sum(unguarded.details["short_lags"]["added"]) == len(dropped)
    w, se = np.array(unguarded.omega), np.array(unguarded.omega_std)
    assert len(modal_fuzz.match(w, se, rec["omega"])) < w.size  # invented modes


def test_the_records_are_screened_for_harmonics_once_per_content(monkeypatch):
    """The short-lag pass screens the same records as the first pass: one
    screen serves both (the deflated pass's projected records get their
    own), and the result is the one with every pass screening afresh."""
    trace = modal_fuzz.unseen_trace(modal_fuzz.unseen_record(1015094))
    real, calls = harmonics.screen, []
    monkeypatch.setattr(harmonics, "screen", lambda records, dt, known=(): calls.append(dt) or real(records, dt, known))
    once = modal.identify([trace])
    assert len(calls) == 1 + (once.details["deflation"].get("skipped") is None)

    class Afresh:
        def __call__(self, records, dt, known=()):
            return harmonics.screen(records, dt, known)
    monkeypatch.setattr(harmonics, "Screens", Afresh)
    shared = len(calls)
    afresh = modal.identify([trace])
    assert len(calls) - shared == shared + 1  # the short-lag pass screened again
    assert afresh.omega == once.omega and afresh.damping == once.damping and afresh.omega_std == once.omega_std
