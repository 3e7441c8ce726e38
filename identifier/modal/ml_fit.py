"""Maximum-likelihood fit of shared poles to weighted free-decay records
(:mod:`identifier.modal.refine`).

Each channel divided by its ``s_ri``, the records of one length
stack as ``Z = B(theta) C + E`` (n x M, one column per channel and record),
``B = [1, t, e^(sigma_j t) cos(omega_d,j t), e^(sigma_j t) sin(omega_d,j t), ...]``.
For given poles the amplitudes are linear least squares and are projected
out (variable projection, Golub and Pereyra 1973): ``theta = (sigma_j,
omega_d,j)`` minimises

    f(theta) = ||(I - P) Z||_F^2,     P = B (B^T B)^-1 B^T,

with Kaufman's Jacobian ``J_k = -(I - P) D_k C`` (``D_k = dB/dtheta_k``; for
pole ``j``'s columns ``u, v``: ``d/dsigma [u, v] = t [u, v]``, ``d/domega_d
[u, v] = t [-v, u]``). Every ``D_k C`` is ``T a_k`` with ``T = t [u_j, v_j]_j``
(n x 2p) and ``a_k`` pole ``j``'s amplitudes, so the Gauss-Newton quantities
need no ``n M x 2p`` Jacobian:

    J^T J = sum_m a_km^T W^T W a_lm,   W = (I - P) T,     J^T r = -sum_m a_km^T T^T r_m

(``r`` is orthogonal to ``B``; Kaufman's gradient is the exact one). They
drive Levenberg-Marquardt steps clipped to bounds until the Gauss-Newton
decrement ``g^T (J^T J)^-1 g`` of the reported poles falls under
``DECREMENT`` (the squared length of the step in their standard errors:
under a tenth of one; the weighted cost is a chi-square).
Least squares on ``B`` use its Gram matrix (columns scaled, Cholesky, one
step of iterative refinement): matrix products only (a Householder QR of a
tall matrix, or ``scipy.optimize.least_squares`` and the SVD of the full
Jacobian at every step, cost 3-50 times more on a loaded machine). ``J^T J``
at the optimum is the Fisher information of the poles with every amplitude
eliminated (the Schur complement of the bound in
:mod:`structbench.planning.free_decay`), so the covariance is ``(f / dof)
(J^T J)^-1``, ``dof = sum n M - N M - 2p``; ``omega = |lambda|``, ``zeta =
-sigma / |lambda|`` and their standard errors follow by the delta method
(``f / dof`` at least 1: each noise level is at least ``FLOOR`` x its
channel's RMS, so a noise-free record states the errors of that level, not
of rounding).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la

from .close_pairs.free_decay_fit import basis

MAX_ITERATIONS = 50  # Levenberg-Marquardt iterations of one fit
DECREMENT = 1e-2  # converged: the Gauss-Newton step moves the reported poles by under 0.1 standard errors
FLOOR = 1e-6  # least noise standard deviation, x the channel's RMS


def noise_levels(t: np.ndarray, y: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Per column the RMS of the residual of ``y`` (n, M) on ``columns`` (n, N), ``sum r^2 / (n - N)``."""
    try:
        r = Solver(columns).coefficients(y)[1]
    except la.LinAlgError:
        q, _ = la.qr(columns, mode="economic")
        r = y - q @ (q.T @ y)
    s = np.sqrt(np.sum(r**2, axis=0) / max(t.size - columns.shape[1], 1))
    return np.maximum(s, FLOOR * np.sqrt(np.mean(y**2, axis=0)) + np.finfo(float).tiny)


