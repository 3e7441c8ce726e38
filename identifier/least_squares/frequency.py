"""Least squares on the equations of motion in the frequency domain (issue 22).

Equations. At a measured line ``omega_l`` and a force at DOF ``f``, the
receptance column ``h = H(omega_l) e_f`` (every DOF, m/N) of
``M u'' + C u' + K u = f`` satisfies

    (K - omega^2 M + i omega C) h = e_f,

linear in the element parameters: exactly the time-domain regression of
:mod:`identifier.least_squares.regression` with the complex "motion"
``a = -omega^2 h``, ``v = i omega h``, ``u = h``, force ``e_f`` (its
:func:`~identifier.least_squares.regression.layout` assembles the columns,
Rayleigh factors included). Each block ``b = (line, force)`` gives the
complex equation error ``e_b = Y_b theta``, ``theta = [p; -1]``; real and
imaginary parts are both used (``Re(Y^H Omega Y)``). A velocity or
acceleration FRF is a receptance times ``(i omega)^k``: divided exactly, no
differentiation (:mod:`identifier.least_squares.frequency_data`).

Errors in variables. ``h`` is noisy (``dh_i``, zero mean, circular, variance
``V_i = E|dh_i|^2``, independent between DOF), so ``Y`` is noisy:
``dY_b = sum_i dh_i B_i`` with ``B_i`` the regressor of a unit ``h = e_i``
(``B_i = -omega^2 W_a[i] + i omega W_v[i] + W_u[i]`` in the layout's channel
rows). Plain least squares solves ``Re(G) theta = 0`` with ``E[G] = G_0 +
D``, ``D = sum_b sum_i V_bi B_i^H Omega_b B_i``: biased (the parameters
shrink) however many lines. Bias compensation solves
``Re(G - D)_uu p_u = Re(G - D)_uf - Re(G - D)_uk p_k``
(``u`` unknown, ``k`` known parameters, ``f`` the force column), as
:mod:`identifier.least_squares.bias_compensated` does in the time domain.

Weighting. Unweighted, the equation error is swamped by ``K dh`` (on the
chapter 3 beam the unweighted estimates were off by 100 % and more), so the
start is :func:`scaled_start`: the model's unknown values (a prior, or a
topology's 1.0) scaled by one factor per parameter kind, the factors fitted
with one weight per line (its signal-to-noise ratio), then whitened. From
there :data:`REWEIGHTINGS` times whitened at the latest estimate: ``cov(e_b) = Z diag(V_b) Z^H`` with ``Z =
K - omega^2 M + i omega C``, so ``Omega_b = Z^-H diag(1/V_b) Z^-1 =
Hh^H diag(1/V_b) Hh`` with ``Hh = Z^-1`` the model's receptance: the
whitened equation error is the output error ``(h - Hh e_f) / sqrt(V)`` at
the solution (the equations stay linear; each re-weighting is one solve).

Standard errors. The estimator solves ``sum_b g_b = 0``, ``g_b =
Re(Y_b^H Omega_b Y_b - D_b) theta``, zero-mean at the truth. Adjacent lines
of a windowed (Welch) estimate are correlated (Hann: DFT bins one apart
correlate by -2/3), so ``g_b`` are summed over clusters of :data:`CLUSTER`
consecutive lines before the sandwich ``H^-1 (sum_c g_c g_c^T) H^-1``,
``H = Re(G - D)_uu`` (first order: the weights and ``V`` taken as known;
times ``n_c / (n_c - n_u)`` for ``n_c`` clusters and ``n_u`` unknowns).

Iterating the re-weighting to convergence can drift when many lines have
a signal-to-noise ratio near one (``G - D`` the small difference of two
large matrices): :mod:`identifier.least_squares.frequency_output` finishes
with the output-error fit that the iteration converges to, and
:mod:`identifier.least_squares.frequency_data` gets the lines from traces.

Assumptions: a linear structure whose model (topology) is right; ``h`` free
of bias (leakage: undamped or lightly damped modes against short segments
bias ``H1`` near resonances, which the coherence only partly shows);
``V`` right (estimated from coherence and averages it is itself noisy:
fine with tens of averages, poor with a handful). Fails or degrades when:
lines do not excite the parameters (a single line, or lines where every
response is noise; rank deficiency raised naming the parameters); ``G - D``
is ill-conditioned (noise comparable with the signal at most lines); the
variances are badly wrong (the bias returns in proportion).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from structbench.models import Structure

from .bias_compensated import _check_rank
from .estimate import Estimate
from .identifiability import check_count
from .regression import layout

REWEIGHTINGS = 3
CLUSTER = 8  # consecutive lines per cluster of the sandwich (windowed lines are correlated)
CHUNK = 256  # blocks per pass (memory ~ CHUNK n^2 complex)
# Products are taken per block (line x force), each small enough for OpenBLAS to run it on the calling
# thread: its threaded products spin-wait for each other when the other core is busy (a 45 x 165,000
# Gram matrix took 3.4 s instead of 18 ms).


@dataclass
class Lines:
    """Blocks ``b`` (line x force): ``omega`` (B,) rad/s, ``h`` (B, n) complex
    receptance (m/N, rad/(N m) ...), ``var`` (B, n) its noise variance
    ``E|dh|^2``, ``force`` (B,) the force DOF index, ``cluster`` (B,) the
    sandwich cluster label (blocks with correlated errors share one)."""

    omega: np.ndarray
    h: np.ndarray
    var: np.ndarray
    force: np.ndarray
    cluster: np.ndarray

    def take(self, keep: np.ndarray) -> "Lines":
        return Lines(self.omega[keep], self.h[keep], self.var[keep], self.force[keep], self.cluster[keep])

    @staticmethod
    def join(parts: list["Lines"]) -> "Lines":
        offset, clusters = 0, []
        for p in parts:
            clusters.append(p.cluster + offset)
            offset += int(p.cluster.max(initial=-1)) + 1
        cat = (lambda name: np.concatenate([getattr(p, name) for p in parts]))
        return Lines(cat("omega"), cat("h"), cat("var"), cat("force"), np.concatenate(clusters))


class Equations:
    """The regression of one model over blocks of lines (see the module docstring)."""

    def __init__(self, model: Structure):
        self.model, self.lay = model, layout(model)
        n = model.n_dof
        W = self.lay.W.tocsr()
        self.n, self.cols = n, self.lay.n_columns
        self.Wd = W.toarray()  # (4 n, n_pairs)
        self.WT = W.T.tocsr()  # (n_pairs, 4 n): a sparse product, a few channels per pair
        # B_i in compact form: rows S_i (smax,), columns C_i (cmax,), coefficients per channel kind
        pr, pc = self.lay.pair_row, self.lay.pair_col
        per = []
        for i in range(n):
            touched = np.flatnonzero(np.any(self.Wd[[i, n + i, 2 * n + i]] != 0, axis=0))
            per.append((touched, np.unique(pr[touched]), np.unique(pc[touched])))
        smax = max(1, max(s.size for _, s, _ in per))
        cmax = max(1, max(c.size for _, _, c in per))
        self.S = np.zeros((n, smax), dtype=int)
        self.C = np.full((n, cmax), self.cols, dtype=int)  # padding: a dummy column, dropped
        self.coef = np.zeros((3, n, smax, cmax))  # acceleration, velocity, displacement channel weights
        for i, (touched, rows, cols) in enumerate(per):
            self.S[i, :rows.size], self.C[i, :cols.size] = rows, cols
            for pair in touched:
                r, c = np.searchsorted(rows, pr[pair]), np.searchsorted(cols, pc[pair])
                for k in range(3):
                    self.coef[k, i, r, c] += self.Wd[k * n + i, pair]

    def regressor(self, omega: np.ndarray, h: np.ndarray, force: np.ndarray) -> np.ndarray:
        """``Y_b`` (B, n, n_columns) complex."""
        n = self.n
        x = np.zeros((omega.size, 4 * n), dtype=complex)
        x[:, :n] = -(omega**2)[:, None] * h
        x[:, n:2 * n] = 1j * omega[:, None] * h
        x[:, 2 * n:3 * n] = h
        x[np.arange(omega.size), 3 * n + force] = 1.0
        pairs = (self.WT @ x.T).T  # (B, n_pairs)
        Y = np.zeros((omega.size, n, self.cols), dtype=complex)
        Y[:, self.lay.pair_row, self.lay.pair_col] = pairs
        return Y

    def receptance(self, theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """The model's ``Z(omega)^-1`` (B, n, n) at ``theta = [p; -1]``."""
        M, C, K = matrices(self.model, theta[:-1])
        Z = K[None] - (omega**2)[:, None, None] * M[None] + 1j * omega[:, None, None] * C[None]
        return np.linalg.inv(Z)

    def moments(self, lines: Lines, theta: np.ndarray | None, scores: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
        """``Re G``, ``Re D`` (n_columns, n_columns), weighted at ``theta``
        (None: unweighted), and at ``scores`` (a theta) the per-block terms
        ``Re(Y^H Omega Y) theta`` and ``Re(D_b) theta``, each (B, n_columns)."""
        cols = self.cols
        G, D = np.zeros((cols, cols)), np.zeros((cols + 1, cols + 1))
        g = (np.zeros((lines.omega.size, cols)), np.zeros((lines.omega.size, cols))) if scores is not None else None
        scale = np.mean(lines.var)
        for lo in range(0, lines.omega.size, CHUNK):
            part = slice(lo, lo + CHUNK)
            w, h, v, f = lines.omega[part], lines.h[part], lines.var[part], lines.force[part]
            Y = self.regressor(w, h, f)
            if theta is None:  # one weight per block: its signal-to-noise ratio sum|h|^2 / sum V
                snr = np.sum(np.abs(h) ** 2, axis=1) / np.maximum(np.sum(v, axis=1), 1e-300) if scale > 0 \
                    else np.ones(w.size)
                omega_b = snr[:, None, None] * np.eye(self.n, dtype=complex)[None]
            else:
                inv_v = 1.0 / (v + 1e-9 * scale) if scale > 0 else np.ones_like(v)
                Hh = self.receptance(theta, w)
                omega_b = np.matmul(np.conj(Hh.transpose(0, 2, 1)), inv_v[:, :, None] * Hh)
            OY = np.matmul(omega_b, Y)
            # Re(Y^H OY) per block as one real product of the stacked real and imaginary parts
            Yr = np.concatenate([Y.real, Y.imag], axis=1)  # (b, 2 n, cols)
            OYr = np.concatenate([OY.real, OY.imag], axis=1)
            G += np.matmul(Yr.transpose(0, 2, 1), OYr).sum(axis=0)
            # noise Gram: sum_i V_i B_i^H Omega[S_i, S_i] B_i, compact per DOF i
            B = (-(w**2)[:, None, None, None] * self.coef[0] + 1j * w[:, None, None, None] * self.coef[1]
                 + self.coef[2])  # (b, n, smax, cmax)
            sub = omega_b[:, self.S[:, :, None], self.S[:, None, :]]  # (b, n, smax, smax)
            local = np.matmul(np.conj(B).transpose(0, 1, 3, 2), np.matmul(sub, B)).real
            local *= v[:, :, None, None]
            idx_i = np.broadcast_to(self.C[:, :, None], local.shape[1:])
            idx_j = np.broadcast_to(self.C[:, None, :], local.shape[1:])
            np.add.at(D, (idx_i.ravel(), idx_j.ravel()), local.sum(axis=0).ravel())
            if g is not None:
                e = np.matmul(Y, scores.astype(complex)[None, :, None])[..., 0]
                first = np.einsum("bri,br->bi", np.conj(Y), np.matmul(omega_b, e[:, :, None])[..., 0]).real
                th = np.append(scores, 0.0)[self.C]  # (n, cmax)
                dth = np.einsum("bicd,id->bic", local, th)  # (b, n, cmax)
                corr = np.zeros((w.size, cols + 1))
                for i in range(self.n):
                    np.add.at(corr, (slice(None), self.C[i]), dth[:, i])
                g[0][part], g[1][part] = first, corr[:, :cols]
        return G, D[:cols, :cols], g


def matrices(model: Structure, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dense ``M``, ``C``, ``K`` at parameters ``p`` (any values: estimates
    under noise need not be physical), Rayleigh damping included."""
    par, rows, cols, vals = model.triplets
    kind = np.array([q.kind for q in model.parameters])[par]
    n = model.n_dof
    out = {}
    for k in ("mass", "damping", "stiffness"):
        A = np.zeros((n, n))
        sel = kind == k
        np.add.at(A, (rows[sel], cols[sel]), vals[sel] * p[par[sel]])
        out[k] = A
    alpha, beta = model.rayleigh
    return out["mass"], out["damping"] + alpha * out["mass"] + beta * out["stiffness"], out["stiffness"]


def _solve(N: np.ndarray, mask: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, tuple]:
    u, k = np.flatnonzero(mask), np.flatnonzero(~mask)
    lu = la.lu_factor(N[np.ix_(u, u)])
    return la.lu_solve(lu, N[u, -1] - N[np.ix_(u, k)] @ known), lu


def scaled_start(eq: Equations, model: Structure, lines: Lines, compensate: bool = True,
                 passes: int = REWEIGHTINGS + 1) -> np.ndarray:
    """All parameters of the model's unknown values scaled by one factor per
    kind (the unknown values are only a shape: a topology's 1.0 or a prior),
    the factors fitted bias-compensated, whitened at the previous factors
    (first: one weight per line, its signal-to-noise ratio). A start for the
    whitening: the unweighted full fit is swamped by ``K dh``."""
    mask = model.kind_mask()
    kinds = [p.kind for p in model.parameters]
    groups = sorted({k for k, u in zip(kinds, mask) if u})
    base = np.where(mask & (model.values == 0), 1.0, model.values)
    T = np.zeros((eq.cols, len(groups) + 1))
    for j, (k, u) in enumerate(zip(kinds, mask)):
        T[j, groups.index(k) if u else -1] = base[j] if u else -base[j]
    T[-1, -1] = 1.0
    theta = None
    for _ in range(passes):
        G, D, _ = eq.moments(lines, theta)
        N = T.T @ (G - D if compensate else G) @ T
        factors = np.abs(la.solve(N[:-1, :-1], N[:-1, -1]))  # a sign flip would leave the whitening singular
        theta = T @ np.append(factors, -1.0)
    return theta[:-1]


def solve_lines(model: Structure, lines: Lines, weighting: str = "noise", compensate: bool = True,
                rcond: float = 1e-7, start: np.ndarray | None = None, reweightings: int = REWEIGHTINGS,
                errors: bool = True) -> Estimate:
    """Unknown parameters (``model.kind_mask()``) from the receptance ``lines``
    (module docstring): bias-compensated unless ``compensate`` is False,
    whitened (``weighting="noise"``) from ``start`` (all parameters) or from
    :func:`scaled_start`."""
    eq = Equations(model)
    mask = model.kind_mask()
    labels = [p.label for p, u in zip(model.parameters, mask) if u]
    known = model.values[~mask]
    check_count(2 * lines.h.size, int(mask.sum()))
    u = np.flatnonzero(mask)

    def theta_of(p_u: np.ndarray) -> np.ndarray:
        p = model.values.copy()
        p[mask] = p_u
        return np.append(p, -1.0)

    if start is None and weighting == "noise":
        start = scaled_start(eq, model, lines, compensate)
    theta = None if start is None or weighting != "noise" else np.append(start, -1.0)
    G, D, _ = eq.moments(lines, theta)
    condition = _check_rank(_sparse(G[np.ix_(u, u)]), labels, rcond)
    p_u, lu = _solve(G - D if compensate else G, mask, known)
    passes = reweightings if weighting == "noise" else 0
    for _ in range(passes):
        G, D, _ = eq.moments(lines, theta_of(p_u))
        p_u, lu = _solve(G - D if compensate else G, mask, known)
    theta = theta_of(p_u)
    details = {"estimator": "bias-compensated" if compensate else "plain",
               "weighting": "noise (output-error whitening)" if weighting == "noise" else "none",
               "std_errors": f"sandwich over clusters of {CLUSTER} consecutive lines"}
    if not errors:
        return Estimate(p_u, np.full(u.size, np.nan), condition, float("nan"), 2 * lines.h.size, details)
    G, D, (first, corr) = eq.moments(lines, theta if weighting == "noise" else None, scores=theta)
    g = first - corr if compensate else first
    clusters = np.unique(lines.cluster, return_inverse=True)[1]
    summed = np.zeros((clusters.max() + 1, g.shape[1]))
    np.add.at(summed, clusters, g)
    z = la.lu_solve(lu, summed[:, u].T)  # (n_u, clusters)
    n_c = summed.shape[0]
    std = np.sqrt(np.sum(z**2, axis=1) * n_c / max(1, n_c - u.size))  # small-sample factor (HC1)
    e = np.concatenate([np.matmul(eq.regressor(lines.omega[k], lines.h[k], lines.force[k]),
                                  theta.astype(complex)[None, :, None])[..., 0]
                        for k in (slice(lo, lo + CHUNK) for lo in range(0, lines.omega.size, CHUNK))])
    return Estimate(p_u, std, condition, float(np.sqrt(np.mean(np.abs(e) ** 2))), 2 * lines.h.size, details)


def _sparse(A: np.ndarray):
    import scipy.sparse as sp
    return sp.csr_matrix(A)
