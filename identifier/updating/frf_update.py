"""Updating from FRFs (the residuals of :mod:`.frf_residuals`, the lines of
:mod:`.frf_data`), alone or stacked with modal data or with the natural
frequencies of the free vibration in harmonic records. The equations: the
package docstring and :mod:`.frf_residuals`."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from structbench.models import Structure

from ..errors import IdentificationError
from ..io.results import Identification
from .data import ModalData
from .flow import SEARCH_TOL, checked, dof_indices, estimates, refuse_on_bounds, selection, solve, starting_points
from .frf_data import FrfData
from .frf_residuals import ETAS, Combined, FrfResiduals, resonant_lines
from .modal_update import as_data, with_shape_std
from .pairing import deduplicated
from .residuals import Residuals
from .sensitivity import AffineModel
from .solve import Fit, fit, identifiability

NATURAL_REL_STD = 1e-3  # natural frequencies of the records used only when known to this relative standard error
NATURAL_FACTOR = 10.0   # their stated error: this times the Cramer-Rao bound (see _natural)
NATURAL_FLOOR = 1e-7    # and at least this share of the frequency


def _natural(frf: FrfData) -> ModalData | None:
    """The free-vibration natural frequencies of the harmonic records
    (``frf.natural``), those whose Cramer-Rao standard error is below
    :data:`NATURAL_REL_STD` of the frequency, as modal data without shapes
    (None when there are none). Stated error: :data:`NATURAL_FACTOR` times the
    Cramer-Rao bound, at least :data:`NATURAL_FLOOR` relative. The bound
    assumes the record's model (forced plus free sinusoids) exact; on the
    chapter 4 records the estimates scatter up to 10 to 18 times it (the
    leakage of components not fitted exactly, the first mode's 3 cycles in
    200 s against the fitted drift)."""
    w, s = frf.natural, frf.natural_std
    ok = np.isfinite(w) & np.isfinite(s) & (w > 0) & (s < NATURAL_REL_STD * np.where(w > 0, w, 1.0))
    if not ok.any():
        return None
    w, s = w[ok], np.maximum(NATURAL_FACTOR * s[ok], NATURAL_FLOOR * w[ok])
    m = len(frf.dofs)
    return ModalData(w**2, 2 * w * s, np.full((m, w.size), np.nan), np.full((m, w.size), np.nan), list(frf.dofs),
                     "natural frequencies of the free vibration in the harmonic records")


def _underdetermined(res: FrfResiduals, labels: list[str], rank_tol: float) -> bool:
    """Whether the FRF residuals' weighted sensitivity at the prior has
    numerical rank below the number of parameters."""
    J = res(np.zeros(len(labels))).J
    if not np.all(np.isfinite(J)):
        J = res.with_eta(ETAS[-1])(np.zeros(len(labels))).J
    return identifiability(J, labels, rank_tol)["rank"] < len(labels)


def update_frf(model: Structure, frf: FrfData, kinds: str | Sequence[str] | None = None,
               bounds: Sequence[float] = (-0.9, 3.0), starts: int = 1, scatter: float = 0.3, seed: int = 0,
               regularisation: str | float = "auto", rank_tol: float = 1e-6, parameters: Sequence[str] | None = None,
               max_nfev: int = 200, tol: float = 1e-10, x0: Sequence[Sequence[float]] | None = None,
               modal: ModalData | dict | str | Path | None = None, shape_std: float | None = None,
               modes: Sequence[int] | None = None, natural: bool | str = "auto", repetition: int = 0,
               tests: Sequence[str] = ()) -> Identification:
    """Update the prior ``model`` to measured FRFs ``frf`` (:mod:`.frf_residuals`),
    and to the modal data ``modal`` as well when given (residuals stacked,
    each weighted by its own stated errors). Without ``modal``, the natural
    frequencies of the free vibration in the harmonic records
    (``frf.natural``, :func:`_natural`) are added when ``natural`` is True,
    or with ``"auto"`` when the FRFs alone leave the parameters undetermined
    (the weighted sensitivity at the prior of numerical rank below their
    number at ``rank_tol``: one response per force on an undamped structure
    gives one real number per line). Options as :func:`.modal_update.update`."""
    if not isinstance(model, Structure):
        raise IdentificationError(f"model updating needs a finite-element model; {model.name} is modal",
                                  field="model")
    sel = selection(model, kinds, parameters)
    lo, hi = checked(regularisation, starts, scatter, bounds)
    labels = [model.parameters[j].label for j in sel]
    sensors = dof_indices(model, frf.dofs, frf.source, "measured DOF")
    forces = dof_indices(model, frf.force, frf.source, "forced DOF")
    affine = AffineModel(model, sel, sensors)
    C = model.damping(model.values)
    damped = C.nnz > 0 and bool(np.any(C.data != 0))
    damping = (C.toarray() if affine.dense else sp.csc_matrix(C)) if damped else None
    keep = resonant_lines(affine, frf, damped)
    res_frf = FrfResiduals(affine, frf, forces, damping, 0.0, keep)
    if res_frf.n_res == 0:
        raise IdentificationError(f"{frf.source}: no FRF line left to update from", field="frf")
    measured, left_out = None, []
    res: Any = res_frf
    if modal is not None:
        measured = with_shape_std(as_data(modal).select(None if modes is None else list(modes)), shape_std)
        measured, left_out = deduplicated(Residuals(AffineModel(model, sel, _at(model, measured)), measured),
                                          measured, None if modes is None else list(modes))
    elif natural is True or (natural == "auto" and _underdetermined(res_frf, labels, rank_tol)):
        measured = _natural(frf)
    if measured is not None:
        res = Combined(Residuals(AffineModel(model, sel, _at(model, measured)), measured), res_frf)
    lower, upper = np.full(sel.size, lo), np.full(sel.size, hi)
    stages: list[Any] = [res_frf.with_eta(e, "log") for e in ([] if damped else ETAS)] + [res_frf.with_eta(0.0, "log")]
    guide = measured if measured is not None else _natural(frf)
    if guide is not None:  # the natural frequencies place the model's resonances during the search
        guided = Residuals(AffineModel(model, sel, _at(model, guide)), guide)
        stages = [Combined(guided, stage) for stage in stages]

    def from_start(x: np.ndarray, floor: float) -> Fit:
        nfev = 0
        for stage in stages:  # log-magnitude, continuation in a fictitious loss factor (undamped prior)
            step = fit(stage, x, floor, lower, upper, max_nfev, max(tol, SEARCH_TOL))
            x, nfev = step.alpha, nfev + step.nfev
        out = fit(res_frf, x, floor, lower, upper, max_nfev, max(tol, SEARCH_TOL))
        out.nfev += nfev
        return out

    out = solve(res, from_start, labels, lower, upper, starting_points(x0, seed, starts, scatter, sel.size, lo, hi),
                regularisation, rank_tol, max_nfev, tol, recost=True)
    alpha, err, ev = out.final.alpha, out.err, out.ev
    p0 = affine.p0[sel]
    params, at_bound = estimates(model, sel, p0, alpha, err, lower, upper)
    if len(at_bound) == sel.size:
        refuse_on_bounds(labels, lo, hi, out.prior.r, ev.r)
    M, K = affine.matrices(alpha)
    lam, _ = affine.modes(M, K, min(affine.n, 12))
    excluded = [float(w) for w in frf.omega[~keep]]
    details = {
        "data": "frf" if modal is None else "both", "frf": {
            "source": frf.source, "lines": frf.lines, "responses": [list(d) for d in frf.dofs],
            "omega": frf.omega.tolist(), "excluded": excluded, "n_data": res_frf.n_res,
            "continuation": [] if damped else list(ETAS),
            "damping": "the prior's, not updated" if damped else "none (undamped prior)"} | frf.details,
        "sensors_dof": [list(d) for d in frf.dofs], "n_data": res.n_res, "n_effective": res.n_res - res.n_scales,
        "parameters": labels, "alpha": alpha.tolist(),
        "weights": {k: ("stated standard errors" if v else "unit (no standard errors stated)")
                    for k, v in res.stated.items()},
        "regularisation": {"rule": out.rule, "weight": out.mu, "floor": out.floor, "reason": out.why},
        "identifiability": out.report, "std_errors": err.form, "misfit": err.extra["misfit"],
        "dof": err.extra["dof"], "at_bound": at_bound,
        "starts": {"count": len(out.fits), "seed": seed, "scatter": scatter, "agreeing": out.agree,
                   "costs": [f.cost for f in out.fits]},
    }
    if measured is not None:
        details |= {"modal": measured.source, "modes": int(measured.lam.size), "left_out": left_out,
                    "natural_frequencies": np.sqrt(measured.lam).tolist(),
                    "natural_frequencies_std": (measured.lam_std / (2 * np.sqrt(measured.lam))).tolist()}
    final = out.final
    return Identification(
        method="updating", structure=model.name, repetition=repetition, tests=list(tests),
        status="converged" if final.status > 0 else "max-iterations",
        message="" if final.status > 0 else final.message, parameters=params,
        iterations=final.nfev, history=[p0.tolist(), [p.value for p in params]],
        misfit_history=[float(np.linalg.norm(np.nan_to_num(out.prior.r, posinf=1e150, neginf=-1e150))),
                        float(np.sqrt(ev.r @ ev.r))],
        omega=np.sqrt(np.clip(lam, 0.0, None)).tolist(), eigenvalues=lam.tolist(), details=details)

def _at(model: Structure, data: ModalData) -> np.ndarray:
    return dof_indices(model, data.dofs, data.source, "measured DOF")
