"""The spatial line test: a sinusoid's spectral line against the random
response of every sensor, whitened by the channels' local cross-spectral
matrix (the third test of :mod:`identifier.modal.harmonics`).

The periodogram summed over the channels scatters about its running median
like one exponential when one input drives the structure (every channel's
random response at a frequency is then the same shape times one random
number), so that a weak line must stand ``LINE`` times over it. A sinusoid
from another input (a machine elsewhere on the structure) has another
shape, and the random response leaves the other directions of the ``m``
channels to the sensors' noise. With ``X_j`` (m,) the Hann-windowed
transforms of the channels at line ``j`` and ``S_j`` (m, m) the mean of
``X_k X_k^H`` over the lines ``GAP + 1`` to ``WINDOW`` either side
(``N = 2 (WINDOW - GAP)`` lines; ``WINDOW`` is
:data:`identifier.modal.harmonics_lines.WINDOW`, passed as ``window``):

    T_j = X_j^H S_j^-1 X_j

is, for a stationary Gaussian response whose cross-spectrum is constant
over the window, Hotelling's ``T^2`` of complex data: ``(N_e - m + 1) T /
(m N_e) ~ F(2 m, 2 (N_e - m + 1))`` with ``N_e = N / HANN`` independent
lines, whatever
the channels' coherence: a chi-square of ``2 m`` degrees of freedom for
large ``N_e``, not an exponential. ``T_j`` over its running median (lines 3
to ``WINDOW`` either side) is compared with that law's quantile over its
median at the false-alarm probability ``SPATIAL_P`` over every line of the
record (:func:`spatial_bar`). A sinusoid of the random response's own
shape gains nothing (it is a scaled line of the summed periodogram).
A Hann-windowed line is ``X_k = (Y_k - (Y_(k-1) + Y_(k+1)) / 2) / 2`` of the
unwindowed, independent ``Y``: neighbours correlate by -2/3 and lines two
apart by 1/6, so that a mean of ``N`` outer products holds ``N / (1 + 2
(4/9 + 1/36)) = N / 1.94`` independent ones (``HANN``).

A step of the background (an excitation's band edge: the random forces
stop, the response falls to the sensors' noise) breaks the constant
``S_j``: next to it the two halves of the window differ, and a line of the
loud side whitened by their mean stands out. :func:`sided` whitens each
line by either side alone, ``T^L_j`` by the mean over the lines ``GAP + 1``
to ``GAP + N`` below ``j`` and ``T^R_j`` above (the same ``N`` lines, so
the same law), each taken over the running median of its own side's
values (the lines 3 to ``WINDOW`` below, or above; :func:`side_medians`).
At a step the side the line belongs to whitens it as its own; but the
one-sided means reach ``GAP + N`` lines away and miss a bump of the
background tens of lines wide that the two-sided one holds. The test
takes the smallest of the three ratios
(:func:`identifier.modal.harmonics_lines.spatial_excess`): each follows
the law above where its own background is constant, so the smallest
exceeds the bar no more often than any one of them.

Shapes: ``X`` (m, lines) complex; frequencies in spectral lines. Fails
(gives no bar, NaN) with fewer than ``2 m`` lines in the window (too many
channels: the cross-spectrum estimate is singular) or a single channel;
a narrow mode's peak whose shape differs from its surroundings' also
stands out (the callers keep lines that a narrow SSI mode explains).
"""
from __future__ import annotations

import numpy as np
from scipy import stats

GAP = 3  # lines either side of j left out of S_j (a sinusoid's main lobe and scalloping)
SPATIAL_P = 1e-3  # chance that a record's random response gives any line over the bar
HANN = 1 + 2 * ((2 / 3)**2 + (1 / 6)**2)  # lines per independent one in a Hann cross-spectrum mean
EMPTY = 1e-10  # line power, relative to the record's largest, under which a line holds nothing to whiten


def independent_lines(window: int) -> float:
    """``N_e``: independent lines in the cross-spectrum estimate of :func:`whitened` over ``window``."""
    return 2 * (window - GAP) / HANN


def spatial_bar(m: int, lines: int, window: int) -> float:
    """The least ``T_j`` over its running median that a stationary random response of ``m``
    channels gives at any of ``lines`` lines with probability ``SPATIAL_P``: the quantile of
    Hotelling's law (module docstring) at ``SPATIAL_P / lines`` over its median; NaN when
    ``m < 2`` or ``N_e < 2 m``."""
    n_e = independent_lines(window)
    if m < 2 or n_e < 2 * m:
        return float("nan")
    law = stats.f(2 * m, 2 * (n_e - m + 1))
    return float(law.isf(SPATIAL_P / max(lines, 1)) / law.median())


