"""Tests of one SSI pole against the spectral line it may have been fitted
to: the pole half of :mod:`identifier.modal.harmonics` (whose docstring has
the rules they serve).

``P`` (lines,) is the Hann periodogram summed over the RMS-scaled channels
of a record ``y`` (m, n) sampled every ``dt`` s, ``bg`` its running median
(:func:`identifier.modal.harmonics_lines.background`), ``bin_w = 2 pi / (n
dt)`` rad/s its line spacing; a pole is ``omega`` rad/s and ``|zeta|``, of
half-power half-width ``h = |zeta| omega / bin_w`` lines and ``D = 2 pi h``
decay times in the record.
"""
from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.optimize import minimize_scalar

from .harmonics_lines import CONC, H_MIN, WINDOW, _spectrum, fit
from .harmonics_spatial import GAP, HANN, independent_lines

SHARE_P = 1e-3  # chance that a mode's random response gives a coherent share as large (coherent_share)
LINE_P = 1e-3  # chance that a mode's band holds a line over the line test's threshold (conc)
PEAK_Z = float(stats.norm.isf(SHARE_P))  # a pole's band keeps a peak without its line (peak_left): 3.09


def conc(r: int) -> float:
    """The ``line`` test's threshold over a search of the ``2 r + 1`` lines
    ``j0 - r .. j0 + r``: ``max(CONC, log2((2 r + 1) / LINE_P))``. A random
    periodogram line exceeds ``c`` times its median with probability
    ``2^-c`` (exponential scatter), so a mode's band of ``2 r + 1`` lines
    holds one that high with probability under ``LINE_P`` (``CONC`` alone
    gives a broad mode's band of 2000 lines a line 15 medians high in some
    per cent of records)."""
    return max(CONC, float(np.log2((2 * r + 1) / LINE_P)))


def _pole_line(P: np.ndarray, omega: float, zeta: float, bin_w: float) -> tuple[int, float, float]:
    """For a pole (``omega`` rad/s, ``|zeta|``) of half-width ``h = zeta
    omega / bin_w`` lines: the strongest line ``j`` of ``P`` within ``r =
    max(h, 2)`` lines, its excess over a mode's peak (``P_j`` over the
    median of the lines 4 to ``max(r, 8)`` from it, times the median of ``1 /
    (1 + (d / h)^2)`` there) and the band's rise over its surroundings
    (infinite when ``h < H_MIN``: too few lines to tell). ``j`` is -1 (and
    the excess 0) when the band runs off the spectrum."""
    h = zeta * omega / bin_w
    j0, r = int(round(omega / bin_w)), int(np.ceil(max(h, 2.0)))
    wide = max(r, 8)
    lo, hi = max(j0 - r, wide), min(j0 + r, P.size - wide - 1)
    if hi < lo:
        return -1, 0.0, float("inf")
    j = lo + int(np.argmax(P[lo:hi + 1]))
    d = np.r_[-wide:-3, 4:wide + 1]
    shape = 1.0 / (1.0 + (d / max(h, 1e-3))**2)
    excess = float(P[j] / max(np.median(P[j + d]), 1e-300) * np.median(shape))
    if h < H_MIN or j0 - 4 * r < 0 or j0 + 4 * r >= P.size:
        return j, excess, float("inf")
    inner = np.r_[j0 - r:max(j - 3, j0 - r), min(j + 4, j0 + r + 1):j0 + r + 1]
    outer = np.r_[j0 - 4 * r:j0 - 2 * r, j0 + 2 * r + 1:j0 + 4 * r + 1]
    if inner.size == 0:
        return j, excess, float("inf")
    return j, excess, float(np.median(P[inner]) / max(np.median(P[outer]), 1e-300))


