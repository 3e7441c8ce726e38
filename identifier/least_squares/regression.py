"""The equations of motion as a regression, assembled row by row and streamed over samples.

Row ``(k, r)`` (sample time ``t_k``, DOF ``r``) of the augmented regression
``Y = [B | F]`` has one entry per column ``j`` (parameter, or the force
column last) whose matrix touches DOF ``r``; each entry is a linear
combination of the *raw channels* ``x = [a, v, u, f]`` (4 n per sample):

    Y[(k, r), j] = sum_c W[c, (r, j)] x[k, c]

with ``W`` from the model's assembly triplets (mass: ``a + alpha v``;
damping: ``v``; stiffness: ``u + beta v``; Rayleigh ``alpha M + beta K``;
force column: ``f_r``). With ``theta = [p; -1]`` the equation error is
``e[k, r] = Y[(k, r), :] theta = (M a + C v + K u - f)_r``.

Per DOF row the entries form a small dense block ``Y_r`` (samples, slots),
so the Gram matrix ``Y^T diag(w^2) Y = sum_r Y_r^T diag(w_r^2) Y_r`` is one
batched matrix product per chunk of samples: time O(m n s^2) and memory
O(chunk n s) for ``m`` samples, ``n`` DOF and ``s`` slots per row (about 4-9
for beams). The expected noise part of that Gram matrix, for independent
zero-mean channel noise of variance ``sigma^2[k, c]``, is

    D = sum_{k, r} w[k, r]^2 W_r^T diag(sigma^2[k]) W_r,

which only needs ``sum_k w[k, r]^2 sigma^2[k, c]`` per (row, channel) pair.
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from structbench.models import Structure

BLOCKS = ("acceleration", "velocity", "displacement", "force")
DENSE_COLUMNS = 1000  # unknowns solved by a dense factorisation up to this many, sparse beyond
DENSE_DOF = 400  # DOF-coupled (dense n x n) noise whitening up to this many DOF, diagonal beyond
CHUNK_VALUES = 4_000_000  # floats per chunk of the (DOF, slots, samples) block


@dataclass(frozen=True)
class Layout:
    """Where the regression's entries come from. ``W`` (4 n, n_pairs) maps
    raw channels to (row, column) pairs; ``pair_row``, ``pair_col`` (n_pairs,);
    ``slots`` (n, s) pair index per row slot (``n_pairs`` pads); ``to_slots``
    (n s, 4 n) is ``W^T`` laid out by slot (pads: empty rows); ``A``
    (n_rc, n_pairs) is ``W`` regrouped by (row, channel) pair ``rc_row``,
    ``rc_chan``; ``n_columns`` = parameters + 1 (force)."""

    n_dof: int
    n_columns: int
    W: sp.csr_matrix
    pair_row: np.ndarray
    pair_col: np.ndarray
    slots: np.ndarray
    to_slots: sp.csr_matrix
    A: sp.csr_matrix
    rc_row: np.ndarray
    rc_chan: np.ndarray

    @property
    def P(self) -> sp.csr_matrix:
        """(n_pairs, n_columns): pair -> column."""
        n_pairs = self.pair_col.size
        return sp.csr_matrix((np.ones(n_pairs), (np.arange(n_pairs), self.pair_col)),
                             shape=(n_pairs, self.n_columns))

    @property
    def slot_to_column(self) -> sp.csr_matrix:
        """(n s, n_columns): slot -> column (pads: empty rows)."""
        flat = self.slots.ravel()
        live = np.flatnonzero(flat < self.pair_col.size)
        return sp.csr_matrix((np.ones(live.size), (live, self.pair_col[flat[live]])),
                             shape=(flat.size, self.n_columns))

    def chunk(self, m: int) -> int:
        """Samples per chunk."""
        return max(1, min(m, CHUNK_VALUES // max(1, self.slots.size, self.rc_row.size)))


def layout(model: Structure) -> Layout:
    """The regression layout of ``model`` (its assembly triplets and Rayleigh factors)."""
    n, n_par = model.n_dof, len(model.parameters)
    par, rows, cols, vals = model.triplets
    alpha, beta = model.rayleigh
    kind = np.array([p.kind for p in model.parameters])[par]
    acc, vel, disp, frc = (q * n for q in range(4))
    parts = [(kind == "mass", acc + cols, vals), (kind == "mass", vel + cols, alpha * vals),
             (kind == "damping", vel + cols, vals), (kind == "stiffness", disp + cols, vals),
             (kind == "stiffness", vel + cols, beta * vals)]
    chan = np.concatenate([c[k] for k, c, _ in parts] + [frc + np.arange(n)])
    row = np.concatenate([rows[k] for k, _, _ in parts] + [np.arange(n)])
    col = np.concatenate([par[k] for k, _, _ in parts] + [np.full(n, n_par)])
    val = np.concatenate([v[k] for k, _, v in parts] + [np.ones(n)])
    keep = val != 0
    chan, row, col, val = chan[keep], row[keep], col[keep], val[keep]
    n_columns = n_par + 1
    pair_key, pair = np.unique(row * n_columns + col, return_inverse=True)
    pair_row, pair_col = pair_key // n_columns, pair_key % n_columns
    n_pairs = pair_key.size
    W = sp.csr_matrix((val, (chan, pair)), shape=(4 * n, n_pairs))
    counts = np.bincount(pair_row, minlength=n)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    width = max(1, counts.max(initial=1))
    slot_of_pair = pair_row * width + np.arange(n_pairs) - start[pair_row]  # pair_key sorted by row
    slots = np.full(n * width, n_pairs)
    slots[slot_of_pair] = np.arange(n_pairs)
    to_slots = sp.csr_matrix((val, (slot_of_pair[pair], chan)), shape=(n * width, 4 * n))
    rc_key, rc = np.unique(row * 4 * n + chan, return_inverse=True)
    A = sp.csr_matrix((val, (rc, pair)), shape=(rc_key.size, n_pairs))
    return Layout(n, n_columns, W, pair_row, pair_col, slots.reshape(n, width), to_slots, A,
                  rc_key // (4 * n), rc_key % (4 * n))


def raw(motion, where: slice) -> np.ndarray:
    """Raw channels ``[a, v, u, f]`` of samples ``where``, transposed: (4 n, m_chunk), C order
    (sparse products copy operands in any other order)."""
    n, m = motion.force.shape[1], len(range(*where.indices(motion.force.shape[0])))
    x = np.empty((4 * n, m))
    for i, q in enumerate(BLOCKS):
        x[i * n:(i + 1) * n] = getattr(motion, q)[where].T
    return x


def raw_variance(motion, where: slice) -> np.ndarray:
    """Noise variance of the raw channels, (4 n, m_chunk), C order; zero where undeclared."""
    n, m = motion.force.shape[1], len(range(*where.indices(motion.force.shape[0])))
    x = np.zeros((4 * n, m))
    for i, q in enumerate(BLOCKS):
        if q in motion.sigma:
            np.square(motion.sigma[q][where].T, out=x[i * n:(i + 1) * n])
    return x


def rows(lay: Layout, x: np.ndarray) -> np.ndarray:
    """Blocks ``Y_r^T`` of a chunk ``x`` (4 n, m_chunk): (n, s, m_chunk)."""
    return np.asarray(lay.to_slots @ x).reshape(lay.n_dof, lay.slots.shape[1], x.shape[1])


def chunks(lay: Layout, m: int) -> Iterator[slice]:
    step = lay.chunk(m)
    return (slice(k, min(m, k + step)) for k in range(0, m, step))


@dataclass(frozen=True)
class Moments:
    """One pass over the samples: per DOF row the block ``Y_r^T Y_r`` (n, s, s)
    and per raw channel the summed noise variance ``sum_k sigma^2[c, k]`` (4 n,);
    ``samples``: m; ``raw_gram``: ``X^T X`` (4 n, 4 n) when asked for."""

    blocks: np.ndarray
    noise: np.ndarray
    samples: int
    raw_gram: np.ndarray | None = None


def moments(lay: Layout, motion, raw_gram: bool = False) -> Moments:
    """The :class:`Moments` of ``motion`` (streamed over chunks of samples);
    with ``raw_gram`` also ``X^T X`` (4 n, 4 n) of the raw channels."""
    m = motion.force.shape[0]
    blocks = np.zeros((lay.n_dof, lay.slots.shape[1], lay.slots.shape[1]))
    noise = np.zeros(4 * lay.n_dof)
    xtx = np.zeros((4 * lay.n_dof, 4 * lay.n_dof)) if raw_gram else None
    for where in chunks(lay, m):
        x = raw(motion, where)
        y = rows(lay, x)
        blocks += np.matmul(y, y.transpose(0, 2, 1))
        if xtx is not None:
            xtx += x @ x.T
    for i, q in enumerate(BLOCKS):  # sum_k sigma^2, without the (4 n, m) copy
        if q in motion.sigma:
            noise[i * lay.n_dof:(i + 1) * lay.n_dof] = np.einsum("kn,kn->n", motion.sigma[q], motion.sigma[q])
    return Moments(blocks, noise, m, xtx)


def _scatter(lay: Layout, blocks: np.ndarray) -> sp.csr_matrix:
    """Per-row (n, s, s) blocks summed into the (n_columns, n_columns) matrix."""
    col = np.append(lay.pair_col, lay.n_columns)[lay.slots]  # padding -> an extra column, dropped
    i = np.broadcast_to(col[:, :, None], blocks.shape).ravel()
    j = np.broadcast_to(col[:, None, :], blocks.shape).ravel()
    size = lay.n_columns + 1
    return sp.csr_matrix((blocks.ravel(), (i, j)), shape=(size, size))[:-1, :-1]


def gram(lay: Layout, mom: Moments, weights: np.ndarray | None = None) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """``G = Y^T diag(w^2) Y`` and its expected noise part ``D``, each
    (n_columns, n_columns) sparse; ``weights`` per DOF row (n,) or None (all ones)."""
    w2 = np.ones(lay.n_dof) if weights is None else weights**2
    AP = lay.A @ lay.P
    D = (AP.T @ sp.diags(mom.noise[lay.rc_chan] * w2[lay.rc_row]) @ AP).tocsr()
    return _scatter(lay, mom.blocks * w2[:, None, None]), D


def scores(lay: Layout, motion, theta: np.ndarray,
           weights: np.ndarray | None = None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Per sample, the estimating-function terms ``g_k = sum_r w_r^2 (Y_kr e_kr - W_r^T diag(sigma_k^2) W_r theta)``,
    transposed (n_columns, m_chunk), and the equation errors ``e`` (n, m_chunk) in N, chunk by chunk.

    At the true ``theta`` each ``g_k`` has zero mean; with noise white in time
    they are independent, so ``sum_k g_k g_k^T`` estimates the covariance of
    ``sum_k g_k`` (the "meat" of a sandwich covariance).
    """
    m = motion.force.shape[0]
    n, s = lay.slots.shape
    w2 = np.ones(n) if weights is None else weights**2
    theta_slot = np.append(theta[lay.pair_col], 0.0)[lay.slots]  # (n, s)
    to_col = lay.slot_to_column.T.tocsr()
    AP = (lay.A @ lay.P).tocsr()
    hw = (AP @ theta) * w2[lay.rc_row]  # (n_rc,): w_r^2 sum_j W[c, (r, j)] theta_j
    spread = (AP.T @ sp.csr_matrix((hw, (np.arange(hw.size), lay.rc_chan)),
                                   shape=(hw.size, 4 * n))).tocsr()  # (n_columns, 4 n)
    for where in chunks(lay, m):
        y = rows(lay, raw(motion, where))
        e = np.einsum("rsk,rs->rk", y, theta_slot)  # equation error, N
        first = to_col @ (y * (w2[:, None] * e)[:, None, :]).reshape(n * s, -1)
        yield first - spread @ raw_variance(motion, where), e


def error_variance(lay: Layout, mom: Moments, theta: np.ndarray) -> np.ndarray:
    """Variance of the equation error at each DOF row, averaged over the samples,
    from the channel noise at ``theta``, (n,) N^2:
    ``sum_c (sum_j W[c, (r, j)] theta_j)^2 mean_k sigma^2[c, k]``."""
    h2 = (lay.A @ lay.P @ theta) ** 2
    return np.bincount(lay.rc_row, h2 * mom.noise[lay.rc_chan] / mom.samples, minlength=lay.n_dof)