class Solver:
    """Least squares on a tall basis ``b`` (n, N) by its Gram matrix (columns
    scaled to unit norm, Cholesky, one step of iterative refinement per
    solve): matrix products only. A Householder QR of a tall matrix runs
    N level-2 BLAS passes, each on every BLAS thread: 10-50 times slower
    on a loaded machine. ``overwrite``: ``b`` is scaled in place (no copy
    of it: each new array of a long record costs its pages' faults)."""

    def __init__(self, b: np.ndarray, overwrite: bool = False) -> None:
        self.scale = np.maximum(np.sqrt(np.einsum("ij,ij->j", b, b)), np.finfo(float).tiny)
        self.b = np.divide(b, self.scale, out=b if overwrite else None)
        self.factor = la.cho_factor(self.b.T @ self.b)

    def coefficients(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Coefficients (N, M) of the scaled columns and the residual (n, M) of ``z`` (n, M)."""
        c = la.cho_solve(self.factor, self.b.T @ z)
        r = self.b @ c
        np.subtract(z, r, out=r)
        c += la.cho_solve(self.factor, self.b.T @ r)
        return c, np.subtract(z, np.matmul(self.b, c, out=r), out=r)


def select(b: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``basis(t, every[idx])`` (n, 2 + 2 len(idx)) from ``b = basis(t, every)``: the same numbers, not recomputed."""
    return b[:, np.r_[0, 1, (2 + 2 * np.asarray(idx, dtype=int)[:, None] + np.arange(2)).ravel()]]


class VarPro:
    """Variable projection over groups ``(t, z)`` with poles ``fixed`` held
    (their columns in the basis) and the free ones' ``(sigma, omega_d)``
    interleaved in ``x``: the cost ``f`` and, from small products, the
    Gauss-Newton gradient and information (no ``n M x 2p`` Jacobian)."""

    def __init__(self, ts: list[np.ndarray], zs: list[np.ndarray], fixed: np.ndarray,
                 columns: list[np.ndarray] | None = None) -> None:
        """``columns``: per group ``basis(t, fixed)`` (n_g, 2 + 2 F) where the
        caller has it (:func:`select`), else computed."""
        self.ts, self.zs = ts, zs
        self.fixed_cols = [basis(t, fixed) for t in ts] if columns is None else columns
        self.costs: dict[bytes, float] = {}  # f at every x evaluated
        self.last: tuple = ()  # the states of the last normal equations and those equations

    def state(self, x: np.ndarray) -> tuple[float, list[tuple]]:
        """``f`` and per group ``e^(lambda_j t)`` (n, p) of the free poles, the
        solver of the basis ``[1, t, free poles' columns, fixed poles'
        columns]``, the amplitudes ``C`` (of the unscaled columns) and the
        residual ``R``; ``f`` infinite where the basis is singular."""
        poles = x[0::2] + 1j * x[1::2]
        k = 2 * poles.size
        out, f = [], 0.0
        for t, z, fc in zip(self.ts, self.zs, self.fixed_cols):
            b = np.empty((t.size, fc.shape[1] + k))
            b[:, :2], b[:, 2 + k:] = fc[:, :2], fc[:, 2:]
            e = np.outer(t, poles)
            np.exp(e, out=e)
            b[:, 2:2 + k:2], b[:, 3:2 + k:2] = e.real, e.imag
            try:
                solver = Solver(b, overwrite=True)
            except la.LinAlgError:
                f, out = np.inf, []
                break
            c, r = solver.coefficients(z)
            f += float(np.sum(r**2))
            out.append((e, solver, c / solver.scale[:, None], r))
        self.costs[x.tobytes()] = f
        return f, out

    def cost(self, x: np.ndarray) -> float:
        """``f`` at ``x``, remembered where :meth:`state` evaluated it (e.g. at a fit's end)."""
        known = self.costs.get(x.tobytes())
        return self.state(x)[0] if known is None else known

    def normal(self, ts: list[np.ndarray], states: list[tuple], p: int) -> tuple[np.ndarray, np.ndarray]:
        """Gradient ``J^T r`` (2p,) and information ``J^T J`` (2p, 2p) of
        Kaufman's Jacobian ``-(I - P) D_k C`` (``P`` the projector on the
        basis): every ``D_k C`` is ``T a_k`` (``T = t [u_j, v_j]_j``, ``a_k`` from
        pole ``j``'s amplitudes), so ``J^T J = sum_m a^T W^T W a`` with ``W =
        (I - P) T`` and ``J^T r = -sum_m a^T T^T r_m`` (``r`` is orthogonal to the basis).
        Those of the last ``states`` are remembered (a fit asks again at its end)."""
        if self.last and self.last[0] is states and self.last[1] is ts:
            return self.last[2]
        grad, info = np.zeros(2 * p), np.zeros((2 * p, 2 * p))
        for t, (e, solver, coef, r) in zip(ts, states):
            tt = np.empty((t.size, 2 * p))
            np.multiply(e.real, t[:, None], out=tt[:, 0::2])
            np.multiply(e.imag, t[:, None], out=tt[:, 1::2])
            _, w = solver.coefficients(tt)
            gram = w.T @ w
            tr = tt.T @ r  # (2p, M)
            m = r.shape[1]
            c = coef[2:2 + 2 * p].reshape(p, 2, m)
            a = np.zeros((2 * p, 2 * p, m))  # [parameter, column of T, channel]
            j = np.arange(p)
            a[2 * j, 2 * j], a[2 * j, 2 * j + 1] = c[:, 0], c[:, 1]  # d/dsigma_j: (c_u, c_v)
            a[2 * j + 1, 2 * j], a[2 * j + 1, 2 * j + 1] = c[:, 1], -c[:, 0]  # d/domega_d,j: (c_v, -c_u)
            ag = np.einsum("kam,ab->kbm", a, gram)
            info += np.einsum("kbm,lbm->kl", ag, a)
            grad -= np.einsum("kam,am->k", a, tr)
        self.last = states, ts, (grad, 0.5 * (info + info.T))
        return self.last[2]


def inverse_information(h: np.ndarray) -> np.ndarray:
    """``h^-1`` of a Fisher information ``h`` (k, k), symmetric positive
    semi-definite, with NaN rows and columns for the parameters it leaves
    undetermined: ``S = D h D`` (``D = diag(h)^-1/2``, units out) is split
    ``S = V diag(mu) V^T``; directions with ``mu < k eps max(mu)`` are lost
    to rounding (the record does not inform them: a pole of a term with no
    amplitude, two poles on one mode); a parameter with a component over
    ``sqrt(eps)`` in one has no finite variance; the rest is ``D V_+
    diag(1 / mu_+) V_+^T D``. Equal to ``h^-1`` when ``h`` is well
    conditioned; no warning on an ill-conditioned one (its conditioning is
    the answer: NaN errors)."""
    k = h.shape[0]
    d = np.diag(h)
    if not np.all(np.isfinite(h)) or np.any(d <= 0):
        return np.full((k, k), np.nan)
    scale = 1.0 / np.sqrt(d)
    mu, v = np.linalg.eigh(h * scale[:, None] * scale[None, :])
    kept = mu > k * np.finfo(float).eps * mu.max()
    cov = (v[:, kept] / mu[kept]) @ v[:, kept].T * scale[:, None] * scale[None, :]
    lost = np.any(np.abs(v[:, ~kept]) > np.sqrt(np.finfo(float).eps), axis=1)
    cov[lost, :] = np.nan
    cov[:, lost] = np.nan
    return cov


def fit_poles(ts, zs, fixed: np.ndarray, start: np.ndarray, lower: np.ndarray, upper: np.ndarray,
         watch: int | None = None, fit: VarPro | None = None) -> tuple[np.ndarray, np.ndarray, bool, np.ndarray]:
    """Free poles (p,) fitted from ``start`` by Levenberg-Marquardt on the
    normal equations (steps clipped to the bounds), their covariance (2p, 2p)
    of ``(sigma, omega_d)``, whether it converged (the Gauss-Newton decrement
    ``g^T H^-1 g``, what a full step would lower the cost by and, the data
    being in units of their noise, its squared length in standard errors,
    under ``DECREMENT``; parameters on a bound that the step would push out
    held there), and which ended on a bound (p,). With
    ``watch``, only the first ``watch`` poles' share of the decrement counts
    (the step's move of them in their own standard errors, squared): a
    nuisance pole of a mode the model fits badly may creep on for long
    without moving them.) ``fit``: the caller's :class:`VarPro` of ``ts, zs,
    fixed`` (its fixed columns shared; :meth:`VarPro.cost` then knows the cost at the end)."""
    fit = VarPro(ts, zs, fixed) if fit is None else fit
    p = start.size
    x = np.clip(np.column_stack([start.real, start.imag]).ravel(), lower, upper)
    f, states = fit.state(x)
    if not np.isfinite(f):
        return start, np.full((x.size, x.size), np.nan), False, np.zeros(p, bool)
    damping, converged = 1e-3, False
    width = upper - lower
    for _ in range(MAX_ITERATIONS):
        g, h = fit.normal(ts, states, p)
        # parameters on a bound that the descent direction pushes out stay there
        held = ((x - lower < 1e-9 * width) & (g > 0)) | ((upper - x < 1e-9 * width) & (g < 0))
        move = np.flatnonzero(~held)
        hm, gm = h[np.ix_(move, move)], g[move]
        scale = np.maximum(np.diag(hm), np.finfo(float).tiny)
        try:
            factor = la.cho_factor(hm, check_finite=False)
            full = la.cho_solve(factor, gm, check_finite=False)
            if watch is None or watch >= p:
                decrement = float(gm @ full)
            else:
                mine = move < 2 * watch
                cw = la.cho_solve(factor, np.eye(move.size), check_finite=False)[np.ix_(mine, mine)]
                decrement = float(full[mine] @ la.cho_solve(la.cho_factor(cw, check_finite=False), full[mine],
                                                            check_finite=False))
        except (la.LinAlgError, ValueError):
            decrement = np.inf
        if decrement < DECREMENT:  # the Gauss-Newton step would lower the cost by less: converged
            converged = True
            break
        for _ in range(30):
            step = np.zeros_like(x)
            try:
                step[move] = -la.cho_solve(la.cho_factor(hm + damping * np.diag(scale), check_finite=False), gm,
                                           check_finite=False)
            except (la.LinAlgError, ValueError):
                step[:] = np.nan
            if np.all(np.isfinite(step)):
                trial = np.clip(x + step, lower, upper)
                f_new, st_new = fit.state(trial)
                if f_new <= f:
                    break
            damping *= 4.0
        else:
            break  # no step lowers the cost
        x, f, states = trial, f_new, st_new
        damping = max(damping / 3.0, 1e-9)
    g, h = fit.normal(ts, states, p)
    n_lin = 2 + 2 * (p + fixed.size)
    dof = sum(z.size for z in zs) - n_lin * sum(z.shape[1] for z in zs) - x.size
    cov = max(f / max(dof, 1), 1.0) * inverse_information(h)  # noise levels at least FLOOR: not rounding's
    edge = (np.abs(x - lower) < 1e-6 * width) | (np.abs(upper - x) < 1e-6 * width)
    return x[0::2] + 1j * x[1::2], cov, converged, edge.reshape(-1, 2).any(axis=1)