def whitened(X: np.ndarray, window: int, chunk: int = 4096) -> np.ndarray:
    """``T_j = X_j^H S_j^-1 X_j`` (lines,) of the transforms ``X`` (m, lines) (module docstring);
    NaN within ``window`` lines of either end and where the record holds nothing (:func:`_form`).
    ``S_j`` gets a ridge of 1e-12 of its trace so that identical channels do not make it singular."""
    m, L = X.shape
    T = np.full(L, np.nan)
    if L <= 2 * window + 1:
        return T
    n = 2 * (window - GAP)
    top = _top(X)
    for start in range(window, L - window, chunk):
        stop = min(start + chunk, L - window)
        lo, hi = start - window, stop + window
        Xc = X[:, lo:hi]
        cum = np.concatenate([np.zeros((1, m, m), complex), np.cumsum(np.einsum("mj,nj->jmn", Xc, Xc.conj()), axis=0)])
        j = np.arange(start, stop) - lo
        S = (cum[j - GAP] - cum[j - window] + cum[j + window + 1] - cum[j + GAP + 1]) / n
        T[start:stop] = _form(S, X[:, start:stop], top)
    return T


def sided(X: np.ndarray, window: int, chunk: int = 4096) -> tuple[np.ndarray, np.ndarray]:
    """``T^L_j, T^R_j`` (lines,) each: ``X_j^H S^-1 X_j`` of the transforms ``X`` (m, lines) with
    ``S`` the mean of ``X_k X_k^H`` over the ``N = 2 (window - GAP)`` lines ``j - GAP - N .. j - GAP
    - 1`` (left) or ``j + GAP + 1 .. j + GAP + N`` (right) (module docstring); NaN within ``GAP +
    N`` lines of either end. Ridge as :func:`whitened`."""
    m, L = X.shape
    n = 2 * (window - GAP)
    reach = GAP + n
    left, right = np.full(L, np.nan), np.full(L, np.nan)
    if L <= 2 * reach + 1:
        return left, right
    top = _top(X)
    for start in range(reach, L - reach, chunk):
        stop = min(start + chunk, L - reach)
        lo, hi = start - reach, stop + reach
        Xc = X[:, lo:hi]
        cum = np.concatenate([np.zeros((1, m, m), complex), np.cumsum(np.einsum("mj,nj->jmn", Xc, Xc.conj()), axis=0)])
        j = np.arange(start, stop) - lo
        for out, S in ((left, cum[j - GAP] - cum[j - reach]), (right, cum[j + reach + 1] - cum[j + GAP + 1])):
            out[start:stop] = _form(S / n, X[:, start:stop], top)
    return left, right


def _top(X: np.ndarray) -> float:
    """The largest mean power ``mean_i |X_ij|^2`` over the lines of the transforms ``X`` (m, lines)."""
    return float(np.max(np.mean(np.abs(X) ** 2, axis=0), initial=0.0))


def _form(S: np.ndarray, X: np.ndarray, top: float) -> np.ndarray:
    """``x_j^H S_j^-1 x_j`` (lines,) for ``S`` (lines, m, m) and ``X`` (m, lines), ``S_j`` with a ridge of
    1e-12 of its mean diagonal; NaN where that mean is under ``EMPTY`` times ``top``, the record's largest
    mean line power (the running sums' rounding: a band the record holds nothing in, as a band-pass
    filter in the frequency domain leaves it)."""
    m = X.shape[0]
    level = np.einsum("jii->j", S).real / m
    T = np.full(X.shape[1], np.nan)
    ok = np.isfinite(level) & (level > EMPTY * top)
    x = X[:, ok].T[:, :, None]
    ridged = S[ok] + 1e-12 * level[ok, None, None] * np.eye(m)
    T[ok] = np.real(np.sum(np.conj(x) * np.linalg.solve(ridged, x), axis=(1, 2)))
    return T


def side_medians(T: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray]:
    """The median of ``T`` (lines,) over the lines 3 to ``window`` below each line, and above it
    (NaN where that side runs off ``T`` or holds a NaN)."""
    size = window - 2
    below, above = np.full(T.size, np.nan), np.full(T.size, np.nan)
    if T.size < size:
        return below, above
    med = np.median(np.lib.stride_tricks.sliding_window_view(T, size), axis=1)  # med[i]: T[i:i + size]
    j = np.arange(T.size)
    ok = j - window >= 0
    below[ok] = med[j[ok] - window]
    ok = j + 3 + size <= T.size
    above[ok] = med[j[ok] + 3]
    return below, above
