"""Bounded, regularised least squares over the scale factors, the choice of
the regularisation weight, the identifiability report and standard errors
(the equations are in the package docstring, :mod:`structbench.identifier.updating`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import brentq, least_squares
from scipy.stats import chi2 as chi2_dist

from .residuals import Evaluation, Residuals

FLOOR = 1e-12       # regularisation floor, relative to the largest squared singular value at the prior
MU_RANGE = 1e4      # largest weight tried, relative to the same
UNDETERMINED_LOAD = 0.01  # share of a parameter's unit vector in the undetermined subspace that voids its error


@dataclass
class Fit:
    """One bounded least-squares solution: ``alpha`` (q,), half the squared
    norm of the data residuals plus penalty ``cost``, evaluations ``nfev``."""

    alpha: np.ndarray
    cost: float
    nfev: int
    status: int
    message: str


def fit(res: Residuals, x0: np.ndarray, mu: float, lower: np.ndarray, upper: np.ndarray,
        max_nfev: int, tol: float) -> Fit:
    """``min |r(alpha)|^2 + mu |alpha|^2`` over ``lower <= alpha <= upper`` by
    trust-region reflective with the analytic Jacobian."""
    root = np.sqrt(mu)
    eye = root * np.eye(x0.size)

    def fun(x: np.ndarray) -> np.ndarray:
        return np.concatenate([res(x).r, root * x])

    def jac(x: np.ndarray) -> np.ndarray:
        return np.vstack([res(x).J, eye])

    x0 = np.clip(x0, lower + 1e-9 * (upper - lower), upper - 1e-9 * (upper - lower))
    out = least_squares(fun, x0, jac, bounds=(lower, upper), method="trf", x_scale="jac",
                        ftol=tol, xtol=tol, gtol=None, max_nfev=max_nfev)
    return Fit(out.x, float(out.cost), int(out.nfev), int(out.status), str(out.message))


def min_norm(res: Residuals, alpha: np.ndarray, rank_tol: float, lower: np.ndarray, upper: np.ndarray,
             iterations: int = 30) -> np.ndarray:
    """Gauss-Newton steps to the solution nearest the prior where the data
    leave directions undetermined: ``alpha <- alpha - J^+ r - (I - J^+ J) alpha``
    (``J^+`` by the SVD truncated at ``rank_tol``), whose fixed points fit
    the data and have no component in the null space of ``J``; a tiny
    Tikhonov weight alone moves along those flat directions too slowly."""
    for _ in range(iterations):
        ev = res(alpha)
        U, s, Vt = np.linalg.svd(ev.J, full_matrices=ev.J.shape[0] < ev.J.shape[1])
        rank = int(np.sum(s > rank_tol * s[0])) if s.size and s[0] > 0 else 0
        step = -Vt[:rank].T @ ((U[:, :rank].T @ ev.r) / s[:rank]) - Vt[rank:].T @ (Vt[rank:] @ alpha)
        alpha = np.clip(alpha + step, lower, upper)
        if np.max(np.abs(step)) < 1e-12:
            break
    return alpha


def _svd(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values (q,) (zeros appended when J has fewer rows than
    columns) and every right singular vector ``Vt`` (q, q) of ``J`` (n, q)."""
    q = J.shape[1]
    _, s, Vt = np.linalg.svd(J, full_matrices=J.shape[0] < q)
    return np.concatenate([s, np.zeros(q - s.size)]), Vt


