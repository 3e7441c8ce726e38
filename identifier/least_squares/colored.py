"""Bias-compensated least squares when the regression's noise is coloured in time
and correlated between slots (prefiltered equations, :mod:`identifier.least_squares.prefilter`).

Model. Every record holds white noise sources: per response DOF one
measured channel (noise ``sigma_l``, (m,) per sample) reaching the ``a``,
``v``, ``u`` slots of that DOF through slot filters ``h_a``, ``h_v``,
``h_u``; per forced DOF one force channel through ``h_f``. The raw slot
noise ``xi_k`` (4 n,) is then correlated in time and between the slots of
a DOF; only its summed second moments enter the estimator:

    V[c, c'] = sum_k E[xi_k[c] xi_k[c']]   (4 n, 4 n, sparse: slots of one DOF)

(:func:`identifier.least_squares.prefilter.noise_sums`).

Equations. With ``theta = [p; -1]``, ``Mt(theta)`` (4 n, n) and ``W``, ``P``
from :mod:`identifier.least_squares.regression`, the whitened Gram matrix
of the equations ``G = sum_k B_k^T Omega B_k`` and its expected noise part

    D = P^T ((W^T V W) o Omega[row_p, row_q]) P

give the estimate ``(G - D)_uu p_u = (G - D)_uf - (G - D)_uk p_k`` as in
:mod:`identifier.least_squares.bias_compensated`. ``Omega`` is the inverse
of the time-averaged covariance of one sample's equation errors,
``S = Mt^T (V / m) Mt``, at the previous estimate (full up to
:data:`identifier.least_squares.regression.DENSE_DOF` DOF, its diagonal
beyond); the first solution is unweighted.

Standard errors. To first order in the noise the estimating function is
``z = sum_k B_k^T Omega Mt^T xi_k``, and ``xi`` is a filtered white
sequence, so with ``y_k^(i) = Mt(rho_i)^T x_k`` for row ``rho_i`` of
``H^-1`` (``H = (G - D)_uu``; ``x_k`` the raw slots) and
``g_k^(i) = Mt Omega y_k^(i)`` (4 n,),

    var(p_i) = sum_sources sum_l sigma_l^2 (sum_slots (h_slot^T g^(i))_l)^2,

``h^T`` the adjoint (time-reversed) slot filter: exact to first order for
noise correlated over the whole record, unlike the per-sample sandwich.
Time O(n_u m n (n + s)) for ``n_u`` unknowns; the raw slots of every record
are kept in memory. Neglected: terms of second order in the noise
(relative size about the noise-to-signal ratio of the equations).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from structbench.models import Structure

from .bias_compensated import _check_rank, _solve, _Solver, _theta
from .estimate import Estimate
from .identifiability import check_count, check_excited
from . import offsets as nuisance
from .prefilter import SlotFilter, noise_sums
from .regression import DENSE_DOF, Layout, gram, layout, moments, raw
from . import whitened

REWEIGHTINGS = 3
BATCH = 8  # unknowns per pass of the standard errors
BATCH_VALUES = 4_000_000  # floats of the per-unknown equation matrices in one pass


@dataclass(frozen=True)
class Source:
    """White noise ``sigma`` (m, c) of ``c`` channels at DOF ``dofs`` (c,),
    reaching raw-channel blocks ``blocks`` (0 a, 1 v, 2 u, 3 f) through ``filters``."""

    dofs: np.ndarray
    sigma: np.ndarray
    blocks: tuple[int, ...]
    filters: tuple[SlotFilter, ...]


@dataclass(frozen=True)
class Record:
    """One record's filtered slots (``motion``: a
    :class:`identifier.least_squares.Motion`) and its noise sources;
    ``steps``: its offset signatures
    (:class:`identifier.least_squares.offsets.Steps`), or None; ``projected``:
    the free ones are out of its slots (its offsets get estimated)."""

    motion: object
    sources: tuple[Source, ...]
    steps: object = None
    projected: bool = False


def noise_gram(records: list[Record], n: int) -> sp.csr_matrix:
    """``V`` (4 n, 4 n): summed second moments of the raw slot noise (after
    the records' projections, :mod:`identifier.least_squares.offsets`)."""
    rows, cols, vals = [], [], []
    for rec in records:
        m = rec.motion.force.shape[0]
        for src in rec.sources:
            h = [f.impulse(m) for f in src.filters]
            for i, bi in enumerate(src.blocks):
                for j, bj in enumerate(src.blocks):
                    rows.append(bi * n + src.dofs)
                    cols.append(bj * n + src.dofs)
                    vals.append(noise_sums(src.sigma, h[i], h[j]) - (
                        0.0 if not rec.projected else
                        nuisance.noise_correction(src.sigma, rec.steps.U, src.filters[i], src.filters[j])))
    if not rows:
        return sp.csr_matrix((4 * n, 4 * n))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(4 * n, 4 * n))


