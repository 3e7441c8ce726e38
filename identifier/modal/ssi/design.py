"""Default sizes of the SSI-cov Hankel matrix, from the data: lag span,
block rows and block columns.

What the lag span must do depends on the record. In a free decay the poles
are deterministic and only sensor noise blurs them: the longer the span of
the block rows, the more of the decay the shift structure ``O_down = O_up A``
fits and the smaller the error (for a slow mode roughly as ``p^-3/2``), so
the lags use as much of the record as the covariance estimates allow. In a
stationary response to random excitation the finite record itself limits
the accuracy (a relative frequency error of about ``sqrt(zeta / (omega T))``
whatever the method) and longer rows do not help; but the lags must span a
good fraction of a period of the lowest mode the response carries (a tenth
of the period missed it in tests, a fifth found it), which with fine
sampling is more lags than rows can afford. A free response that does not
decay (an undamped structure) is not told apart from a stationary one; it
gets the longer of the two spans.

The span ``p + q`` of lags 1 .. p + q - 1 is at most ``n / 20`` (every
lagged product averages at least 95 % of the record) and at most
``LAG_BUDGET / (m r)`` (the per-group covariance sums, ``groups x L x m x r``
numbers, stay below about 250 MB). The block rows ``p`` are the costly
dimension (the subspace, its QR and the Gram matrices grow with ``p x row
channels``): ``p <= ROW_BUDGET / row channels`` and at most 4/5 of that
longest span. The columns ``q`` are a quarter of the rows; unless every
record is a free decay they extend the span to a quarter period of
``f_low``, the frequency below which 2 % of the reference channels' power
lies (Welch spectrum), where that is longer (products with the Hankel matrix
are FFTs over the lag axis and cost little more for more columns; but in
random data lags many decay times long carry only noise for the faster
modes: a span of half a period lost the four highest modes of the damped
beam in tests); and they are at least ``1.5 max_order / r``, so that every
model order has columns enough.

A random response then keeps only the lags that carry signal
(:func:`signal_span`): past a few correlation times of its modes the
covariances are their own estimation noise, measured by the spread of the
covariances of the ``G`` contiguous sample groups, and there SSI fits
poles of the noise and loses the observability of a heavily damped mode
(one mode of zeta 0.03 and a correlation time of 25 samples on 12
sensors: 333 block rows lost it, the 64 lags with signal found it within
0.4 %). A free decay keeps its span: the noise poles of its long lags are
told apart by their temporal coherence (:mod:`identifier.modal`).
"""
from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.fft import rfftfreq
from scipy.signal import get_window

from ..runtime import rfft
from .covariance import Covariances

ROW_BUDGET = 4000  # block rows x row channels
ROW_CHANNELS = 20  # at most this many (principal) row channels, as many as the references
LAG_BUDGET = 4_000_000  # lags x channels x references (8 groups of sums: about 250 MB)
SIGNAL_RATIO = 2.0  # covariance power / its estimation noise's: below it the lags carry no signal


def lowest_frequency(records: list[np.ndarray], dt: float, refs: np.ndarray) -> float:
    """``f_low`` Hz: the frequency below which 2 % of the power of the
    standardised reference channels lies (:func:`welch_power`, segments of
    up to 8192 samples, at most the shortest record), over all records."""
    size = min(min(y.shape[1] for y in records), 8192)
    power = sum(welch_power(z / np.maximum(np.std(z, axis=1, keepdims=True), np.finfo(float).tiny), size)
                for z in (y[refs] for y in records))
    share = np.cumsum(power[1:]) / np.sum(power[1:])
    return float(rfftfreq(size, dt)[1 + np.searchsorted(share, 0.02)])