def choose_weight(J: np.ndarray, r: np.ndarray, alpha: np.ndarray, n_eff: int, rank: int, known: bool,
                  floor: float, rule: str) -> tuple[float, str, str]:
    """The regularisation weight ``mu``, the rule used and why.

    On the linear model about ``alpha`` (``r(a) = J a - b``, ``b = J alpha - r``,
    exact for any ``alpha``, bounded or not): ``a(mu) = V diag(s / (s^2 + mu)) U^T b``.
    ``rule``: ``auto`` (``chi2`` when ``known``, else ``gcv``), ``chi2``
    (the minimum of the regularised functional ``|r|^2 + mu |a|^2`` equal to
    ``n_eff``), ``gcv``, ``none`` (the floor only) or a number."""
    if rule not in ("auto", "discrepancy", "gcv", "none"):
        return max(float(rule), floor), "given", "the option regularisation"
    if rule == "none":
        return floor, "none", "regularisation = none: only the floor that keeps undetermined directions at the prior"
    rule = ("discrepancy" if known else "gcv") if rule == "auto" else rule
    U, s, _ = np.linalg.svd(J, full_matrices=False)
    b = J @ alpha - r
    beta = U.T @ b
    rest = max(float(b @ b - beta @ beta), 0.0)
    top = MU_RANGE * max(s[0] ** 2, 1e-300)

    def chi2(mu: float) -> float:
        return rest + float(np.sum((mu / (s**2 + mu) * beta) ** 2))

    def functional(mu: float) -> float:
        return chi2(mu) + mu * float(np.sum((s * beta / (s**2 + mu)) ** 2))

    if rule == "discrepancy":
        if functional(floor) >= n_eff:
            return floor, rule, (f"misfit {functional(floor):.3g} already at or above its expectation {n_eff} "
                                 "(the data less the profiled shape scales): no further regularisation")
        if functional(top) <= n_eff:
            return top, rule, f"even the prior fits within the noise (misfit {functional(top):.3g} <= {n_eff})"
        mu = float(np.exp(brentq(lambda t: functional(np.exp(t)) - n_eff, np.log(floor), np.log(top), xtol=1e-6)))
        return mu, rule, (f"|r|^2 + mu |alpha|^2 = {n_eff} (its expectation under the stated standard errors and "
                          "the prior N(0, I / mu))")
    free = n_eff - rank
    if free <= 0:
        return floor, rule, (f"GCV needs residual degrees of freedom ({n_eff} data, rank {rank}): the floor only "
                             "keeps undetermined directions at the prior; state standard errors for the discrepancy "
                             "rule")
    grid = np.exp(np.linspace(np.log(floor), np.log(top), 241))
    dof = np.array([n_eff - np.sum(s**2 / (s**2 + mu)) for mu in grid])
    gcv = np.array([chi2(mu) for mu in grid]) / np.maximum(dof, 1e-300) ** 2
    best = int(np.argmin(gcv))
    return float(grid[best]), rule, "minimum of the generalised cross-validation function (noise level unknown)"


def identifiability(J: np.ndarray, labels: list[str], rank_tol: float) -> dict[str, Any]:
    """SVD of the weighted sensitivity ``J`` (n, q) in the scale factors: the
    numerical rank (singular values above ``rank_tol`` times the largest) and
    each undetermined combination (right singular vector below it, ``vector``
    over the parameters) with its four largest components by label."""
    q = J.shape[1]
    s, Vt = _svd(J)
    rank = int(np.sum(s > rank_tol * s[0])) if s[0] > 0 else 0
    combos = []
    for k in range(rank, q):
        v = Vt[k] * np.sign(Vt[k][np.argmax(np.abs(Vt[k]))])
        top = np.argsort(-np.abs(v))[:4]
        combos.append({"singular_value": float(s[k]),
                       "components": [{"label": labels[j], "weight": round(float(v[j]), 4)} for j in top],
                       "text": " ".join(f"{v[j]:+.2f} {labels[j]}" for j in top), "vector": v.tolist()})
    return {"rank": rank, "parameters": q, "rank_tol": rank_tol, "singular_values": s.tolist(),
            "undetermined": combos, "null_space": Vt[rank:]}


@dataclass
class Errors:
    """Covariance of the scale factors (q, q), how it was computed, and which
    parameters have no meaningful error (loaded on undetermined directions)."""

    cov: np.ndarray
    form: str
    void: np.ndarray
    extra: dict[str, Any] = field(default_factory=dict)


def errors(res: Residuals, ev: Evaluation, mu: float, known: bool, null_space: np.ndarray) -> Errors:
    """Linearised covariance of the regularised estimate, ``H = J^T J + mu I``:
    stated standard errors: ``H^-1``, the inverse of the Fisher information
    plus the regulariser's (the posterior covariance of Tikhonov read as a
    Gaussian prior), multiplied by ``chi2 / dof`` when the misfit exceeds its
    99 % quantile (a sign of model error); otherwise the sandwich
    ``H^-1 J^T S J H^-1``, ``S = diag(r_i^2 / (1 - h_i))`` (leverage-corrected, HC2)."""
    J, r = ev.J, ev.r
    H = J.T @ J + mu * np.eye(J.shape[1])
    Hinv = np.linalg.pinv(H)
    A = J @ Hinv @ J.T
    p_eff = float(np.trace(A))
    dof = res.n_res - res.n_scales - p_eff
    chi2 = float(r @ r)
    extra: dict[str, Any] = {"misfit": chi2, "dof": dof}
    if known:
        scale, form = 1.0, "fisher + regulariser, inverse (stated standard errors)"
        if dof > 0.5 and chi2 > chi2_dist.ppf(0.99, dof):
            scale = chi2 / dof
            form = f"fisher + regulariser, inverse, scaled by misfit/dof = {scale:.3g} (misfit above its 99 % quantile: model error)"
        cov = scale * Hinv
    else:
        h = np.clip(np.diag(A) + res.leverage_of_scales(ev), 0.0, 0.99)
        cov = Hinv @ (J.T * (r**2 / (1 - h))) @ J @ Hinv
        form = "sandwich HC2 (no or partial stated standard errors)"
    void = (np.sum(null_space**2, axis=0) > UNDETERMINED_LOAD) if null_space.size else np.zeros(J.shape[1], bool)
    return Errors(cov, form, void, extra)
