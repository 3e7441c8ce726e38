"""Sparse change detection from a baseline prior: forward stepwise selection
tested against the baseline's own error.

When the prior is a baseline's updated model and the data come from the
same structure later, a local change (damage) moves few parameters. Fitting
every parameter at once spreads it over the combinations the data barely
determine; the stepwise search instead fits changes of as few parameters as
the data demand (``alpha`` (q,), ``p_j = p0_j (1 + alpha_j)``, residuals
``r`` (n,) of :mod:`.residuals` in stated standard errors, Jacobian ``J``
(n, q), ``n_eff`` independent data).

The baseline is not the truth: in the directions its sensors could not
determine it keeps its own prior's error, and the later data see that error
as small changes of every parameter. A partial F test whose null holds the
unselected parameters exactly at the baseline counts that error as evidence,
and an element beside the damaged one enters to soak it up. The null here
is a linear mixed model: the selected changes are fixed effects, every other
``alpha_j ~ N(0, gamma sigma^2)`` (the baseline's error, a random effect
whose variance ratio ``gamma`` the data estimate), the noise ``N(0, sigma^2)``
in the stated errors:

1. the selected set ``S`` starts empty; ``alpha_S`` is its least-squares
   fit with the others at the baseline (bounded trust region), misfit ``c_S``;
2. the ``SCREEN`` parameters ``j`` outside ``S`` of the largest linearised
   drops ``(J_j^T r)^2 / |J_j|^2`` at ``alpha_S`` are fitted as ``T = S + j``;
   the one of the least misfit ``c_T`` is the candidate (the others cannot
   win);
3. the candidate is tested by the likelihood ratio of the mixed models
   ``S`` and ``T``, each linearised at its own fit, with ``gamma`` and
   ``sigma^2`` maximised in each: ``-2 log L_U = min_gamma n_eff log(c_U(gamma)
   / n_eff) + sum_i log(1 + gamma s_i^2)``, ``c_U(gamma) = sum_i z_i^2 / (1 +
   gamma s_i^2) + |P r|^2 - |z|^2`` (``P`` projects out ``J_U``, ``P J_{not U}
   = U diag(s) V^T``, ``z = U^T P r``: the generalised least-squares misfit
   ``r^T V^-1 r``, ``V = I + gamma J_{not U} J_{not U}^T``), ``gamma`` in
   ``{0} + GAMMA_RANGE``; the ratio as an F statistic
   ``F = (n_eff - |S| - 1) (exp((-2 log L_S + 2 log L_T) / n_eff) - 1)``,
   which with ``gamma = 0`` in both is the classical partial F
   ``(c_S - c_T) / (c_T / (n_eff - |S| - 1))``;
4. the candidate joins ``S`` when ``F`` exceeds the ``1 - level /
   n_candidates`` quantile of ``F(1, n_eff - |S| - 1)`` (a Bonferroni bound
   over the candidates); otherwise the search stops.

A damaged candidate explains its change in ``T`` and leaves the baseline's
scatter to ``gamma``; without it the same change must be spread over many
small random effects, which costs likelihood. An undamaged neighbour gains
only what the random effects could already explain. Both likelihoods profile
``sigma^2``, so a common scale error of the stated standard errors cancels.
The reported changes are the fixed-effect fit of ``S`` (the unselected at
the baseline), with standard errors ``s^2 (J_S^T J_S)^-1``, ``s^2 = c_S /
(n_eff - |S|)``, which hold the baseline's mismatch through ``s^2``;
unselected parameters keep the prior's value with ``std_error`` null.

The search stops when the misfit left is below ``EXACT * n_eff`` (data
fitted exactly: an F statistic of rounding errors means nothing). Fails
like :func:`structbench.identifier.updating.update`; needs ``n_eff``
greater than the parameters selected plus one.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares, minimize_scalar
from scipy.stats import f as f_dist

from .residuals import Residuals

SCREEN = 6        # candidates fitted per step: those of the largest linearised misfit drops
TRIAL_TOL = 1e-8  # tolerance of the candidates' fits
EXACT = 1e-12  # misfit per datum (in stated standard errors) below which nothing is left to explain
GAMMA_RANGE = (1e-10, 1.0)  # searched variance ratios of the random effect (its relative scatter^2 / sigma^2), and 0


@dataclass
class Localised:
    """The stepwise answer: ``alpha`` (q,), relative ``std`` (q,) (NaN where
    not selected), the selected indices in order, the misfit ``cost`` and
    the steps (``{"label", "misfit", "F", "threshold", "scatter"}``, the last
    one refused; ``scatter``: ``sqrt(gamma)`` of the models ``S`` and ``T``,
    the baseline's relative error per parameter in units of the noise scale)."""

    alpha: np.ndarray
    std: np.ndarray
    selected: list[int]
    cost: float
    nfev: int
    steps: list[dict[str, Any]] = field(default_factory=list)


def _fit(res: Residuals, subset: list[int], q: int, start: np.ndarray, lower: float, upper: float,
         tol: float, max_nfev: int) -> tuple[np.ndarray, float, int]:
    """``min |r(alpha)|^2`` over ``alpha[subset]`` (the rest 0): (alpha, misfit, evaluations)."""
    idx = np.asarray(subset, dtype=int)

    def full(x: np.ndarray) -> np.ndarray:
        a = np.zeros(q)
        a[idx] = x
        return a

    x0 = np.clip(start[idx], lower + 1e-9, upper - 1e-9)
    out = least_squares(lambda x: res(full(x)).r, x0, lambda x: res(full(x)).J[:, idx], bounds=(lower, upper),
                        method="trf", x_scale="jac", ftol=tol, xtol=tol, gtol=None, max_nfev=max_nfev)
    return full(out.x), float(2 * out.cost), int(out.nfev)


def profile(r: np.ndarray, J: np.ndarray, fixed: list[int], n_eff: int) -> tuple[float, float]:
    """``(min over gamma of -2 log L + const, gamma)``: the maximum likelihood
    of the linear mixed model ``r = J_T b + J_R d + e``, ``d ~ N(0, gamma
    sigma^2 I)``, ``e ~ N(0, sigma^2 I)`` (``T = fixed``, ``R`` the other
    columns of ``J`` (n, q)), ``b`` and ``sigma^2`` profiled out:
    ``n_eff log(c(gamma) / n_eff) + log det(I + gamma J_R J_R^T)``, with the
    generalised least-squares misfit ``c(gamma) = sum_i z_i^2 / (1 + gamma
    s_i^2) + |P r|^2 - |z|^2`` (``P`` projects out ``J_T``, ``P J_R = U diag(s)
    V^T``, ``z = U^T P r``); ``gamma`` in ``{0} + GAMMA_RANGE``. ``r`` is the
    residual at the fit of ``T`` (the linearisation point)."""
    rest = np.setdiff1d(np.arange(J.shape[1]), fixed)
    K = J[:, rest]
    det_s2 = np.linalg.svd(K, compute_uv=False) ** 2 if rest.size else np.zeros(0)
    if fixed:
        Q, _ = np.linalg.qr(J[:, fixed])
        r = r - Q @ (Q.T @ r)
        K = K - Q @ (Q.T @ K)
    U, s, _ = np.linalg.svd(K, full_matrices=False)
    keep = s > s[0] * 1e-10 if s.size and s[0] > 0 else np.zeros(s.size, dtype=bool)
    z2 = (U[:, keep].T @ r) ** 2
    s2 = s[keep] ** 2
    other = max(float(r @ r - z2.sum()), 0.0)

    def objective(gamma: float) -> float:
        c = float(np.sum(z2 / (1.0 + gamma * s2))) + other
        return n_eff * np.log(max(c / n_eff, 1e-300)) + float(np.sum(np.log1p(gamma * det_s2)))

    lo, hi = np.log(GAMMA_RANGE[0]), np.log(GAMMA_RANGE[1])
    out = minimize_scalar(lambda x: objective(np.exp(x)), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-4})
    best = min((0.0, float(np.exp(out.x)), GAMMA_RANGE[1]), key=objective)  # the search may miss an end
    return float(objective(best)), best