def coherent_share(y: np.ndarray, dt: float, P: np.ndarray, bg: np.ndarray, omega: float,
                   zeta: float, X: np.ndarray | None = None) -> tuple[float, float, int]:
    """The share of a narrow pole's spectral peak that one sinusoid holds.

    Over the band ``B`` of lines ``|j - j0| <= r``, ``r = ceil(max(2 h,
    3))``: the sinusoid ``a_c cos(w t) + b_c sin(w t)`` fitted by least
    squares to every channel at the frequency ``w`` (within 0.75 lines of
    the band's strongest line: of the whitened lines ``T_k`` of
    :func:`_whitened_share` with 2 channels or more, where a sinusoid of
    another shape stands out of a broad mode's peak, else of ``P``) that maximises ``sum_c |a_c - i b_c|^2`` is
    projected out of ``y``, and ``share = 1 - sum_B (P'_j - bg_j) / sum_B
    (P_j - bg_j)`` (``P'``: the residual's periodogram, scaled as ``P``).
    A harmonic on a random background leaves the background: a share near
    1. A mode's random response of ``D`` decay times keeps most of its peak
    (its envelope wanders over the record): ``1 - share`` under ``x`` with
    probability about ``x^sqrt(D)`` in the tail (:func:`share_bound`). Returns (share, the band's strongest line over
    ``bg`` there, corrected for where the fitted frequency falls between lines (:func:`hann_gain`): a
    sinusoid half a line off puts 0.72 of its power in each of two lines; its index); NaN share when
    the band runs off the spectrum or holds no excess. ``X``: ``_spectrum(y)`` when computed already
    (the same numbers: the transforms of the channels over their own RMS)."""
    n = y.shape[1]
    bin_w = 2 * np.pi / (n * dt)
    h = zeta * omega / bin_w
    j0, r = int(round(omega / bin_w)), int(np.ceil(max(2 * h, 3.0)))
    if j0 - r < 1 or j0 + r >= P.size - 1:
        return float("nan"), 0.0, -1
    band = np.arange(j0 - r, j0 + r + 1)
    rms = np.sqrt(np.mean(y**2, axis=1, keepdims=True))
    X = _spectrum(y, rms) if X is None else X
    T = _whitened_band(X, j0, r)
    j = int(band[np.argmax(P[band] if T is None else T[0])])
    w, rest = _take_out(y, dt, j)
    Xr = _spectrum(rest, rms)
    ratio = float(P[j] / max(bg[j], 1e-300)) / hann_gain(w / bin_w - j)  # the line's power wherever it falls
    white = _whitened_share(X, Xr, j0, r)
    if np.isfinite(white):
        return white, ratio, j
    Pr = np.sum(np.abs(Xr[:, band])**2, axis=0)
    before = float(np.sum(P[band] - bg[band]))
    if before <= 0:
        return float("nan"), ratio, j
    return 1.0 - float(np.sum(Pr - bg[band])) / before, ratio, j


def _take_out(y: np.ndarray, dt: float, j: int) -> tuple[float, np.ndarray]:
    """The sinusoid within 0.75 lines of line ``j`` that holds most of ``y`` (m, n) (the frequency
    ``w`` rad/s maximising ``sum_c |a_c - i b_c|^2``, least squares), and ``y`` less it."""
    n = y.shape[1]
    bin_w = 2 * np.pi / (n * dt)
    t = np.arange(n) * dt
    best = minimize_scalar(lambda w: -float(np.sum(np.abs(fit(y, w, t))**2)),
                           bounds=((j - 0.75) * bin_w, (j + 0.75) * bin_w), method="bounded",
                           options={"xatol": 1e-4 * bin_w})
    w = float(best.x)
    a = fit(y, w, t)
    return w, y - np.outer(a.real, np.cos(w * t)) + np.outer(a.imag, np.sin(w * t))


def peak_left(y: np.ndarray, dt: float, P: np.ndarray, omega: float, zeta: float,
              X: np.ndarray | None = None) -> float:
    """The peak a pole's band keeps once the sinusoid at its strongest line is taken out, in
    standard errors of a random background: over the band ``B`` of :func:`coherent_share` less
    the lines within ``GAP`` of the strongest whitened line (what a fit leaves of a strong line stays there;
    ``k`` lines), ``rho = sum_B (T'_k - b) / sigma`` with ``T'`` the residual's whitened
    lines and ``b`` their expected value as in :func:`_whitened_share`, and

        sigma = b k sqrt(HANN / (k m) + 1 / (m N_e)),

    a random line's ``T`` being ``b`` times a chi-square of ``2 m`` degrees of freedom over ``2 m``
    (``k`` lines hold ``k / HANN`` independent ones), plus the error of the ring's estimate of ``S``
    common to the band (``sum_B T = tr(S^-1 sum_B X X^H)``: relative variance ``1 / (m N_e)`` of
    the trace). A mode's peak under the line
    leaves ``rho`` of several (a mode of 5 lines half-width over 16 channels: about 9); a line on
    a flat background leaves about 0 (a little under: the fit takes the random part at its
    frequency too), over ``PEAK_Z`` with probability about ``SHARE_P`` (Monte Carlo,
    tests/test_modal_harmonics_poles.py). NaN with one channel, ``N_e < 2 m`` or a band off the
    spectrum (as :func:`_whitened_share`). ``X``: as in :func:`coherent_share`."""
    n = y.shape[1]
    bin_w = 2 * np.pi / (n * dt)
    h = zeta * omega / bin_w
    j0, r = int(round(omega / bin_w)), int(np.ceil(max(2 * h, 3.0)))
    rms = np.sqrt(np.mean(y**2, axis=1, keepdims=True))
    X = _spectrum(y, rms) if X is None else X
    white = _whitened_band(X, j0, r)
    if white is None:
        return float("nan")
    lines = np.arange(-r, r + 1)
    k = int(np.argmax(white[0]))
    Xr = _spectrum(_take_out(y, dt, j0 + lines[k])[1], rms)
    Tr = _whitened_band(X, j0, r, Xr)[1][np.abs(lines - lines[k]) > GAP]  # a strong line's fit leaves some
    m, n_e = y.shape[0], independent_lines(WINDOW)
    b = m * n_e / (n_e - m)
    sigma = b * Tr.size * np.sqrt(HANN / (Tr.size * m) + 1.0 / (m * n_e))
    return float(np.sum(Tr - b) / sigma)