def welch_power(z: np.ndarray, size: int, batch: int = 1 << 22) -> np.ndarray:
    """Welch's power spectrum (size // 2 + 1,) of the rows of ``z`` (k, n)
    summed over the rows, up to a constant factor: the mean over segments
    of ``size`` samples, half overlapping, each with its mean removed and a
    Hann window, of ``|FFT|^2``, doubled but at 0 Hz and Nyquist (one-sided):
    ``scipy.signal.welch``'s estimate without its constant scale and its
    per-call set-up. About ``batch`` samples at a time."""
    window = get_window("hann", size)
    starts = np.arange(0, z.shape[1] - size + 1, size - size // 2)
    segments = sliding_window_view(z, size, axis=1)  # (k, n - size + 1, size), a view
    power, per_batch = np.zeros(size // 2 + 1), max(1, batch // (size * z.shape[0]))
    for first in range(0, starts.size, per_batch):
        chunk = segments[:, starts[first:first + per_batch]]
        chunk = (chunk - chunk.mean(axis=2, keepdims=True)) * window
        power += np.sum(np.abs(rfft(chunk, axis=2)) ** 2, axis=(0, 1))
    power[1:(size + 1) // 2] *= 2.0
    return power / starts.size


def signal_span(cov: Covariances, window: int, ratio: float = SIGNAL_RATIO) -> int:
    """Lags over which the lagged covariances of stationary records stand
    out of their own estimation noise: the start of the first window of
    ``window`` lags (after the first) where ``sum ||R_l||_F^2 < ratio sum
    se_l^2``, ``se_l^2 = sum_g ||R_(g,l) - R_l||_F^2 / (G (G - 1))`` the
    variance of the mean ``R_l`` from its ``G`` contiguous groups; all the
    lags when there is none."""
    groups = cov.sums.shape[0]
    mean = cov.mean()
    spread = cov.sums / np.maximum(cov.counts, 1)[:, :, None, None] - mean
    noise = np.einsum("glmr,glmr->l", spread, spread) / (groups * (groups - 1))
    power = np.einsum("lmr,lmr->l", mean, mean)
    count = mean.shape[0] // window
    if count < 2:
        return mean.shape[0]
    windows = slice(0, count * window)
    snr = power[windows].reshape(count, window).sum(1) / noise[windows].reshape(count, window).sum(1)
    low = np.flatnonzero(snr[1:] < ratio)
    return int((low[0] + 1) * window) if low.size else mean.shape[0]


def block_sizes(samples: int, m: int, references: int, row_channels: int, max_order: int, dt: float,
                decay: bool, f_low: float, rows: int | None = None, span: int | None = None) -> tuple[int, int]:
    """Block rows ``p`` (``rows`` if given) and columns ``q`` (see the module
    docstring) for records of at least ``samples`` samples of ``m`` channels,
    ``references`` reference and ``row_channels`` row channels, sampled at
    ``dt`` s; ``decay``: every record is a free decay; ``f_low`` Hz; ``span``:
    at most this many lags (:func:`signal_span`). Chosen
    sizes fit the record (``p + q`` at most the longest span): on a short
    record the columns give way down to the split that allows the highest
    model order, ``(p - 1) row_channels = q references``, and the rows take
    the rest; given ``rows`` are kept as they are."""
    longest = min(samples // 20, LAG_BUDGET // (m * references), span or samples)
    chosen = rows
    rows = rows or max(2, min(ROW_BUDGET // row_channels, 4 * longest // 5))
    columns = rows // 4
    if not decay:
        quarter_period = int(np.ceil(1.0 / (4.0 * f_low * dt))) + 1
        columns = min(longest, max(rows + columns, quarter_period)) - rows
    columns = max(columns, -(-3 * max_order // (2 * references)), 1)
    if chosen is None and rows + columns > longest:  # a short record: as high an order as rows and columns allow
        columns = max(1, min(columns, (longest - 1) * row_channels // (row_channels + references)))
        rows = max(2, longest - columns)
    return int(rows), int(columns)


def short_record_warnings(decay: bool, f_low: float, length: float) -> list[str]:
    """What the record cannot support, said once: a stationary record of
    under 2 periods of ``f_low`` Hz, the lowest frequency that carries 2 %
    of its power."""
    if decay or f_low * length >= 2:
        return []
    return [f"the record ({length:.4g} s) holds {f_low * length:.2g} periods of {f_low:.4g} Hz, the lowest "
            f"frequency carrying 2 % of its power: modes there are not supported by it"]
