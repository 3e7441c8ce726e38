"""The harmonics search computes a record's transforms once (issue 21 item 7:
8 h records cost about 0.2 CPU s per transform and 1.5 s per spatial
excess): :func:`screen` hands its :class:`Spectra` to :func:`confirm`, and
:func:`coherent_share` takes the record's transforms. The same numbers as
computing them again, to the bit."""
from __future__ import annotations

import numpy as np

from structbench.identifier.modal import harmonics_poles
from structbench.identifier.modal.harmonics import Screened, confirm, screen
from structbench.identifier.modal.harmonics_lines import _spectrum, background, spectra
from structbench.identifier.modal.harmonics_poles import coherent_share


def _weak_line(n: int = 150_001, dt: float = 1 / 500) -> tuple[np.ndarray, float, float]:
    """White noise on 2 channels with a sinusoid 60 times its median line, 0.4 lines off a line
    (as in test_modal_harmonics_poles.py); (record, line rad/s, line spacing rad/s)."""
    rng = np.random.default_rng(1)
    bin_w = 2 * np.pi / (n * dt)
    line = 15_000.4 * bin_w
    hann = np.hanning(n)
    a = np.sqrt(60 * np.log(2) * 4 * np.sum(hann**2)) / np.sum(hann)
    return rng.standard_normal((2, n)) + np.outer([1.0, 0.5], a * np.cos(line * np.arange(n) * dt + 1.0)), line, bin_w


def test_screen_hands_on_the_spectra_of_the_records_it_left_as_they_were():
    rng = np.random.default_rng(0)
    plain = rng.standard_normal((3, 20_000))
    t = np.arange(20_000) * 0.01
    strong = plain + np.outer([1.0, 0.8, 0.6], 3.0 * np.cos(40.0 * t))  # a sure line: subtracted
    s = screen([plain, strong], 0.01)
    assert s.records[0] is plain and s.records[1] is not strong and s.spectra[1] is None
    for got, want in zip(s.spectra[0], spectra(plain)):
        assert np.array_equal(got, want)


def test_confirm_with_the_handed_spectra_is_confirm_without_them(monkeypatch):
    """A narrow pole 7 lines beside a weak line (the coherent test at the line): the same
    harmonics and drops to the bit; its two coherent shares (the pole's band, then the line
    beside it) transform only their residuals (4 transforms without the handed spectra)."""
    y, line, bin_w = _weak_line()
    pole = line - 7 * bin_w
    zeta = np.array([18.0 / (pole * y.shape[1] / 500)])
    args = (1 / 500, np.array([pole]), zeta, zeta, np.array([4.4 * bin_w]))
    drop, found = confirm(Screened([y], [], []), *args)
    calls = []
    monkeypatch.setattr(harmonics_poles, "_spectrum", lambda *a: calls.append(1) or _spectrum(*a))
    drop2, found2 = confirm(Screened([y], [], [], [spectra(y)]), *args)
    assert drop.tolist() == drop2.tolist() == [True] and len(calls) == 2
    assert [(f.omega, f.test, f.ratio) for f in found] == [(f.omega, f.test, f.ratio) for f in found2]
    assert all(np.array_equal(f.amplitude, g.amplitude) for f, g in zip(found, found2))
    P = np.sum(np.abs(_spectrum(y))**2, axis=0)
    bg = background(P)
    assert coherent_share(y, 1 / 500, P, bg, line, 1e-5) == coherent_share(y, 1 / 500, P, bg, line, 1e-5,
                                                                           _spectrum(y))