def _whitened_share(X: np.ndarray, Xr: np.ndarray, j0: int, r: int) -> float:
    """:func:`coherent_share` in every sensor's lines: ``1 - sum_B (T'_k - b) / sum_B (T_k - b)``
    with ``T_k = X_k^H S^-1 X_k`` over the band ``B = j0 - r .. j0 + r`` of the transforms ``X``
    (m, lines) of the record and ``Xr`` of its residual, ``S`` the mean of ``X_k X_k^H`` over the
    ``N = 2 (WINDOW - GAP)`` lines ``r + GAP + 1`` to ``r + WINDOW`` either side of ``j0``, and ``b
    = m N_e / (N_e - m)`` the expected ``T`` of a random line (complex Wishart, ``N_e``
    independent lines: :func:`identifier.modal.harmonics_spatial.independent_lines`). The random
    background of ``m`` channels scatters as a chi-square of ``2 m`` degrees of freedom about ``b``, so a sinusoid of another
    shape than the background's leaves far less of the peak than in the summed periodogram; a
    mode's random response leaves the same share (its own shape dominates both sums). NaN with one
    channel, ``N_e < 2 m``, a band off the spectrum or no excess."""
    white = _whitened_band(X, j0, r, Xr)
    if white is None:
        return float("nan")
    T, Tr = white
    m, n_e = X.shape[0], independent_lines(WINDOW)
    b = m * n_e / (n_e - m)
    before = float(np.sum(T - b))
    return 1.0 - float(np.sum(Tr - b)) / before if before > 0 else float("nan")


def _whitened_band(X: np.ndarray, j0: int, r: int, *more: np.ndarray) -> tuple[np.ndarray, ...] | None:
    """``T_k = Z_k^H S^-1 Z_k`` over the band ``k = j0 - r .. j0 + r`` for ``Z`` = ``X`` and each of
    ``more`` (transforms (m, lines)), ``S`` the ring mean of :func:`_whitened_share` from ``X``.
    None with one channel, ``N_e < 2 m`` or a ring off the spectrum."""
    m, L = X.shape
    if m < 2 or independent_lines(WINDOW) < 2 * m or j0 - r - WINDOW < 1 or j0 + r + WINDOW >= L:
        return None
    d = np.arange(r + GAP + 1, r + WINDOW + 1)
    ring = X[:, np.r_[j0 - d, j0 + d]]
    S = ring @ ring.conj().T / ring.shape[1]
    S += 1e-12 * np.trace(S).real / m * np.eye(m)
    band = np.arange(j0 - r, j0 + r + 1)
    return tuple(np.real(np.sum(np.conj(Z[:, band]) * np.linalg.solve(S, Z[:, band]), axis=0)) for Z in (X, *more))


def hann_gain(offset: float) -> float:
    """Power of a sinusoid ``offset`` lines from a line in that line of the Hann-windowed periodogram,
    relative to its power on the line: ``(sinc(d) / (1 - d^2))^2`` (1 at 0, 0.72 at 0.5)."""
    d = min(abs(offset), 0.75)
    return float((np.sinc(d) / (1.0 - d * d))**2)


def share_bound(decays: float) -> float:
    """The coherent share over which a pole of ``D = decays`` decay times is
    a sinusoid: ``1 - SHARE_P^(1 / sqrt(D))`` (:func:`coherent_share`), so
    that a mode's random response passes it with probability about
    ``SHARE_P``. The law ``P(1 - share < x) = x^sqrt(D)`` fits the 1 %
    quantiles of a Monte Carlo of one mode's random response (150 records
    each of D = 4 and 14: 0.108 and 0.286; the 5 % quantiles are steeper
    and the deeper tail steepens further, so the bound errs towards modes;
    docs/modal-method.md)."""
    return 1.0 - SHARE_P ** (1.0 / np.sqrt(max(decays, 1e-9)))
