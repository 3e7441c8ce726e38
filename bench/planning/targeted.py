"""Targeted sensor layouts: the channels that minimise the predicted
relative variances of the natural frequencies a user asks for
(A-optimality on those quantities of the modal bound).

On the relative information of :mod:`.layouts` (each candidate ``c`` a block
``I_c`` (2R, 2R) on ``(alpha_r / omega_r, wd_r / omega_r)``) the objective of a
layout ``S`` is the sum over the target modes ``r`` (the lowest ``T`` planned)
(or any set of ``T`` planned modes) of ``var(omega_r) / omega_r^2`` of the
Cramer-Rao bound,

    f(S) = tr(G^T (eps I + sum_{c in S} I_c)^-1 G),   G (2R, T),

column ``r`` of ``G`` holding ``d(omega_r / omega_r0) / d(alpha'_r, wd'_r) =
(zeta_r, sqrt(1 - zeta_r^2))`` in rows ``2r, 2r + 1`` (``omega = sqrt(alpha^2 +
wd^2)``). ``f`` is the square of the layout's predicted RMS relative
frequency error times ``T``: the user's figure of merit, not the volume of
the whole confidence region (D-optimality) that also weighs damping and
the modes not asked for.

Chosen greedily (the channel that most lowers ``f``), then exchange passes
(each chosen channel swapped for the best other while that lowers ``f``),
at most one channel per location. Each step evaluates ``f(J + I_c)`` for
every allowed candidate: exactly (a batched solve, O(C R^3)) when at most
:data:`SHORTLIST` are allowed; above that the candidates are ranked by the
decoupled-mode value (each mode's 2 x 2 block of ``J + I_c`` alone,
``g_r^T B_rc^-1 g_r``, O(C R)) and the best :data:`SHORTLIST` evaluated
exactly. A local optimum: no guarantee of the global one (exhaustive
search is combinatorial). Fails (``ValueError``) for ``T`` < 1 or above R.

Ties: the planning model's modes carry rounding differences between runs
(a threaded eigensolver: 1e-10 relative in the amplitudes of a 1,000-DOF
beam), so two candidates whose scores differ by less than :data:`TIE`
(relative) count as equal and the lower candidate index wins
(:func:`tied_order`): the same input gives the same layout.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

SHORTLIST = 64  # candidates evaluated exactly per step; above: screened by the decoupled-mode value
EXCHANGE_PASSES = 5
TIE = 1e-6  # scores closer than this (relative; absolute on a log det) count as equal: lower index first


def tied_order(values: np.ndarray, tol: float) -> np.ndarray:
    """Ascending order of ``values`` (n,) in which values chained by gaps of
    at most ``tol`` (absolute, >= 0) count as equal and keep their positions'
    order: positions (n,) of ints. Non-finite values each form their own group."""
    o = np.argsort(values, kind="stable")
    with np.errstate(invalid="ignore"):
        new = ~(np.diff(values[o]) <= tol)
    group = np.empty(values.size, dtype=int)
    group[o] = np.concatenate([[0], np.cumsum(new)])
    return np.lexsort((np.arange(values.size), group))


def target_matrix(zeta: np.ndarray, count: int, modes: np.ndarray | None = None) -> np.ndarray:
    """``G`` (2R, T) of the module docstring for damping ratios ``zeta`` (R,):
    the target modes are the lowest ``count`` (T = count), or the mode indices
    ``modes`` (T,) when given (distinct, in 0..R-1; ``count`` then unused)."""
    R = zeta.size
    if modes is None:
        if not 1 <= count <= R:
            raise ValueError(f"target modes must be between 1 and {R}, got {count}")
        modes = np.arange(count)
    modes = np.asarray(modes, dtype=int)
    if not modes.size or np.unique(modes).size != modes.size or modes.min() < 0 or modes.max() >= R:
        raise ValueError(f"target modes must be distinct indices in 0..{R - 1}, got {modes.tolist()}")
    G = np.zeros((2 * R, modes.size))
    t = np.arange(modes.size)
    G[2 * modes, t], G[2 * modes + 1, t] = zeta[modes], np.sqrt(1.0 - zeta[modes] ** 2)
    return G


def objective(J: np.ndarray, G: np.ndarray) -> float:
    """``tr(G^T J^-1 G)`` for one information ``J`` (2R, 2R); inf if singular."""
    try:
        return float(np.trace(G.T @ np.linalg.solve(J, G)))
    except np.linalg.LinAlgError:
        return np.inf


def _exact(J: np.ndarray, blocks: np.ndarray, G: np.ndarray) -> np.ndarray:
    """``f(J + I_c)`` (m,) for ``blocks`` (m, 2R, 2R)."""
    M = J[None] + blocks
    X = np.linalg.solve(M, np.broadcast_to(G, (blocks.shape[0],) + G.shape))
    return np.einsum("it,mit->m", G, X)


def mode_blocks(M: np.ndarray) -> np.ndarray:
    """Each mode's 2 x 2 diagonal block of ``M`` (..., 2R, 2R) as ``(p, q, s)``
    (..., R, 3): ``[[p, q], [q, s]]``."""
    R = M.shape[-1] // 2
    r = np.arange(R)
    return np.stack([M[..., 2 * r, 2 * r], M[..., 2 * r, 2 * r + 1], M[..., 2 * r + 1, 2 * r + 1]], axis=-1)


def _decoupled(J: np.ndarray, blocks: np.ndarray, G: np.ndarray) -> np.ndarray:
    """Approximate ``f(J + I_c)`` (m,) from the candidates' mode blocks
    ``blocks`` (m, R, 3): each target mode's 2 x 2 block alone."""
    r = np.argmax(G[1::2] != 0, axis=0)  # column t's mode (its wd row is sqrt(1 - zeta^2) > 0)
    t = np.arange(G.shape[1])
    pqs = mode_blocks(J)[None, r] + blocks[:, r]
    p, q, s = pqs[..., 0], pqs[..., 1], pqs[..., 2]
    g0, g1 = G[2 * r, t], G[2 * r + 1, t]
    with np.errstate(divide="ignore", invalid="ignore"):
        val = (s * g0**2 - 2 * q * g0 * g1 + p * g1**2) / (p * s - q**2)
    return np.where(np.isfinite(val) & (val > 0), val, np.inf).sum(axis=1)


