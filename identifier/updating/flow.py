"""The solution flow every residual kind of updating shares (modal data,
FRFs, both): the parameters chosen and the options checked, the starting
points, the search from each start, the regularisation weight, the polish,
the identifiability report and the standard errors (equations: the
package docstring and :mod:`.solve`), and the estimates they give.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from structbench.models import ModelError, Structure

from ..errors import IdentificationError
from ..io.results import ParameterEstimate
from .solve import FLOOR, Fit, choose_weight, errors, fit, identifiability, min_norm

REGULARISATION = ("auto", "discrepancy", "gcv", "none")
SEARCH_TOL = 1e-6  # tolerance of the searches from the starts; the polish then uses ``tol``


def kinds_of(model: Structure, kinds: str | Sequence[str] | None) -> tuple[str, ...]:
    chosen = model.unknown if kinds is None else ((kinds,) if isinstance(kinds, str) else tuple(kinds))
    chosen = tuple(k.strip() for item in chosen for k in item.split(",") if k.strip())
    bad = sorted(set(chosen) - {"mass", "stiffness", "damping"})
    if bad:
        raise IdentificationError(f"unknown parameter kind(s) {bad}; modal data update mass and stiffness",
                                  field="kinds")
    return tuple(k for k in chosen if k != "damping")


def selection(model: Structure, kinds: str | Sequence[str] | None, parameters: Sequence[str] | None) -> np.ndarray:
    sel = np.flatnonzero(model.kind_mask(kinds_of(model, kinds)))
    if parameters is not None:
        wanted = [parameters] if isinstance(parameters, str) else list(parameters)
        known = {model.parameters[j].label: j for j in sel}
        missing = [w for w in wanted if w not in known]
        if missing:
            raise IdentificationError(f"no parameter {', '.join(missing)} of the kinds {kinds_of(model, kinds)} in "
                                      f"{model.name}", field="parameters")
        sel = np.array(sorted(known[w] for w in wanted), dtype=int)
    if sel.size == 0:
        raise IdentificationError(f"{model.name} has no parameter of the kinds {kinds or model.unknown} "
                                  "(damping is not updated)", field="kinds")
    return sel


def checked(regularisation: str | float, starts: int, scatter: float, bounds: Sequence[float]) -> tuple[float, float]:
    if isinstance(regularisation, str) and regularisation not in REGULARISATION:
        raise IdentificationError(f"regularisation must be one of {', '.join(REGULARISATION)} or a number >= 0, "
                                  f"got {regularisation!r}", field="regularisation")
    if not isinstance(regularisation, str) and not float(regularisation) >= 0:
        raise IdentificationError(f"regularisation weight must be >= 0, got {regularisation}", field="regularisation")
    if int(starts) < 1 or not float(scatter) >= 0:
        raise IdentificationError(f"starts must be >= 1 and scatter >= 0, got {starts} and {scatter}", field="starts")
    if len(bounds) != 2:
        raise IdentificationError(f"bounds must be [lower, upper], got {bounds}", field="bounds")
    lo, hi = float(bounds[0]), float(bounds[1])
    if not -1.0 <= lo < 0.0 < hi:
        raise IdentificationError(f"bounds must satisfy -1 <= lower < 0 < upper, got {list(bounds)}", field="bounds")
    return lo, hi


def dof_indices(model: Structure, dofs: Sequence[tuple[int, str]], source: str, what: str) -> np.ndarray:
    try:
        return np.array([model.dof_index(n, d) for n, d in dofs], dtype=int)
    except ModelError as err:
        raise IdentificationError(f"{source}: {err}; the {what} must be free DOF of the prior model",
                                  field="dofs") from None


def starting_points(x0: Sequence[Sequence[float]] | None, seed: int, starts: int, scatter: float, q: int, lo: float,
            hi: float) -> list[np.ndarray]:
    """The starting points in ``alpha``: ``x0``, else the prior and ``starts - 1``
    draws ``N(0, scatter^2)`` clipped to the bounds (``default_rng(seed)``)."""
    if x0 is not None:
        return [np.asarray(x, dtype=float) for x in x0]
    rng = np.random.default_rng(seed)
    return [np.zeros(q)] + [np.clip(rng.normal(0.0, scatter, q), lo, hi) for _ in range(max(int(starts), 1) - 1)]


@dataclass
class Solved:
    """What :func:`solve` found (see there)."""

    prior: Any
    final: Fit
    ev: Any
    report: dict[str, Any]
    err: Any
    mu: float
    rule: str
    why: str
    fits: list[Fit]
    agree: int
    floor: float


def solve(res: Any, from_start: Any, labels: list[str], lower: np.ndarray, upper: np.ndarray,
           points: list[np.ndarray], regularisation: str | float, rank_tol: float, max_nfev: int,
           tol: float, recost: bool = False) -> Solved:
    """The common flow of every residual kind: the floor weight from the
    weighted sensitivity at the prior, a search from each start
    (``from_start(x, floor)`` returns a :class:`~.solve.Fit`; with ``recost``
    its ``cost`` is re-evaluated on ``res``), the weight chosen at the best start's answer, the
    polish on ``res``, the weight again at the answer, the minimum-norm
    completion of undetermined directions, identifiability and errors."""
    q = len(labels)
    prior = res(np.zeros(q))
    J0 = prior.J if np.all(np.isfinite(prior.r)) else np.nan_to_num(prior.J)
    s1 = float(np.linalg.norm(J0, 2)) if J0.size else 0.0
    floor = FLOOR * max(s1**2, 1e-300)
    fits = []
    for x in points:
        found = from_start(x, floor)
        if recost:
            r = res(found.alpha).r
            found.cost = 0.5 * float(r @ r) if np.all(np.isfinite(r)) else np.inf
        fits.append(found)
    best = min(fits, key=lambda f: f.cost)
    agree = sum(np.max(np.abs(f.alpha - best.alpha)) < 1e-3 for f in fits)
    known = all(res.stated.values())
    n_eff = res.n_res - res.n_scales
    rule_given = str(regularisation) if isinstance(regularisation, str) else regularisation

    def weight(alpha: np.ndarray) -> tuple[float, str, str, int]:
        here = res(alpha)
        rank = identifiability(here.J, labels, rank_tol)["rank"]
        return (*choose_weight(here.J, here.r, alpha, n_eff, rank, known, floor, rule_given), rank)

    mu, rule, why, rank = weight(best.alpha)
    final = fit(res, best.alpha, mu, lower, upper, max_nfev, tol)
    again = weight(final.alpha)  # the weight from the linear model at the answer itself
    if not 0.5 <= again[0] / mu <= 2.0:
        mu, rule, why, rank = again
        final = fit(res, final.alpha, mu, lower, upper, max_nfev, tol)
    if rank < q and mu <= floor * (1 + 1e-9):
        polished = min_norm(res, final.alpha, rank_tol, lower, upper)
        if np.sum(res(polished).r ** 2) <= max(2 * np.sum(res(final.alpha).r ** 2), 1e-20):
            final.alpha = polished
    ev = res(final.alpha)
    report = identifiability(ev.J, labels, rank_tol)
    err = errors(res, ev, mu, known, report.pop("null_space"))
    return Solved(prior, final, ev, report, err, mu, rule, why, fits, int(agree), floor)


def estimates(model: Structure, sel: np.ndarray, p0: np.ndarray, alpha: np.ndarray, err: Any,
              lower: np.ndarray, upper: np.ndarray) -> tuple[list[ParameterEstimate], list[str]]:
    """The updated parameters (SI; ``std_error`` None where undetermined) from
    the scale factors ``alpha`` and the errors ``err`` (:func:`.solve.errors`),
    and the labels of those that ended on a bound."""
    std = np.sqrt(np.clip(np.diag(err.cov), 0.0, None)) * np.abs(p0)
    edge = np.isclose(alpha, lower, atol=1e-6) | np.isclose(alpha, upper, atol=1e-6)
    params = [ParameterEstimate(model.parameters[j].label, model.parameters[j].kind, model.parameters[j].unit,
                                float(v0 * (1 + a)), None if void else float(s), float(v0))
              for j, v0, a, s, void in zip(sel, p0, alpha, std, err.void)]
    return params, [p.label for p, e in zip(params, edge) if e]


def refuse_on_bounds(labels: list[str], lo: float, hi: float, r_prior: np.ndarray, r_answer: np.ndarray,
                     hint: str = "") -> None:
    """Raise :class:`IdentificationError`: every parameter ended on a bound of
    ``alpha`` in ``[lo, hi]``, which is no answer (the data cannot be fitted
    by the prior's model within the bounds: most often modes paired wrongly
    or a wrong model). Names the misfits ``|r|^2`` at the prior and at the
    bound and the ``hint`` (what the residual kind knows of the cause)."""
    cost = [float(np.sum(np.nan_to_num(r, posinf=1e150, neginf=-1e150) ** 2)) for r in (r_prior, r_answer)]
    raise IdentificationError(
        f"every parameter ({len(labels)}: {', '.join(labels[:3])}{', ...' if len(labels) > 3 else ''}) ended on a "
        f"bound of alpha [{lo:g}, {hi:g}], which is no answer (misfit {cost[0]:.3g} at the prior, {cost[1]:.3g} "
        "there): the prior's model cannot fit these data within the bounds; check the data's modes and their "
        "pairing" + (f" ({hint})" if hint else "") + ", the model's topology, or the bounds", field="bounds")
