"""Least squares with unmeasured DOF: the equations of motion on FRFs at the measured DOF.

At a line ``omega`` with the force at DOF ``f`` the receptance column ``h``
of every DOF satisfies ``Z(p) h = e_f``, ``Z = K - omega^2 M + i omega C``,
affine in the element parameters ``p``. Only the measured DOF ``s`` of ``h``
are known (``h_s``, noise variance ``V_s``); the unmeasured ones ``h_u`` are
unknown per line: the pseudo-parameters of chapter 4. For given ``p`` they
are eliminated exactly (condensation, or variable projection: the solution
for ``h_u`` is closed-form), which leaves the measured receptance of the
model, ``Hh_s(p) e_f = [Z(p)^-1 e_f]_s`` (the inverse of the condensed
dynamic stiffness ``Z_ss - Z_su Z_uu^-1 Z_us``, applied to the condensed
force). The estimate minimises the output error

    J(p) = sum_b |(h_s,b - [Z(p)^-1 e_f]_s) / sqrt(V_s,b)|^2,

the maximum likelihood for Gaussian FRF noise; errors in variables do not
arise (``h_s`` is the output, never a regressor), as in the full-DOF
output-error fit of :mod:`identifier.least_squares.frequency_output`.

Start, from the data and the topology only (no prior value): the model's
unknown values are only a shape (a topology's 1.0 for every element of a
kind, or a prior). The linear pseudo-parameter iteration: at ``p_k`` the
unmeasured responses are expanded, ``h_u = Z_uu^-1 (e_u - Z_us h_s)`` (the u
rows of the equations hold), and ``p_(k+1)`` solves the equations of
motion, linear in ``p`` for the completed ``h``, whitened by ``W_b =
diag(V_s)^(-1/2) [Z(p_k)^-1]_(s, :)``. ``W_b Z(p_k)_(:, u) = 0``: the whitened
equation error does not depend on ``h_u`` at ``p_k``, and at a fixed point
it equals the output error (``W_b (Z h - e_f) = (h_s - Hh_s e_f) /
sqrt(V_s)``); the equations stay linear. Far from the answer that
whitening (the model's resonances in the wrong places) makes plain passes
wander, so each pass is taken in a trust region (a Levenberg-Marquardt
weight toward ``p_k``, accepted when the output error falls). First one
factor per kind (mass, damping, stiffness) on the lowest lines, then every
parameter on bands widened from there to all lines (a continuation: the
lowest modes fix the coarse distribution before the higher ones are
fitted; from the whole band at once the chapter 3 beam's start stopped in
local minima), from :data:`STARTS` stiffness-to-mass ratios and
:data:`FIRST_BANDS` first bands; the start of smallest output error is
kept. Then Gauss-Newton on ``J`` with Levenberg-Marquardt steps (exact
Jacobian ``d h_s / d p_j = -[Z^-1 Z_j Z^-1 e_f]_s``).

Identifiability (the measured set may not determine every parameter): the
Gauss-Newton matrix ``A = Re(J^H J)`` at the estimate, column-scaled, has
eigenvalues below :data:`RANK_TOL` times its largest in the directions the
data do not see; parameters with weight over 1 % in them are reported as
undetermined (value NaN, no standard error; ``details["undetermined"]``).
None determined raises :class:`IdentificationError` naming them and the
unmeasured DOF.

Standard errors of the determined parameters: the larger of the sandwich
over clusters of consecutive lines (Welch lines are correlated) and the
model-based ``A^-1`` times the cost per degree of freedom, as in
:mod:`identifier.least_squares.frequency_output`.

Assumptions: as the full-DOF frequency domain (a linear, stationary
structure whose model is right; ``V_s`` right); the expanded ``h_u`` carry
the model's error while ``p`` is far off, which the pseudo-parameter
iteration corrects. Fails when: the measured set does not determine the
parameters (reported or raised as above); the start is outside the basin
of the output error (a kind-factor start far from every parameter: the
iteration then stops at a local minimum, which a large cost per degree of
freedom in ``details["output_error_cost"]`` shows); the lines are too few to
support the estimate (no more clusters of correlated lines than determined
parameters: refused, :func:`~.unmeasured_support.check_support`).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la

from structbench.models import Structure

from ..errors import IdentificationError
from .frequency import CHUNK, Equations, Lines, matrices
from .identifiability import check_count, not_identifiable
from .unmeasured_support import check_support

PSEUDO_PASSES = 30  # linear pseudo-parameter passes at most (every parameter)
FACTOR_PASSES = 10  # the same for the kind factors
MU, MAX_MU = 1e-6, 1e8  # the trust region's first and largest weight (column-scaled Gram matrix)
ITERATIONS = 60  # Gauss-Newton steps at most
STEP_TOL = 0.01  # Gauss-Newton stops when every step is below this share of its standard error
RANK_TOL = 1e-10  # eigenvalue of the column-scaled A below this share of the largest: undetermined
STARTS = (0.1, 1.0, 10.0)  # stiffness-to-mass factor ratios tried, x the median line's omega^2
FIRST_BANDS = (0.2, 1.0)  # quantile of the lines' omega where the start's continuation begins (1: no continuation)
BAND_STEP = 0.2  # quantile steps of the continuation


def _z(model: Structure, p: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """``Z(omega)`` (B, n, n) complex at parameters ``p``."""
    M, C, K = matrices(model, p)
    return K[None] - (omega**2)[:, None, None] * M[None] + 1j * omega[:, None, None] * C[None]


def _weights(lines: Lines) -> np.ndarray:
    """``1 / sqrt(V)`` (B, n); 0 at unmeasured entries (``var`` inf)."""
    with np.errstate(divide="ignore"):
        return np.where(np.isfinite(lines.var), 1.0 / np.sqrt(np.maximum(lines.var, 1e-300)), 0.0)


def expand(model: Structure, p: np.ndarray, lines: Lines) -> np.ndarray:
    """``h`` (B, n) with the unmeasured entries expanded through the model at
    ``p``: ``h_u = Z_uu^-1 (e_u - Z_us h_s)`` per block (measured entries kept)."""
    seen = np.isfinite(lines.var)
    h = lines.h.copy()
    patterns, which = np.unique(seen, axis=0, return_inverse=True)
    for k, pattern in enumerate(patterns):
        u, s = np.flatnonzero(~pattern), np.flatnonzero(pattern)
        if u.size == 0:
            continue
        b = np.flatnonzero(which.ravel() == k)
        Z = _z(model, p, lines.omega[b])
        rhs = (np.arange(model.n_dof)[None, u] == lines.force[b, None]).astype(complex)
        rhs -= np.einsum("bij,bj->bi", Z[:, u][:, :, s], h[b][:, s])
        h[np.ix_(b, u)] = np.linalg.solve(Z[:, u][:, :, u], rhs[..., None])[..., 0]
    return h


def pseudo_gram(eq: Equations, lines: Lines, p: np.ndarray, T: np.ndarray | None = None) -> np.ndarray:
    """``Re sum_b (W_b Y_b T)^H (W_b Y_b T)`` (k, k): the whitened equations
    at ``p`` with ``h_u`` expanded there (module docstring), columns mapped by
    ``T`` (n_columns, k; None: identity)."""
    h = expand(eq.model, p, lines)
    rows = _seen_rows(lines)
    inv_sd = _weights(lines)[:, rows]
    k = eq.cols if T is None else T.shape[1]
    G = np.zeros((k, k))
    for lo in range(0, lines.omega.size, CHUNK):
        part = slice(lo, lo + CHUNK)
        w = lines.omega[part]
        Hs = _inverse_rows(_z(eq.model, p, w), rows)
        Y = eq.regressor(w, h[part], lines.force[part])
        if T is not None:
            Y = Y @ T
        WY = np.matmul(inv_sd[part][:, :, None] * Hs, Y).reshape(-1, k)
        X = np.concatenate([WY.real, WY.imag])
        G += X.T @ X
    return G


def _seen_rows(lines: Lines) -> np.ndarray:
    """DOF measured in at least one block (r,)."""
    return np.flatnonzero(np.isfinite(lines.var).any(axis=0))


def _inverse_rows(Z: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Rows ``rows`` of ``Z^-1`` (B, r, n): ``Z`` is complex symmetric, so
    ``Z^-1[rows, :] = (Z^-1 E_rows)^T``, one factorisation and r right-hand sides."""
    E = np.zeros((Z.shape[0], Z.shape[1], rows.size), dtype=complex)
    E[:, rows, np.arange(rows.size)] = 1.0
    return np.ascontiguousarray(np.linalg.solve(Z, E).transpose(0, 2, 1))


