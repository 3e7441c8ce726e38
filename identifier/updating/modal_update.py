"""Updating from modal data (the residuals of :mod:`.residuals`): the
search keeps the mode numbers paired at the prior, the polish pairs by MAC
at every evaluation; or the stepwise change search (:mod:`.localise`) from
a baseline. The equations: the package docstring."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from structbench.models import Structure

from ..errors import IdentificationError
from ..io.results import Identification, ParameterEstimate
from . import data as modal_data
from .data import ModalData
from .flow import SEARCH_TOL, checked, dof_indices, estimates, refuse_on_bounds, selection, solve, starting_points
from .localise import stepwise
from .pairing import deduplicated
from .residuals import Residuals
from .sensitivity import AffineModel
from .solve import Fit, fit

NEEDED = ("model updating needs identified modal data: --option modal=FILE with a modal results file "
          "(DIR/results/modal.json from `structbench identify DIR --method modal`) or a modal-data file "
          "(docs/modal-data-format.md)")


def as_data(source: ModalData | dict | str | Path) -> ModalData:
    if isinstance(source, ModalData):
        return source
    if isinstance(source, dict):
        return modal_data.from_document(source, "modal data")
    return modal_data.load(source)


def with_shape_std(data: ModalData, shape_std: float | None) -> ModalData:
    if shape_std is None:
        return data
    scale = np.nanmax(np.abs(data.shapes), axis=0, keepdims=True)
    std = np.where(np.isnan(data.shape_std), float(shape_std) * scale, data.shape_std)
    return ModalData(data.lam, data.lam_std, data.shapes, std, data.dofs, data.source)


def update(model: Structure, data: ModalData | dict | str | Path, kinds: str | Sequence[str] | None = None,
           bounds: Sequence[float] = (-0.9, 3.0), starts: int = 1, scatter: float = 0.3, seed: int = 0,
           regularisation: str | float = "auto", rank_tol: float = 1e-6, shape_std: float | None = None,
           modes: Sequence[int] | None = None, parameters: Sequence[str] | None = None,
           max_nfev: int = 200, tol: float = 1e-10, localise: bool = False, level: float = 0.001,
           x0: Sequence[Sequence[float]] | None = None, repetition: int = 0,
           tests: Sequence[str] = ()) -> Identification:
    """Update the prior ``model`` to the modal ``data`` (see the module
    docstring). ``bounds``: ``[lower, upper]`` on every ``alpha`` (``lower >
    -1`` keeps parameters positive); ``modes``: 0-based measured modes to use;
    ``parameters``: labels (``stiffness[3]``) to update, of the chosen kinds
    (default: all of them; the others stay at the prior);
    ``x0``: explicit starting points in ``alpha`` (replace the prior and the
    random draws); ``localise``: instead of updating every parameter, select
    the few that changed from the prior (a baseline) by forward stepwise
    F tests at family level ``level`` (:mod:`.localise`)."""
    if not isinstance(model, Structure):
        raise IdentificationError(f"model updating needs a finite-element model; {model.name} is modal",
                                  field="model")
    if data is None:
        raise IdentificationError(NEEDED, field="modal")
    measured = with_shape_std(as_data(data).select(None if modes is None else list(modes)), shape_std)
    sel = selection(model, kinds, parameters)
    lo, hi = checked(regularisation, starts, scatter, bounds)
    labels = [model.parameters[j].label for j in sel]
    affine = AffineModel(model, sel, dof_indices(model, measured.dofs, measured.source, "measured DOF"))
    res = Residuals(affine, measured)
    measured, left_out = deduplicated(res, measured, None if modes is None else list(modes))
    if left_out:
        res = Residuals(affine, measured)
    lower, upper = np.full(sel.size, lo), np.full(sel.size, hi)
    if localise:
        found = _localised(model, sel, labels, affine, res, measured, lo, hi, float(level), tol, int(max_nfev),
                           repetition, tests)
        found.details["left_out"] = left_out
        return found
    search = Residuals(affine, measured, "entry")
    search.fix_pairs(res(np.zeros(sel.size)).pairs)

    def from_start(x: np.ndarray, floor: float) -> Fit:
        return fit(search, x, floor, lower, upper, max_nfev, max(tol, SEARCH_TOL))

    out = solve(res, from_start, labels, lower, upper, starting_points(x0, seed, starts, scatter, sel.size, lo, hi),
                regularisation, rank_tol, max_nfev, tol)
    prior, final, ev, report, err, mu, rule, why, fits, agree, floor = (
        out.prior, out.final, out.ev, out.report, out.err, out.mu, out.rule, out.why, out.fits, out.agree, out.floor)
    n_eff = res.n_res - res.n_scales
    alpha = final.alpha
    p0 = affine.p0[sel]
    params, at_bound = estimates(model, sel, p0, alpha, err, lower, upper)
    if len(at_bound) == sel.size:
        refuse_on_bounds(labels, lo, hi, prior.r, ev.r, _worst_pairs(res, left_out))
    stated = res.stated
    details = {
        "data": measured.source, "modes": int(measured.lam.size), "sensors_dof": [list(d) for d in measured.dofs],
        "n_data": res.n_res, "n_effective": n_eff, "parameters": labels, "alpha": alpha.tolist(),
        "weights": {k: ("stated standard errors" if v else "unit (no standard errors stated)")
                    for k, v in stated.items()},
        "regularisation": {"rule": rule, "weight": mu, "floor": floor, "reason": why},
        "identifiability": report, "std_errors": err.form, "misfit": err.extra["misfit"],
        "dof": err.extra["dof"], "pairs": (ev.pairs + 1).tolist(), "mac": ev.mac.tolist(),
        "mode_switches": res.switches + search.switches, "at_bound": at_bound, "left_out": left_out,
        "starts": {"count": len(fits), "seed": seed, "scatter": scatter, "agreeing": int(agree),
                   "costs": [f.cost for f in fits]},
    }
    omega = np.sqrt(np.clip(ev.lam, 0.0, None))
    return Identification(
        method="updating", structure=model.name, repetition=repetition, tests=list(tests),
        status="converged" if final.status > 0 else "max-iterations",
        message="" if final.status > 0 else final.message, parameters=params,
        iterations=final.nfev, history=[p0.tolist(), [p.value for p in params]],
        misfit_history=[float(np.sqrt(prior.r @ prior.r)), float(np.sqrt(ev.r @ ev.r))],
        omega=omega.tolist(), eigenvalues=ev.lam.tolist(), details=details)


def _worst_pairs(res: Residuals, left_out: list[dict]) -> str:
    """The three measured modes whose eigenvalue residual at the prior is the
    largest, with the model mode paired to each, and any modes left out."""
    ev = res(np.zeros(res.model.q))
    lam = res.model.modes(*res.model.matrices(np.zeros(res.model.q)), res.count)[0]
    worst = np.argsort(-np.abs(ev.r[:res.k]))[:3]
    text = "; ".join(f"measured mode {i + 1} ({np.sqrt(res.data.lam[i]):.4g} rad/s) paired with model mode "
                     f"{ev.pairs[i] + 1} ({np.sqrt(max(lam[ev.pairs[i]], 0.0)):.4g} rad/s), residual "
                     f"{ev.r[i]:+.3g} standard errors" for i in worst)
    return text + "".join(f"; {d['text']}" for d in left_out)


def _localised(model: Structure, sel: np.ndarray, labels: list[str], affine: AffineModel, res: Residuals,
               measured: ModalData, lo: float, hi: float, level: float, tol: float, max_nfev: int,
               repetition: int, tests: Sequence[str]) -> Identification:
    """The result of the stepwise change search (:mod:`.localise`)."""
    if not 0 < level < 1:
        raise IdentificationError(f"level must be in (0, 1), got {level}", field="level")
    n_eff = res.n_res - res.n_scales
    before = res(np.zeros(sel.size))
    found = stepwise(res, labels, n_eff, lo, hi, level, tol, max_nfev)
    ev = res(found.alpha)
    p0 = affine.p0[sel]
    params = [ParameterEstimate(lab, model.parameters[j].kind, model.parameters[j].unit, float(v0 * (1 + a)),
                                None if np.isnan(s) else float(s * abs(v0)), float(v0))
              for lab, j, v0, a, s in zip(labels, sel, p0, found.alpha, found.std)]
    details = {
        "data": measured.source, "modes": int(measured.lam.size), "sensors_dof": [list(d) for d in measured.dofs],
        "n_data": res.n_res, "n_effective": n_eff, "parameters": labels, "alpha": found.alpha.tolist(),
        "weights": {k: ("stated standard errors" if v else "unit (no standard errors stated)")
                    for k, v in res.stated.items()},
        "std_errors": "stepwise: s^2 (J_S^T J_S)^-1 of the selected changes, s^2 = misfit / (n_eff - |S|); "
                      "null where not selected",
        "misfit": found.cost, "dof": n_eff - len(found.selected), "pairs": (ev.pairs + 1).tolist(),
        "mac": ev.mac.tolist(), "mode_switches": res.switches,
        "localisation": {"level": level, "selected": [labels[j] for j in found.selected], "steps": found.steps},
    }
    return Identification(
        method="updating", structure=model.name, repetition=repetition, tests=list(tests), status="converged",
        message="", parameters=params, iterations=found.nfev, history=[p0.tolist(), [p.value for p in params]],
        misfit_history=[float(np.sqrt(before.r @ before.r)), float(np.sqrt(found.cost))],
        omega=np.sqrt(np.clip(ev.lam, 0.0, None)).tolist(), eigenvalues=ev.lam.tolist(), details=details)