def _noise_part(lay: Layout, V: sp.csr_matrix, omega: np.ndarray | None) -> sp.csr_matrix:
    """``D`` for the weighting ``omega`` (n, n) or, None, unweighted."""
    Wc = lay.W.tocsc()
    noisy = sp.coo_matrix(Wc.T @ V @ Wc)  # (n_pairs, n_pairs), sparse: pairs sharing a noisy DOF
    ri, rj = lay.pair_row[noisy.row], lay.pair_row[noisy.col]
    coupling = (ri == rj).astype(float) if omega is None else omega[ri, rj]
    noisy = sp.csr_matrix((noisy.data * coupling, (noisy.row, noisy.col)), shape=noisy.shape)
    return sp.csr_matrix(lay.P.T @ noisy @ lay.P)


class _System:
    """``G`` and ``D``, unweighted or whitened at ``theta``."""

    def __init__(self, lay: Layout, motion, V: sp.csr_matrix):
        self.lay, self.V, self.full, self.motion = lay, V, lay.n_dof <= DENSE_DOF, motion
        self.mom = moments(lay, motion, raw_gram=self.full)
        self.omega: np.ndarray | None = None

    def gram(self, theta: np.ndarray | None) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        if theta is None:
            return gram(self.lay, self.mom)[0], _noise_part(self.lay, self.V, None)
        mt = whitened.equation_matrix(self.lay, theta)
        S = mt.T @ (self.V @ mt) / self.mom.samples
        S[np.diag_indices_from(S)] += 1e-9 * np.trace(S) / S.shape[0] + np.finfo(float).tiny
        if self.full:
            self.omega = la.inv(S)
            G = whitened.gram(self.lay, self.mom.raw_gram, np.zeros(4 * self.lay.n_dof), self.omega)[0]
        else:
            w = 1.0 / np.sqrt(np.diag(S))
            self.omega = np.diag(w**2)
            G = gram(self.lay, self.mom, w)[0]
        return G, _noise_part(self.lay, self.V, self.omega)