def best_addition(J: np.ndarray, info: np.ndarray, blocks: np.ndarray, allowed: np.ndarray,
                  G: np.ndarray) -> tuple[int, float]:
    """The allowed candidate (index into ``info``; ``blocks`` its
    :func:`mode_blocks`) of least ``f(J + I_c)`` and that value."""
    idx = np.flatnonzero(allowed)
    if idx.size > SHORTLIST:
        approx = _decoupled(J, blocks[idx], G)
        finite = approx[np.isfinite(approx)]
        tol = TIE * (float(finite.min()) if finite.size else 1.0)
        idx = np.sort(idx[tied_order(approx, tol)[:SHORTLIST]])
    val = _exact(J, info[idx], G)
    finite = val[np.isfinite(val)]
    i = int(tied_order(val, TIE * (float(np.abs(finite).min()) if finite.size else 1.0))[0])
    return int(idx[i]), float(val[i])


def greedy_exchange(info: np.ndarray, ridge: np.ndarray, locations: np.ndarray, k: int,
                    best: Callable[[np.ndarray, np.ndarray], tuple[int, float]],
                    better: Callable[[float, np.ndarray], bool], passes: int) -> list[int]:
    """Indices of ``k`` candidates (at most one per location): greedy
    additions of ``best(J, allowed)`` (the allowed candidate whose
    information ``info[c]`` (C, P, P) added to ``J`` scores best, and that
    score), then up to ``passes`` exchange passes, each sensor in turn
    replaced by the best one given the others where ``better(score, J)``
    (the score beats the layout ``J`` with it kept). ``ridge`` (P, P): the
    information before any sensor."""
    def allowed(taken: list[int]) -> np.ndarray:
        return ~np.isin(locations, locations[taken]) if taken else np.ones(locations.size, bool)

    chosen: list[int] = []
    J = ridge.copy()
    for _ in range(k):
        j, _ = best(J, allowed(chosen))
        chosen.append(j)
        J = J + info[j]
    for _ in range(passes):
        improved = False
        for pos in range(k):
            rest = chosen[:pos] + chosen[pos + 1:]
            J_rest = ridge + info[rest].sum(axis=0)
            j, val = best(J_rest, allowed(rest))
            if j != chosen[pos] and better(val, J_rest + info[chosen[pos]]):
                chosen[pos], improved = j, True
        if not improved:
            break
    return chosen


def targeted(info: np.ndarray, zeta: np.ndarray, locations: np.ndarray, k: int, eps: float,
             count: int, modes: np.ndarray | None = None) -> list[int]:
    """Indices of ``k`` candidates (at most one per location) minimising the
    summed relative frequency variances of the lowest ``count`` modes (or of
    the mode indices ``modes``): greedy, then exchange passes (module
    docstring). ``info`` (C, 2R, 2R) relative, ``zeta`` (R,), ``locations``
    (C,) ids, ``eps`` the ridge."""
    G = target_matrix(zeta, count, modes)
    blocks = mode_blocks(info)
    return greedy_exchange(info, eps * np.eye(info.shape[1]), locations, k,
                           lambda J, allowed: best_addition(J, info, blocks, allowed, G),
                           lambda val, J: val < objective(J, G) * (1 - 1e-9), EXCHANGE_PASSES)
