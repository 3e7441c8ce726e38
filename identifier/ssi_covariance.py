"""Output covariances at non-zero lags and their block Hankel matrix, for
covariance-driven stochastic subspace identification (SSI-cov).

For outputs ``y_k`` (m,) and reference outputs ``y_ref,k`` (r,) of a linear
system ``x_{k+1} = A x_k + w_k``, ``y_k = C x_k + v_k`` driven by white noise
(operational data) or left to itself (free decay), the lagged products

    R_l = sum_k y_{k+l} y_ref,k^T / sum_k 1,     l = 1, 2, ..., L = p + q - 1

satisfy ``R_l = C A^(l-1) G``: for free decay with ``G = A sum_k x_k x_k^T
C_ref^T / n`` and for stationary data with ``G = E[x_{k+1} y_ref,k^T]``.
White sensor noise ``v`` enters only ``R_0``, which is never used, so it
adds variance but no bias. The block Hankel matrix

    H = [[R_1, R_2, ..., R_q], [R_2, ..., R_{q+1}], ..., [R_p, ..., R_{p+q-1}]]

(p m x q r) factors as ``O Gamma`` with the observability matrix ``O = [C; C A;
...; C A^(p-1)]``, which is what :mod:`identifier.ssi_poles` extracts.

The sums are kept per group of samples (the sample index ``k`` of the
reference), so that the identification can be repeated with one group left
out (jackknife, :mod:`identifier.modal_uncertainty`): ``groups`` contiguous
segments for stationary records, or interleaved blocks of L samples
(each group then spans the whole record) for free decays, whose signal is
concentrated at the start. Channels are divided by their RMS first so that
sensors of different size weigh alike; shapes are scaled back by the caller.
Fails (by design) to see a mode whose shape vanishes at every reference
channel, and modes with less than about one period within the record.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Covariances:
    """Lagged output covariance sums per sample group.

    ``sums`` (g, L, m, r): ``sum_{k in group} y_{k+l} y_ref,k^T`` for l = 1..L
    (standardised channels; ``k < n - L``, one set of ``k`` for every lag, so
    that the shift structure holds exactly for a free decay too); ``counts``
    (g, L) the number of terms;
    ``scale`` (m,) the channel RMS used to standardise; ``references``
    (r,) the reference channel indices; ``dt`` s.
    """

    sums: np.ndarray
    counts: np.ndarray
    scale: np.ndarray
    references: np.ndarray
    dt: float

    def mean(self, leave_out: int | None = None) -> np.ndarray:
        """``R_l`` (L, m, r) from every group, or from all but group ``leave_out``."""
        keep = np.ones(self.sums.shape[0], dtype=bool)
        if leave_out is not None:
            keep[leave_out] = False
        return self.sums[keep].sum(axis=0) / self.counts[keep].sum(axis=0)[:, None, None]


def reference_channels(m: int, count: int) -> np.ndarray:
    """``count`` channel indices spread evenly over ``m`` channels (all when ``count >= m``)."""
    if count >= m:
        return np.arange(m)
    return np.unique(np.round(np.linspace(0, m - 1, count)).astype(int))


def group_labels(n: int, groups: int, lags: int, decay: bool) -> np.ndarray:
    """Group index (n,) of every sample: contiguous segments, or for a free
    decay interleaved blocks of ``lags`` samples (block b in group b mod groups)."""
    if not decay:
        return np.minimum(np.arange(n) * groups // n, groups - 1)
    block = max(lags, 1)
    return (np.arange(n) // block) % groups


def is_free_decay(y: np.ndarray) -> bool:
    """A record (m, n) whose first tenth carries more than 10 times the mean
    square of its last tenth: a free decay rather than a stationary response."""
    tenth = max(y.shape[1] // 10, 1)
    first, last = np.mean(y[:, :tenth] ** 2), np.mean(y[:, -tenth:] ** 2)
    return bool(first > 10.0 * last)


def covariances(records: list[np.ndarray], dt: float, lags: int, references: int, groups: int) -> Covariances:
    """Lagged covariance sums (see :class:`Covariances`) of one or more
    records (each (m, n_i), same channels, sampling interval ``dt`` s), for
    lags 1..``lags``; several records add up as independent tests."""
    m = records[0].shape[0]
    scale = np.sqrt(np.mean(np.concatenate([y**2 for y in records], axis=1), axis=1))
    scale = np.where(scale > 0, scale, 1.0)
    refs = reference_channels(m, references)
    sums = np.zeros((groups, lags, m, refs.size))
    counts = np.zeros((groups, lags))
    for y in records:
        z = y / scale[:, None]
        usable = z.shape[1] - lags  # the same reference samples k for every lag keep R_l = C A^(l-1) G exact
        labels = group_labels(usable, groups, lags, is_free_decay(z))
        for g in range(groups):
            k = np.flatnonzero(labels == g)
            if k.size == 0:
                continue
            contiguous = k[-1] - k[0] + 1 == k.size
            ref = z[refs, k[0]:k[-1] + 1] if contiguous else z[refs][:, k]
            for lag in range(1, lags + 1):
                ahead = z[:, k[0] + lag:k[-1] + 1 + lag] if contiguous else z[:, k + lag]
                sums[g, lag - 1] += ahead @ ref.T
            counts[g] += k.size
    return Covariances(sums, counts, scale, refs, dt)


def hankel(R: np.ndarray, rows: int, columns: int | None = None) -> np.ndarray:
    """Block Hankel matrix (rows m, columns r) of ``R`` (>= rows + columns - 1
    lags, m, r): block (i, j) = ``R[i + j]`` (that is R_{i+j+1}); ``columns``
    defaults to ``rows``."""
    _, m, r = R.shape
    columns = columns or rows
    idx = np.arange(rows)[:, None] + np.arange(columns)[None, :]
    return R[idx].transpose(0, 2, 1, 3).reshape(rows * m, columns * r)