def _std_errors(lay: Layout, records: list[Record], theta: np.ndarray, omega: np.ndarray | None,
                mask: np.ndarray, solver: _Solver) -> np.ndarray:
    """First-order standard errors (n_u,) for coloured noise (module docstring),
    :data:`BATCH` unknowns at a time (fewer on large models)."""
    n = lay.n_dof
    u = np.flatnonzero(mask)
    mt = whitened.equation_matrix(lay, theta)
    om = np.eye(n) if omega is None else omega
    rho = solver(np.eye(u.size))  # H^-1 (symmetric: its rows are its columns)
    var = np.zeros(u.size)
    step = max(1, min(BATCH, BATCH_VALUES // (4 * n * n)))
    for start in range(0, u.size, step):
        batch = np.arange(start, min(u.size, start + step))
        coef = np.zeros((theta.size, batch.size))
        coef[u] = rho[:, batch]
        mts = np.stack([whitened.equation_matrix(lay, c) for c in coef.T])  # (k, 4 n, n)
        for rec in records:
            x = raw(rec.motion, slice(None)).T  # (m, 4 n)
            y = np.einsum("mc,kcn->mnk", x, mts, optimize=True)
            g = np.einsum("mnk,nr,cr->mck", y, om, mt, optimize=True)  # (m, 4 n, k)
            for src in rec.sources:
                c = sum(f(g[:, b * n + src.dofs], reverse=True) for b, f in zip(src.blocks, src.filters))
                var[batch] += np.einsum("ml,mlk->k", src.sigma**2, c**2)
    return np.sqrt(var)


def solve_colored(model: Structure, records: list[Record], weighting: str = "noise",
                  rcond: float = 1e-7, start: Estimate | None = None) -> Estimate:
    """Unknown parameters (``model.kind_mask()``) from the filtered records by
    bias-compensated least squares with coloured noise (module docstring);
    projected records (``projected``) get their offsets estimated
    too (:mod:`identifier.least_squares.offsets`: ``details["offset_values"]``,
    (n per record,)), iterating from ``start`` (an earlier estimate) if given."""
    mask = model.kind_mask()
    labels = [p.label for p, k in zip(model.parameters, mask) if k]
    known = model.values[~mask]
    lay = layout(model)
    V = noise_gram(records, model.n_dof)
    n = model.n_dof
    steps = [r.steps if r.projected else None for r in records]

    def evaluate(p_in: np.ndarray | None, c_in: np.ndarray, first: bool):
        """One solve with the offsets' phi_(e+1) part fixed at ``(p_in, c_in)``; the offsets it implies."""
        mt = None if p_in is None else whitened.equation_matrix(lay, _theta(model, mask, p_in))
        recs = [r if s is None or mt is None or not np.any(ci) else replace(r, motion=_with_force(
            r.motion, r.motion.force + nuisance.fixed_force(s, mt, ci)))
            for r, s, ci in zip(records, steps, c_in.reshape(len(records), n))]
        fit = _solve_once(model, recs, V, lay, weighting, rcond, labels, known, mask, check=first)
        mt = whitened.equation_matrix(lay, _theta(model, mask, fit[0]))
        return np.concatenate([np.zeros(n) if s is None else nuisance.fit(s, mt) for s in steps]), fit

    with_offsets = any(s is not None for s in steps)
    c_in = np.zeros(n * len(records))
    p_in = None
    if start is not None and "offset_values" in start.details:
        p_in, c_in = start.values, np.asarray(start.details["offset_values"], dtype=float)
    xs, gs, before, scale = [], [], None, None
    for it in range(nuisance.ITERATIONS if with_offsets else 1):
        c_out, fit = evaluate(p_in, c_in, it == 0)
        if not with_offsets or (before is not None and np.max(
                np.abs(fit[0] - before) / np.maximum(np.abs(fit[0]), 1e-300)) < nuisance.TOLERANCE):
            break
        before, g = fit[0], np.concatenate([fit[0], c_out])
        if scale is None:  # parameters relative to their values, offsets to the largest one
            scale = np.concatenate([np.abs(fit[0]), np.full(c_out.size, np.max(np.abs(c_out)))]) + 1e-300
        x = g if p_in is None else np.concatenate([p_in, c_in])
        p_in, c_in = np.split(nuisance.anderson(xs, gs, x / scale, g / scale) * scale, [fit[0].size])
    c = c_out
    p_u, solver, system, noisy, condition, recs = fit
    theta = _theta(model, mask, p_u)
    std = _std_errors(lay, recs, theta, system.omega if noisy else None, mask, solver)
    motion = system.motion
    e = raw_residual(lay, motion, theta)
    label = ("noise (full DOF covariance)" if system.full else "noise (one weight per DOF row)") if noisy else "none"
    extra = {"offset_values": c, "offset_iterations": it + 1} if with_offsets else {}
    return Estimate(p_u, std, condition, e, motion.force.size,
                    {"estimator": "bias-compensated", "weighting": label,
                     "std_errors": "first-order propagation of the coloured slot noise"} | extra)


def _with_force(motion, force: np.ndarray):
    from . import Motion

    return Motion(motion.times, motion.displacement, motion.velocity, motion.acceleration, force, motion.sigma)


def _solve_once(model: Structure, records: list[Record], V: sp.csr_matrix, lay: Layout, weighting: str,
                rcond: float, labels: list[str], known: np.ndarray, mask: np.ndarray, check: bool):
    """One bias-compensated solve: ``(p_u, solver, system, noisy, condition, records)``."""
    from . import Motion

    motion = Motion.stack([r.motion for r in records])
    u = np.flatnonzero(mask)
    if check:
        check_count(motion.force.size, int(mask.sum()))
    system = _System(lay, motion, V)
    G, D = system.gram(None)
    if check:
        norms = {kind: float(np.sqrt(np.einsum("ij,ij->", x, x))) for kind, x in
                 (("mass", motion.acceleration), ("damping", motion.velocity), ("stiffness", motion.displacement))}
        check_excited(model, norms, np.sqrt(G.diagonal()[u]), labels)
    condition = _check_rank(G[u][:, u], labels, rcond)
    p_u, solver = _solve(G, D, mask, known)
    noisy = bool(abs(V).sum() > 0) and weighting == "noise"
    for _ in range(REWEIGHTINGS if noisy else 0):
        p_u, solver = _solve(*system.gram(_theta(model, mask, p_u)), mask, known)
    return p_u, solver, system, noisy, condition, records


def raw_residual(lay: Layout, motion, theta: np.ndarray) -> float:
    """RMS of the (filtered, unweighted) equation errors, N."""
    e = whitened.equation_matrix(lay, theta).T @ raw(motion, slice(None))
    return float(np.sqrt(np.mean(e**2)))
