"""Output covariances at non-zero lags, for covariance-driven stochastic
subspace identification (SSI-cov), and the principal row channels.

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
...; C A^(p-1)]``, which is what :mod:`identifier.modal.ssi.poles` extracts
(products with ``H`` by FFT: :mod:`identifier.modal.ssi.hankel`).

The sums are kept per group of samples (the sample index ``k`` of the
reference), so that the identification can be repeated with one group left
out (jackknife, :mod:`identifier.modal.uncertainty`): ``groups`` contiguous
segments for stationary records, or interleaved blocks of L / 2 samples
(each group then spans the whole record) for free decays, whose signal is
concentrated at the start. Channels are divided by their RMS first so that
sensors of different size weigh alike; shapes are scaled back by the caller.
With many channels the Hankel matrix's rows use the leading principal
directions of the lagged covariances (:func:`row_projection`) instead of the
channels: they carry every mode the channels see, and the white sensor
noise of the other directions is left out.
Fails (by design) to see a mode whose shape vanishes at every reference
channel, and modes with less than about one period within the record.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft
from scipy import stats

from ..runtime import irfft, rfft

DECAY_ALPHA = 1e-3  # a stationary record taken for a free decay by one channel's decay (decaying_channel)


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

    def truncated(self, lags: int) -> Covariances:
        """The sums of the first ``lags`` lags only (over the same samples ``k``)."""
        return Covariances(self.sums[:, :lags], self.counts[:, :lags], self.scale, self.references, self.dt)

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


def decay_block(lags: int) -> int:
    """Samples per interleaved block of a free decay's groups: half the lag span."""
    return max(-(-lags // 2), 1)


def group_labels(n: int, groups: int, lags: int, decay: bool) -> np.ndarray:
    """Group index (n,) of every sample: contiguous segments, or for a free
    decay interleaved blocks of :func:`decay_block` samples (block b in group
    b mod groups)."""
    if not decay:
        return np.minimum(np.arange(n) * groups // n, groups - 1)
    return (np.arange(n) // decay_block(lags)) % groups


def is_free_decay(y: np.ndarray) -> bool:
    """A record (m, n) that decays: a free decay rather than a stationary
    response. Each channel is scaled to unit RMS first (no one channel's
    units decide); the record decays when its first tenth carries more than
    10 times the mean square of its last tenth over all channels, or when
    one channel's does more than a stationary record's would by chance
    (:func:`decaying_channel`: a channel free of the slow modes that hold
    the pooled ratio down)."""
    y = unit_rms(y)
    tenth = max(y.shape[1] // 10, 1)
    first, last = np.mean(y[:, :tenth] ** 2), np.mean(y[:, -tenth:] ** 2)
    return bool(first > 10.0 * last) or decaying_channel(y)


def decay_shown(y: np.ndarray) -> bool:
    """Whether one channel of a record (m, n), scaled to unit RMS, decays
    beyond a stationary record's chance (:func:`decaying_channel`). A record
    that :func:`is_free_decay` takes for a decay by its pooled first-to-last
    ratio alone may be a slow, lightly damped random response (the ratio of
    a mode holding about one decay time of the record exceeds 10 by chance):
    fits that assume a free response (the ML refinement, its residual
    terms, the residual search) are not run on it unless it is labelled one.
    Implies :func:`is_free_decay`."""
    return decaying_channel(unit_rms(y))


def unit_rms(y: np.ndarray) -> np.ndarray:
    """A record (m, n) with each channel divided by its RMS (about zero)."""
    return y / np.maximum(np.sqrt(np.mean(y**2, axis=1, keepdims=True)), np.finfo(float).tiny)


def decaying_channel(z: np.ndarray) -> bool:
    """Whether a channel of ``z`` (m, n) has a first tenth's mean square
    ``F_i`` over its last tenth's ``L_i`` (``N = n // 10`` samples each) beyond
    ``f.isf(DECAY_ALPHA / m, d_i, d_i)``: the F law of the ratio of two
    mean squares of a stationary Gaussian record, each with ``d_i = N / S_i``
    degrees of freedom, ``S_i = 1 + 2 sum_{k<N} (1 - k/N) rho_ik^2`` (the
    variance of a mean of ``N`` squares over the white case's; ``rho_ik``
    the channel's autocorrelation). A stationary record passes with
    probability about ``DECAY_ALPHA``; a slow, lightly damped random
    response has few degrees of freedom and needs a large ratio. Fails to see
    a free decay whose every channel carries a mode that hardly decays."""
    m, n = z.shape
    tenth = max(n // 10, 1)
    first, last = np.mean(z[:, :tenth] ** 2, axis=1), np.mean(z[:, -tenth:] ** 2, axis=1)
    centred = z - z.mean(axis=1, keepdims=True)
    size = sfft.next_fast_len(2 * n, real=True)  # no wrap-around
    ac = irfft(np.abs(rfft(centred, n=size, axis=1)) ** 2, n=size, axis=1)[:, :tenth]
    rho = np.divide(ac, ac[:, :1], out=np.zeros_like(ac), where=ac[:, :1] > 0)
    k = np.arange(1, tenth)
    dof = tenth / (1.0 + 2.0 * np.sum((1.0 - k / tenth) * rho[:, 1:] ** 2, axis=1))
    return bool(np.any(first > stats.f.isf(DECAY_ALPHA / m, dof, dof) * last))


def stationary_piece(usable: int, groups: int, lags: int, m: int, r: int) -> int:
    """Reference samples per FFT piece of a stationary record of ``usable``
    reference samples in ``groups`` contiguous groups, ``m`` channels and
    ``r`` references: of lengths from a 16th of the lag span up to
    ``max(lags, 4096)`` (at most a group's share), the one of least work:
    each piece's forward transforms (``m + r`` series of ``F log F``) and
    cross spectra (``m r F / 2`` complex products, counted as ``0.8 m r
    F``), each group's inverse transform (``m r`` series), ``F`` the next
    fast length of at least ``piece + lags + 1``. A long record takes long
    pieces (its forward transforms dominate); a short one, whose ``m r``
    inverse series dominate, short ones."""
    share = -(-usable // groups)
    longest = min(max(lags, 4096), share)
    pieces = np.unique(np.geomspace(max(1, min(longest, lags // 16)), longest, 24).astype(int))
    sizes = np.array([sfft.next_fast_len(int(piece) + lags + 1, real=True) for piece in pieces])
    work = (groups * -(-share // pieces) * ((m + r) * np.log2(sizes) + 0.8 * m * r)
            + groups * m * r * np.log2(sizes)) * sizes
    return int(pieces[np.argmin(work)])


def _runs(labels: np.ndarray, piece: int) -> list[tuple[int, int, int]]:
    """(start, stop, group) of the runs of equal ``labels``, cut into pieces of at most ``piece`` samples."""
    edges = np.r_[0, np.flatnonzero(np.diff(labels)) + 1, labels.size]
    return [(a, min(a + piece, b), int(labels[a])) for a, b in zip(edges[:-1], edges[1:])
            for a in range(a, b, piece)]


def covariances(records: list[np.ndarray], dt: float, lags: int, references: int, groups: int) -> Covariances:
    """Lagged covariance sums (see :class:`Covariances`) of one or more
    records (each (m, n_i), same channels, sampling interval ``dt`` s), for
    lags 1..``lags``; several records add up as independent tests.

    Computed by FFT, segment by segment: for a piece of ``S`` reference
    samples starting at ``a``, ``sum_k y_{a+k+l} y_ref,a+k^T`` for every lag
    ``l <= L`` is the inverse FFT (length ``F >= S + L``, no wrap-around) of
    ``Y(f) conj(Y_ref(f))^T``, the spectra of the ``S + L`` samples ahead and of
    the zero-padded reference piece; the cross spectra add over a group's
    pieces before one inverse FFT. About ``8 m r n`` flops plus the FFTs,
    against ``2 L m r n`` lag by lag."""
    m = records[0].shape[0]
    total = sum(np.einsum("ij,ij->i", y, y) for y in records)
    scale = np.sqrt(total / sum(y.shape[1] for y in records))
    scale = np.where(scale > 0, scale, 1.0)
    refs = reference_channels(m, references)
    sums = np.zeros((groups, lags, m, refs.size))
    counts = np.zeros((groups, lags))
    for y in records:
        usable = y.shape[1] - lags  # the same reference samples k for every lag keep R_l = C A^(l-1) G exact
        decay = is_free_decay(y)
        piece = decay_block(lags) if decay else stationary_piece(usable, groups, lags, m, refs.size)
        size = sfft.next_fast_len(piece + lags + 1, real=True)
        runs = _runs(group_labels(usable, groups, lags, decay), piece)
        for g in range(groups):
            mine = [(a, b) for a, b, h in runs if h == g]
            if mine:
                sums[g] += _lagged_sums(y, scale, refs, mine, lags, size)
                counts[g] += sum(b - a for a, b in mine)
    return Covariances(sums, counts, scale, refs, dt)


def _lagged_sums(y: np.ndarray, scale: np.ndarray, refs: np.ndarray, pieces: list[tuple[int, int]],
                 lags: int, size: int) -> np.ndarray:
    """``sum over pieces, k in [a, b) of z_{k+l} z_ref,k^T`` (lags, m, r) of the
    standardised record ``z = y / scale`` by FFTs of length ``size``, a few
    pieces at a time (about 2 million samples)."""
    m = y.shape[0]
    cross = np.zeros((m, refs.size, size // 2 + 1), dtype=complex)
    batch = max(1, 2_000_000 // (m * size))
    for i in range(0, len(pieces), batch):
        chunk = pieces[i:i + batch]
        ahead = np.zeros((len(chunk), m, size))
        for s, (a, b) in enumerate(chunk):
            ahead[s, :, :b - a + lags] = y[:, a:b + lags]
        ahead /= scale[:, None]
        ref = ahead[:, refs]
        for s, (a, b) in enumerate(chunk):
            ref[s, :, b - a:] = 0.0
        cross += np.einsum("saf,scf->acf", rfft(ahead, axis=2), rfft(ref, axis=2).conj(), optimize=True)
    return irfft(cross, n=size, axis=2)[:, :, 1:lags + 1].transpose(2, 0, 1)


def row_projection(R: np.ndarray, count: int) -> np.ndarray | None:
    """The ``count`` principal directions (m, count) of the lagged covariances
    ``R`` (L, m, r): the leading eigenvectors of ``sum_l R_l R_l^T``, the
    channel combinations that carry the structural response (white sensor
    noise, absent from ``R_l``, l >= 1, adds nothing there). ``None`` (every
    channel) when ``count >= m``."""
    m = R.shape[1]
    if count >= m:
        return None
    flat = R.transpose(1, 0, 2).reshape(m, -1)
    return np.linalg.eigh(flat @ flat.T)[1][:, ::-1][:, :count]


def project(R: np.ndarray, W: np.ndarray | None) -> np.ndarray:
    """``W^T R_l`` (L, k, r) for every lag, or ``R`` itself when ``W`` is None."""
    return R if W is None else np.einsum("mk,lmr->lkr", W, R)