def stepwise(res: Residuals, labels: list[str], n_eff: int, lower: float, upper: float, level: float = 0.001,
             tol: float = 1e-10, max_nfev: int = 200) -> Localised:
    """Forward stepwise selection of changed parameters, each step tested
    against a baseline with its own error (module docstring)."""
    q = len(labels)
    alpha, chosen, steps, nfev = np.zeros(q), [], [], 0
    ev = res(alpha)
    cost = float(ev.r @ ev.r)
    trial_tol = max(tol, TRIAL_TOL)
    while len(chosen) < min(q, n_eff - 2) and cost > EXACT * n_eff:  # below: the data are fitted exactly
        dof = n_eff - len(chosen) - 1
        free = [j for j in range(q) if j not in chosen]
        here = res(alpha)
        Jf = here.J[:, free]
        drop = (Jf.T @ here.r) ** 2 / np.maximum(np.sum(Jf * Jf, axis=0), 1e-300)  # linearised misfit drops
        trials = []
        for j in [free[i] for i in np.argsort(-drop)[:SCREEN]]:
            a, c, n = _fit(res, chosen + [j], q, alpha, lower, upper, trial_tol, max_nfev)
            trials.append((c, j, a))
            nfev += n
        c_j, j, a_j = min(trials, key=lambda t: t[0])
        at_t = res(a_j)
        l_s, gamma_s = profile(here.r, here.J, chosen, n_eff)
        l_t, gamma = profile(at_t.r, at_t.J, chosen + [j], n_eff)
        stat = dof * np.expm1(min((l_s - l_t) / n_eff, 700.0))  # the likelihood ratio as an F statistic
        threshold = float(f_dist.ppf(1.0 - level / len(free), 1, dof))
        steps.append({"label": labels[j], "misfit": c_j, "F": float(stat), "threshold": threshold,
                      "scatter": [float(np.sqrt(gamma_s)), float(np.sqrt(gamma))]})
        if not stat > threshold:
            break
        chosen, alpha, cost = chosen + [j], a_j, c_j
    std = np.full(q, np.nan)
    if chosen:
        J = res(alpha).J[:, chosen]
        s2 = cost / max(n_eff - len(chosen), 1)
        std[chosen] = np.sqrt(np.clip(np.diag(np.linalg.pinv(J.T @ J)) * s2, 0.0, None))
    return Localised(alpha, std, chosen, cost, nfev, steps)