def _solve_theta(G: np.ndarray) -> np.ndarray | None:
    """``x`` minimising ``[x; -1]^T G [x; -1]`` (column-scaled), None if singular."""
    d = np.sqrt(np.maximum(np.diag(G)[:-1], 1e-300))
    Gs = G[:-1, :-1] / np.outer(d, d)
    try:
        return la.solve(Gs, G[:-1, -1] / d, assume_a="sym") / d
    except (la.LinAlgError, ValueError):
        return None


def _kind_map(model: Structure, base: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """``T`` (n_columns, kinds + 1): one factor per unknown kind times ``base``,
    the known parameters and the force column fixed (last column)."""
    mask = model.kind_mask()
    kinds = [q.kind for q in model.parameters]
    groups = sorted({k for k, u in zip(kinds, mask) if u})
    T = np.zeros((len(kinds) + 1, len(groups) + 1))
    for j, (k, u) in enumerate(zip(kinds, mask)):
        T[j, groups.index(k) if u else -1] = base[j] if u else -base[j]
    T[-1, -1] = 1.0
    return T, groups


def _unknown_map(model: Structure, p: np.ndarray) -> np.ndarray:
    """``T`` (n_columns, n_u + 1): the unknown parameters free, the known ones
    at ``p`` and the force column fixed (last column)."""
    mask = model.kind_mask()
    u = np.flatnonzero(mask)
    T = np.zeros((mask.size + 1, u.size + 1))
    T[u, np.arange(u.size)] = 1.0
    T[np.flatnonzero(~mask), -1] = -p[~mask]
    T[-1, -1] = 1.0
    return T


def _iterate(eq: Equations, lines: Lines, T: np.ndarray, x: np.ndarray, tol: float,
             positive: bool = False, passes: int = PSEUDO_PASSES) -> tuple[np.ndarray, np.ndarray]:
    """The linear pseudo-parameter iteration over ``theta = T [x; -1]`` from
    ``x`` (module docstring), each pass in a trust region: ``x`` minimises
    ``theta^T G theta + mu |x - x_k|^2`` (column-scaled; ``mu`` divided by 10
    after a pass that lowers the output error, else multiplied by 10 and the
    pass repeated), at most ``passes`` passes, until no unknown moves by
    ``tol`` (relative) or ``mu`` exceeds :data:`MAX_MU`; ``positive``: the
    factors kept positive (a sign flip leaves the whitening singular).
    Returns all parameters and ``x``."""
    at = (lambda x: (T @ np.append(x, -1.0))[:-1])
    p = at(x)
    c, mu = cost(eq, lines, p), MU
    for _ in range(passes):
        with np.errstate(all="ignore"):
            G = pseudo_gram(eq, lines, p, T)
        d = np.sqrt(np.maximum(np.diag(G)[:-1], 1e-300))
        Gs, b = G[:-1, :-1] / np.outer(d, d), G[:-1, -1] / d
        while mu <= MAX_MU:
            try:
                new_x = la.solve(Gs + mu * np.eye(x.size), b + mu * d * x, assume_a="sym") / d
            except (la.LinAlgError, ValueError):
                new_x = x + np.nan
            if positive:
                new_x = np.abs(new_x)
            new_c = cost(eq, lines, at(new_x)) if np.all(np.isfinite(new_x)) else np.inf
            if new_c < c:
                mu /= 10.0
                break
            mu *= 10.0
        if mu > MAX_MU:
            break
        moved = np.max(np.abs(new_x / np.where(x == 0, 1.0, x) - 1))
        x, p, c = new_x, at(new_x), new_c
        if moved < tol:
            break
    return p, x


def _output(eq: Equations, lines: Lines, p: np.ndarray, u: np.ndarray,
            jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Whitened output errors (B, r) complex at the DOF measured in some block
    (0 at an entry unmeasured in its block) and their Jacobian (B, r, n_u)
    with respect to ``p[u]``."""
    rows = _seen_rows(lines)
    inv_sd = _weights(lines)[:, rows]
    r = np.empty((lines.omega.size, rows.size), dtype=complex)
    J = np.empty(r.shape + (u.size,), dtype=complex) if jacobian else None
    for lo in range(0, lines.omega.size, CHUNK):
        part = slice(lo, lo + CHUNK)
        w, f = lines.omega[part], lines.force[part]
        Z = _z(eq.model, p, w)
        e = np.zeros((w.size, Z.shape[1], 1), dtype=complex)
        e[np.arange(w.size), f] = 1.0
        hh = np.linalg.solve(Z, e)[..., 0]
        if jacobian:
            Y = eq.regressor(w, hh, f)[:, :, u]  # Z_p hh
            J[part] = -np.matmul(inv_sd[part][:, :, None] * _inverse_rows(Z, rows), Y)
        r[part] = np.where(inv_sd[part] > 0, lines.h[part][:, rows] - hh[:, rows], 0.0) * inv_sd[part]
    return r, J


def cost(eq: Equations, lines: Lines, p: np.ndarray) -> float:
    """``J(p)``: the summed squared whitened output error (inf where ``Z`` is singular)."""
    try:
        with np.errstate(all="ignore"):
            r, _ = _output(eq, lines, p, np.array([], dtype=int), jacobian=False)
    except np.linalg.LinAlgError:
        return float("inf")
    c = float(np.sum(np.abs(r) ** 2))
    return c if np.isfinite(c) else float("inf")


def start(eq: Equations, lines: Lines) -> tuple[np.ndarray, dict]:
    """All parameters from the data and the model's shape (module docstring,
    "Start"), and what was done."""
    model = eq.model
    mask = model.kind_mask()
    base = np.where(mask & (model.values == 0), 1.0, model.values)
    T, groups = _kind_map(model, base)
    best, tried = None, []
    for first in FIRST_BANDS:
        bands = np.quantile(lines.omega, np.append(np.arange(first, 1.0 - 1e-9, BAND_STEP), 1.0))
        low = lines.take(lines.omega <= bands[0])
        w_mid = float(np.median(low.omega))
        for ratio in STARTS:  # first whitening: resonances of the shape near the band's median, a 2 % loss
            scale = np.ones(len(groups))
            if "mass" in groups:
                scale[groups.index("mass")] = ratio / w_mid**2
            if "damping" in groups:
                scale[groups.index("damping")] = 0.02 / w_mid
            p, _ = _iterate(eq, low, T, scale, STEP_TOL, True, FACTOR_PASSES)
            for top in bands:  # every parameter, on wider and wider bands from the lowest lines
                p, _ = _iterate(eq, lines.take(lines.omega <= top), _unknown_map(model, p), p[mask], STEP_TOL)
            c = cost(eq, lines, p)
            tried.append(c)
            if best is None or c < best[0]:
                best = (c, p)
    return best[1], {"start_costs": tried}


def fit(eq: Equations, lines: Lines, p0: np.ndarray,
        iterations: int = ITERATIONS) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Gauss-Newton with Levenberg-Marquardt steps on ``J(p)`` from ``p0``:
    all parameters, the unknowns' standard errors (NaN where undetermined),
    a boolean (n_u,) of the undetermined ones, and what was done."""
    model = eq.model
    u = np.flatnonzero(model.kind_mask())
    n_obs = int(np.isfinite(lines.var).sum())
    check_count(2 * n_obs, u.size)
    dof = max(1, 2 * n_obs - u.size)
    p = np.array(p0, dtype=float)
    r, J = _output(eq, lines, p, u)
    c = float(np.sum(np.abs(r) ** 2))
    lam, steps = 1e-3, 0
    for _ in range(iterations):
        Jf = J.reshape(-1, u.size)
        A, g = (Jf.conj().T @ Jf).real, (Jf.conj().T @ r.ravel()).real
        d = np.sqrt(np.maximum(np.diag(A), 1e-300))
        As = A / np.outer(d, d)
        std = np.sqrt(np.clip(np.diag(la.pinvh(As, atol=RANK_TOL * np.max(np.diag(As)))), 0, None)) / d
        std = np.where(std > 0, std, np.abs(p[u])) * np.sqrt(max(c, 1e-300) / dof)
        while True:
            delta = la.solve(As + lam * np.eye(u.size), g / d, assume_a="pos") / d
            trial = p.copy()
            trial[u] += delta
            new = cost(eq, lines, trial)
            if np.isfinite(new) and new <= c:
                lam = max(lam / 3.0, 1e-12)
                break
            lam *= 4.0
            if lam > 1e10:
                break
        if lam > 1e10:
            break
        p, c, steps = trial, new, steps + 1
        r, J = _output(eq, lines, p, u)
        if np.all(np.abs(delta) <= STEP_TOL * std):
            break
    Jf = J.reshape(-1, u.size)
    A = (Jf.conj().T @ Jf).real
    d = np.sqrt(np.maximum(np.diag(A), 1e-300))
    vals, vecs = la.eigh(A / np.outer(d, d))
    null = vecs[:, vals <= RANK_TOL * vals.max()]
    labels = [q.label for q, m in zip(model.parameters, model.kind_mask()) if m]
    bad = np.isin(labels, not_identifiable(null.T, labels)) if null.size else np.zeros(u.size, bool)
    bad |= d <= 1e-300 * max(1.0, d.max())
    ok = np.flatnonzero(~bad)
    std = np.full(u.size, np.nan)
    if ok.size:
        do = d[ok]  # A = D A_s D: solved in the column-scaled form, whose conditioning the rank test bounds
        As = A[np.ix_(ok, ok)] / np.outer(do, do)
        s = (np.conj(J[:, :, ok]) * r[:, :, None]).sum(axis=1).real  # (B, n_ok)
        clusters = np.unique(lines.cluster, return_inverse=True)[1]
        summed = np.zeros((clusters.max() + 1, ok.size))
        np.add.at(summed, clusters, s)
        z = la.solve(As, summed.T / do[:, None], assume_a="pos") / do[:, None]
        n_c = summed.shape[0]
        sandwich = np.sqrt(np.sum(z**2, axis=1) * n_c / max(1, n_c - ok.size))
        classical = np.sqrt(np.diag(la.inv(As)) / do**2 * c / dof)
        std[ok] = np.maximum(sandwich, classical)
        info_se = {"clusters": int(n_c), "sandwich_over_model": float(np.median(sandwich / classical))}
    else:
        info_se = {}
    info = info_se | {"lines": int(lines.omega.size), "output_error_steps": steps, "output_error_cost": c / dof,
            "rank": int(np.sum(vals > RANK_TOL * vals.max())),
            "undetermined_combinations": [
                {lab: round(float(x), 3) for lab, x in sorted(zip(labels, v), key=lambda t: -abs(t[1]))[:4]}
                for v in null.T]}
    return p, std, bad, info


def solve(model: Structure, lines: Lines, p0: np.ndarray | None = None,
          refuse: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """All parameters (the undetermined ones at a value the data do not
    fix), the unknowns' standard errors (n_u,) (NaN where undetermined), the
    undetermined mask (n_u,) and ``details``, from ``lines`` (``var`` inf
    where a DOF is unmeasured), from ``p0`` (all parameters; None: :func:`start`).
    Raises when no parameter is determined, naming them and the unmeasured
    DOF, and (``refuse``) when the lines cannot support the estimate
    (:func:`check_support`)."""
    eq = Equations(model)
    info: dict = {}
    if p0 is None:
        p0, info = start(eq, lines)
    p, std, bad, more = fit(eq, lines, p0)
    unmeasured = [model.dofs[j] for j in np.flatnonzero(~np.isfinite(lines.var).any(axis=0))]
    labels = [q.label for q, m in zip(model.parameters, model.kind_mask()) if m]
    if bad.all():
        raise IdentificationError(
            f"no parameter is determined by the measured DOF (rank {more['rank']} of {bad.size}): "
            f"{', '.join(labels[:12])}{' ...' if len(labels) > 12 else ''} undetermined; unmeasured DOF "
            f"{', '.join(f'({n}, {d!r})' for n, d in unmeasured[:12])}{' ...' if len(unmeasured) > 12 else ''}: "
            "measure more of them", field="channels")
    if refuse:
        check_support(more, int(np.sum(~bad)), unmeasured)
    return p, std, bad, info | more | {"undetermined": [lab for lab, b in zip(labels, bad) if b]}

