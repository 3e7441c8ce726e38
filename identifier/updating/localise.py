"""Sparse change detection from a baseline prior: forward stepwise selection.

When the prior is a baseline's updated model and the data come from the
same structure later, a local change (damage) moves few parameters. Fitting
every parameter at once spreads it over the combinations the data barely
determine; the stepwise search instead fits changes of as few parameters as
the data demand (``alpha`` (q,), ``p_j = p0_j (1 + alpha_j)``, residuals of
:mod:`.residuals`):

1. the selected set ``S`` starts empty (every ``alpha = 0``, the baseline);
   misfit ``c_S = min |r(alpha_S)|^2`` over the parameters in ``S``;
2. each parameter ``j`` outside ``S`` is tried: ``c_j = c_{S + j}`` by
   bounded trust-region least squares (no regularisation: ``|S|`` is small),
   for the ``SCREEN`` candidates of the largest linearised drops
   ``(J_j^T r)^2 / |J_j|^2`` at the current answer (the others cannot win);
3. the best ``j`` joins ``S`` when its partial F statistic
   ``F = (c_S - c_j) / (c_j / (n_eff - |S| - 1))`` exceeds the
   ``1 - level / n_candidates`` quantile of ``F(1, n_eff - |S| - 1)``
   (a Bonferroni bound over the candidates); otherwise the search stops.

The F statistic compares misfit drops with the misfit left, so a common
scale error of the stated standard errors (the baseline's own error is
part of what the damaged data see) cancels. Standard errors of the selected
changes: ``s^2 (J_S^T J_S)^-1`` with ``s^2 = c_S / (n_eff - |S|)``, relative
to the prior (they already include the baseline's mismatch through ``s^2``);
unselected parameters keep the prior's value with ``std_error`` null.

The search stops when the misfit left is below ``EXACT * n_eff`` (data
fitted exactly: an F statistic of rounding errors means nothing). Fails
like :func:`structbench.identifier.updating.update`; needs ``n_eff``
greater than the parameters selected.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import f as f_dist

from .residuals import Residuals

SCREEN = 6        # candidates fitted in full per step: those of the largest linearised misfit drops
TRIAL_TOL = 1e-8  # tolerance of those fits
EXACT = 1e-12  # misfit per datum (in stated standard errors) below which nothing is left to explain


@dataclass
class Localised:
    """The stepwise answer: ``alpha`` (q,), relative ``std`` (q,) (NaN where
    not selected), the selected indices in order, the misfit ``cost`` and
    the steps (``{"label", "misfit", "F", "threshold"}``, the last one refused)."""

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


def stepwise(res: Residuals, labels: list[str], n_eff: int, lower: float, upper: float, level: float = 0.001,
             tol: float = 1e-10, max_nfev: int = 200) -> Localised:
    """Forward stepwise selection of changed parameters (module docstring)."""
    q = len(labels)
    alpha, chosen, steps, nfev = np.zeros(q), [], [], 0
    ev = res(alpha)
    cost = float(ev.r @ ev.r)
    while len(chosen) < min(q, n_eff - 2) and cost > EXACT * n_eff:  # below: the data are fitted exactly
        dof = n_eff - len(chosen) - 1
        free = [j for j in range(q) if j not in chosen]
        here = res(alpha)
        Jf = here.J[:, free]
        drop = (Jf.T @ here.r) ** 2 / np.maximum(np.sum(Jf * Jf, axis=0), 1e-300)  # linearised misfit drops
        trials = []
        for j in [free[i] for i in np.argsort(-drop)[:SCREEN]]:
            a, c, n = _fit(res, chosen + [j], q, alpha, lower, upper, max(tol, TRIAL_TOL), max_nfev)
            trials.append((c, j, a))
            nfev += n
        c, j, a = min(trials, key=lambda t: t[0])
        stat = (cost - c) / max(c / dof, 1e-300)
        threshold = float(f_dist.ppf(1.0 - level / len(free), 1, dof))
        steps.append({"label": labels[j], "misfit": c, "F": float(stat), "threshold": threshold})
        if not stat > threshold:
            break
        chosen, alpha, cost = chosen + [j], a, c
    std = np.full(q, np.nan)
    if chosen:
        J = res(alpha).J[:, chosen]
        s2 = cost / max(n_eff - len(chosen), 1)
        std[chosen] = np.sqrt(np.clip(np.diag(np.linalg.pinv(J.T @ J)) * s2, 0.0, None))
    return Localised(alpha, std, chosen, cost, nfev, steps)
