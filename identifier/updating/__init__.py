"""Sensitivity-based finite-element model updating from identified modes or FRFs.

Data (``data``, the registry's option): ``modal`` (identified modes,
below), ``frf`` (measured FRFs formed from the run's traces: residuals,
weights, Jacobian and search in :mod:`.frf_residuals`, the lines and their
standard errors in :mod:`.frf_data`; :func:`update_frf`), ``both`` (the two
residual vectors stacked, each weighted by its own stated errors), or
``auto`` (the default): modal when ``modal=`` names a file or
``DIR/results/modal.json`` exists, else frf when a trace of the run has a
force (a load cell or the commanded ``/excitation`` force) and a response,
else modal (the error says what is needed). FRFs fix what modes cannot:
the force is known, so the common scale of mass and stiffness is
determined. Where the FRFs alone leave parameters undetermined (one
response per force on an undamped structure: one real number per line),
the natural frequencies of the free vibration in harmonic records are
added as eigenvalue residuals (:func:`_natural`); they guide the FRF
search stages in any case (:mod:`.frf_residuals`). The solution, weight
choice, identifiability report and standard errors below are shared
(:func:`_solve`); what follows describes the modal residuals.

The prior model (topology and the values a user postulates, ``p0`` (P,),
SI units) is corrected by dimensionless scale factors ``alpha`` (q,) of its
chosen element parameters, ``p_j = p0_j (1 + alpha_j)``, so that its modes
match measured ones: ``k`` eigenvalues ``lambda_i = omega_i^2`` (rad^2/s^2)
and shapes at ``m`` measured DOF (any scaling and sign).

Residuals (n,) (:mod:`.residuals`), each divided by its stated standard error:

- eigenvalues: ``(lambda_model - lambda_meas) / lambda_meas``, weight
  ``lambda_meas / std(lambda_meas)`` (``std(lambda) = 2 omega std(omega)``);
- shapes: the model shape at the measured DOF scaled to the measured one
  (by weighted least squares; in the search, at the measured shape's
  largest entry), minus the measured shape, per entry divided by its
  standard error. Eigenvector differences rather than MAC values:
  ``1 - MAC`` is flat far from the answer and a poor guide.

Where no standard errors are stated (shapes of a ``modal`` results file
have none; a modal-data file may omit them) the weights are 1 and
``details.weights`` says so; ``shape_std`` (relative to each shape's largest
entry) states one for the shapes.

Pairing and the two stages. At the prior the model modes are paired with
the measured ones by an assignment on ``1 - MAC`` (a small frequency term
breaks ties): measured mode ``i`` is the model's ``n_i``-th lowest mode.
Far from the answer MAC values at a few sensors are no guide, so the
search from each start keeps these mode numbers (the ``n_i``-th lowest model
mode, whatever its shape) and uses the reference-entry shape scaling of
:mod:`.residuals`, whose misfit grows without bound where the MAC-like one
is flat; each search stops at a relative tolerance of 1e-6. From the
best start a second stage polishes (to ``tol``) with the least-squares
shape scaling and pairs by MAC at every evaluation, following modes that
switch order between iterations (``details.pairs``: the model mode of each
measured one at the answer, 1-based; ``details.mode_switches``: evaluations
whose pairing changed).

Solution: ``min |r(alpha)|^2 + mu |alpha|^2`` subject to ``lower <= alpha <= upper``
(``bounds``) by ``scipy.optimize.least_squares`` (trust-region reflective)
with the analytic Jacobian: ``dlambda/dalpha = phi^T (dK - lambda dM) phi``
(mass-normalised ``phi``) and eigenvector derivatives by Nelson's method
(:mod:`.sensitivity`; exact, needs no other mode, so no truncation and no
residual-flexibility correction). Dense LAPACK up to 400 DOF; above that
sparse matrices, shift-invert Lanczos (``eigsh``) once, then shift-invert
subspace iteration warm-started from the last evaluation's modes, and a
sparse LU per mode for Nelson's equations.

Starts: the prior, plus ``starts - 1`` draws ``alpha ~ N(0, scatter^2)``
clipped to the bounds (``numpy.random.default_rng(seed)``); the start of
least misfit wins (``details.starts``: how many agree with it). Each start is
solved with a tiny weight ``mu_floor = 1e-12 s_1^2`` (``s_1``: the largest
singular value of the weighted sensitivity ``J`` at the prior). When the
answer keeps that floor weight and ``J`` has undetermined directions there,
Gauss-Newton steps ``alpha <- alpha - J^+ r - (I - J^+ J) alpha`` take it
to the solution with no component along them (the prior's values there),
which the tiny weight alone approaches too slowly.

Regularisation weight ``mu`` (Tikhonov toward the prior, ``L = I`` on the
relative changes), chosen from the data on the linear model about a
solution, ``r(a) ~ J a - b`` (SVD ``J = U S V^T``, ``beta = U^T b``:
``a(mu) = V diag(s / (s^2 + mu)) beta``):

- every datum has a stated standard error (the noise level is known): the
  discrepancy principle in the form that holds for any rank (Mead's
  chi-squared principle): the minimum of the regularised functional,
  ``|r(mu)|^2 + mu |a(mu)|^2``, equals its expectation ``n_eff`` (the data
  less one profiled scale per shape) under the stated errors with Tikhonov
  read as the Gaussian prior ``alpha ~ N(0, I / mu)``. Morozov's
  ``|r|^2 = n_eff`` would pull a well-posed, over-determined problem toward
  the prior by far more than its noise, and ``|r|^2 = n_eff - rank`` (the
  unregularised fit's expected misfit) never regularises a problem whose
  data are fitted exactly (``n_eff <= rank``), where noise then drives
  weakly determined combinations onto the bounds; a functional already
  above ``n_eff`` keeps the floor;
- otherwise: generalised cross-validation, ``min |r(mu)|^2 / (n_eff - tr A(mu))^2``,
  ``tr A = sum s_k^2 / (s_k^2 + mu)``, which needs no noise level but
  residual degrees of freedom: with ``n_eff <= rank`` the floor only (the
  data fitted exactly, undetermined directions at the prior; state the
  data's errors to have weakly determined ones regularised).

``regularisation`` may force ``discrepancy``, ``gcv``, ``none`` or a number.
The weight is chosen at the best start's solution and applied in the
polish; chosen again at the answer, a weight over a factor 2 different
is applied in one more solve.

Identifiability (``details.identifiability``): singular values of ``J`` at
the solution (weighted, columns in ``alpha``), the numerical rank (above
``rank_tol`` times the largest) and each undetermined combination (right
singular vector below it) with its four largest components by label.
Regularisation leaves these combinations at the prior instead of driving
parameters onto the bounds; ``details.at_bound`` lists any that end there.

Standard errors (``parameters[i].std_error``, SI units of the parameter),
linearised at the answer, ``H = J^T J + mu I``, times ``p0_j`` for ``alpha_j``:

- every datum has a stated standard error: ``cov = H^-1``, the inverse of
  the Fisher information plus the regulariser's. Those errors make the
  Fisher information exact to first order, and it needs no estimate from a
  few residuals (a residual-variance or sandwich estimate with
  ``n_eff - q`` degrees of freedom is noisy where ``n_eff`` is close to
  ``q``). Adding ``mu I`` (Tikhonov read as a Gaussian prior, the posterior
  covariance) widens the intervals of the directions the regulariser pulls
  toward the prior by about the bias it causes there, which the frequentist
  ``H^-1 J^T J H^-1`` ignores (``benchmarks/updating_smu.py`` measures the
  coverage of these intervals). The misfit is tested against its chi-squared
  distribution and, above its 99 % quantile (the model cannot fit the data
  within their errors: a wrong model), the covariance is scaled by
  ``misfit / dof`` (``details.std_errors`` says so);
- otherwise the weights are arbitrary and only a residual-based estimate is
  consistent: the sandwich ``H^-1 J^T S J H^-1``,
  ``S = diag(r_i^2 / (1 - h_i))`` with the leverages ``h`` of ``J`` and of the
  profiled shape scales (HC2; too small, and its intervals too short, when
  ``n_eff - q`` is small).

Parameters loaded on an undetermined combination (over 1 % of their unit
vector in that subspace) get ``std_error`` null: the data say nothing about
them and the regularised value is the prior's.

Assumptions: real normal modes of an undamped model (damping parameters are
never updated; their kind is dropped from ``kinds``); measured modes are
simple (a repeated eigenvalue has no eigenvector derivative: Nelson's
equations are singular) and among the model's lowest ``k + max(k / 2, 4)``;
sensors measure DOF of the model (``dofs`` of the data, or the
sensors of the results file, by (node, direction)).

Fails (:class:`~structbench.identifier.IdentificationError` naming the item)
when no modal data are given, a measured DOF is not a free DOF of the model,
the model is not a finite-element :class:`~structbench.models.Structure`,
or no parameter of the chosen kinds exists. An undetermined problem does not
fail: it is reported.

Modules: :mod:`.data` (modal data in), :mod:`.sensitivity` (modes and
their derivatives), :mod:`.residuals`, :mod:`.solve` (least squares,
weight, identifiability, errors). Imports only :mod:`structbench.models`,
scipy and numpy: never the harness, and never the truth.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from structbench.models import ModelError, Structure

from ..errors import IdentificationError
from ..io.results import Identification, ParameterEstimate
from . import data as modal_data
from .data import ModalData
from .frf_data import FrfData, from_traces as frf_from_traces, has_force
from .frf_residuals import ETAS, Combined, FrfResiduals, resonant_lines
from .residuals import Residuals
from .sensitivity import AffineModel
from .localise import stepwise
from .solve import FLOOR, Fit, choose_weight, errors, fit, identifiability, min_norm

__all__ = ["FrfData", "ModalData", "identify", "update", "update_frf", "DEFAULTS", "REGULARISATION", "DATA"]

REGULARISATION = ("auto", "discrepancy", "gcv", "none")
SEARCH_TOL = 1e-6  # tolerance of the searches from the starts; the polish then uses ``tol``
DEFAULTS: dict[str, Any] = {"modal": None, "kinds": None, "bounds": [-0.9, 3.0], "starts": 1, "scatter": 0.3,
                            "seed": 0, "regularisation": "auto", "rank_tol": 1e-6, "shape_std": None,
                            "modes": None, "parameters": None, "max_nfev": 200, "tol": 1e-10,
                            "localise": False, "level": 0.001, "data": "auto"}
NEEDED = ("model updating needs identified modal data: --option modal=FILE with a modal results file "
          "(DIR/results/modal.json from `structbench identify DIR --method modal`) or a modal-data file "
          "(docs/modal-data-format.md)")


def _sensors(model: Structure, data: ModalData) -> np.ndarray:
    try:
        return np.array([model.dof_index(n, d) for n, d in data.dofs], dtype=int)
    except ModelError as err:
        raise IdentificationError(f"{data.source}: {err}; the measured DOF must be free DOF of the prior model",
                                  field="dofs") from None


def _kinds(model: Structure, kinds: str | Sequence[str] | None) -> tuple[str, ...]:
    chosen = model.unknown if kinds is None else ((kinds,) if isinstance(kinds, str) else tuple(kinds))
    chosen = tuple(k.strip() for item in chosen for k in item.split(",") if k.strip())
    bad = sorted(set(chosen) - {"mass", "stiffness", "damping"})
    if bad:
        raise IdentificationError(f"unknown parameter kind(s) {bad}; modal data update mass and stiffness",
                                  field="kinds")
    return tuple(k for k in chosen if k != "damping")


def _as_data(source: ModalData | dict | str | Path) -> ModalData:
    if isinstance(source, ModalData):
        return source
    if isinstance(source, dict):
        return modal_data.from_document(source, "modal data")
    return modal_data.load(source)


def _with_shape_std(data: ModalData, shape_std: float | None) -> ModalData:
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
    measured = _with_shape_std(_as_data(data).select(None if modes is None else list(modes)), shape_std)
    sel = np.flatnonzero(model.kind_mask(_kinds(model, kinds)))
    if parameters is not None:
        wanted = [parameters] if isinstance(parameters, str) else list(parameters)
        known = {model.parameters[j].label: j for j in sel}
        missing = [w for w in wanted if w not in known]
        if missing:
            raise IdentificationError(f"no parameter {', '.join(missing)} of the kinds {_kinds(model, kinds)} in "
                                      f"{model.name}", field="parameters")
        sel = np.array(sorted(known[w] for w in wanted), dtype=int)
    if sel.size == 0:
        raise IdentificationError(f"{model.name} has no parameter of the kinds {kinds or model.unknown} "
                                  "(damping is not updated from modes)", field="kinds")
    labels = [model.parameters[j].label for j in sel]
    affine = AffineModel(model, sel, _sensors(model, measured))
    res = Residuals(affine, measured)
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
    lower, upper = np.full(sel.size, lo), np.full(sel.size, hi)
    if localise:
        return _localised(model, sel, labels, affine, res, measured, lo, hi, float(level), tol, int(max_nfev),
                          repetition, tests)
    search = Residuals(affine, measured, "entry")
    search.fix_pairs(res(np.zeros(sel.size)).pairs)

    def from_start(x: np.ndarray, floor: float) -> Fit:
        return fit(search, x, floor, lower, upper, max_nfev, max(tol, SEARCH_TOL))

    out = _solve(res, from_start, labels, lower, upper, _starts(x0, seed, starts, scatter, sel.size, lo, hi),
                 regularisation, rank_tol, max_nfev, tol)
    prior, final, ev, report, err, mu, rule, why, fits, agree, floor = (
        out.prior, out.final, out.ev, out.report, out.err, out.mu, out.rule, out.why, out.fits, out.agree, out.floor)
    n_eff = res.n_res - res.n_scales
    alpha = final.alpha
    p0 = affine.p0[sel]
    std = np.sqrt(np.clip(np.diag(err.cov), 0.0, None)) * np.abs(p0)
    edge = np.isclose(alpha, lower, atol=1e-6) | np.isclose(alpha, upper, atol=1e-6)
    params = [ParameterEstimate(lab, model.parameters[j].kind, model.parameters[j].unit, float(v0 * (1 + a)),
                                None if void else float(s), float(v0))
              for lab, j, v0, a, s, void in zip(labels, sel, p0, alpha, std, err.void)]
    stated = res.stated
    details = {
        "data": measured.source, "modes": int(measured.lam.size), "sensors_dof": [list(d) for d in measured.dofs],
        "n_data": res.n_res, "n_effective": n_eff, "parameters": labels, "alpha": alpha.tolist(),
        "weights": {k: ("stated standard errors" if v else "unit (no standard errors stated)")
                    for k, v in stated.items()},
        "regularisation": {"rule": rule, "weight": mu, "floor": floor, "reason": why},
        "identifiability": report, "std_errors": err.form, "misfit": err.extra["misfit"],
        "dof": err.extra["dof"], "pairs": (ev.pairs + 1).tolist(), "mac": ev.mac.tolist(),
        "mode_switches": res.switches + search.switches, "at_bound": [lab for lab, e in zip(labels, edge) if e],
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


def _selection(model: Structure, kinds: str | Sequence[str] | None, parameters: Sequence[str] | None) -> np.ndarray:
    sel = np.flatnonzero(model.kind_mask(_kinds(model, kinds)))
    if parameters is not None:
        wanted = [parameters] if isinstance(parameters, str) else list(parameters)
        known = {model.parameters[j].label: j for j in sel}
        missing = [w for w in wanted if w not in known]
        if missing:
            raise IdentificationError(f"no parameter {', '.join(missing)} of the kinds {_kinds(model, kinds)} in "
                                      f"{model.name}", field="parameters")
        sel = np.array(sorted(known[w] for w in wanted), dtype=int)
    if sel.size == 0:
        raise IdentificationError(f"{model.name} has no parameter of the kinds {kinds or model.unknown} "
                                  "(damping is not updated)", field="kinds")
    return sel


def _checked(regularisation: str | float, starts: int, scatter: float, bounds: Sequence[float]) -> tuple[float, float]:
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


def _dof_indices(model: Structure, dofs: Sequence[tuple[int, str]], source: str, what: str) -> np.ndarray:
    try:
        return np.array([model.dof_index(n, d) for n, d in dofs], dtype=int)
    except ModelError as err:
        raise IdentificationError(f"{source}: {err}; the {what} must be free DOF of the prior model",
                                  field="dofs") from None


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
    gives one real number per line). Options as :func:`update`."""
    if not isinstance(model, Structure):
        raise IdentificationError(f"model updating needs a finite-element model; {model.name} is modal",
                                  field="model")
    sel = _selection(model, kinds, parameters)
    lo, hi = _checked(regularisation, starts, scatter, bounds)
    labels = [model.parameters[j].label for j in sel]
    sensors = _dof_indices(model, frf.dofs, frf.source, "measured DOF")
    forces = _dof_indices(model, frf.force, frf.source, "forced DOF")
    affine = AffineModel(model, sel, sensors)
    C = model.damping(model.values)
    damped = C.nnz > 0 and bool(np.any(C.data != 0))
    damping = (C.toarray() if affine.dense else sp.csc_matrix(C)) if damped else None
    keep = resonant_lines(affine, frf, damped)
    res_frf = FrfResiduals(affine, frf, forces, damping, 0.0, keep)
    if res_frf.n_res == 0:
        raise IdentificationError(f"{frf.source}: no FRF line left to update from", field="frf")
    measured = None
    res: Any = res_frf
    if modal is not None:
        measured = _with_shape_std(_as_data(modal).select(None if modes is None else list(modes)), shape_std)
    elif natural is True or (natural == "auto" and _underdetermined(res_frf, labels, rank_tol)):
        measured = _natural(frf)
    if measured is not None:
        res = Combined(Residuals(AffineModel(model, sel, _sensors(model, measured)), measured), res_frf)
    lower, upper = np.full(sel.size, lo), np.full(sel.size, hi)
    stages: list[Any] = [res_frf.with_eta(e, "log") for e in ([] if damped else ETAS)] + [res_frf.with_eta(0.0, "log")]
    guide = measured if measured is not None else _natural(frf)
    if guide is not None:  # the natural frequencies place the model's resonances during the search
        guided = Residuals(AffineModel(model, sel, _sensors(model, guide)), guide)
        stages = [Combined(guided, stage) for stage in stages]

    def from_start(x: np.ndarray, floor: float) -> Fit:
        nfev = 0
        for stage in stages:  # log-magnitude, continuation in a fictitious loss factor (undamped prior)
            step = fit(stage, x, floor, lower, upper, max_nfev, max(tol, SEARCH_TOL))
            x, nfev = step.alpha, nfev + step.nfev
        out = fit(res_frf, x, floor, lower, upper, max_nfev, max(tol, SEARCH_TOL))
        out.nfev += nfev
        return out

    out = _solve(res, from_start, labels, lower, upper, _starts(x0, seed, starts, scatter, sel.size, lo, hi),
                 regularisation, rank_tol, max_nfev, tol, recost=True)
    alpha, err, ev = out.final.alpha, out.err, out.ev
    p0 = affine.p0[sel]
    std = np.sqrt(np.clip(np.diag(err.cov), 0.0, None)) * np.abs(p0)
    edge = np.isclose(alpha, lower, atol=1e-6) | np.isclose(alpha, upper, atol=1e-6)
    params = [ParameterEstimate(lab, model.parameters[j].kind, model.parameters[j].unit, float(v0 * (1 + a)),
                                None if void else float(s), float(v0))
              for lab, j, v0, a, s, void in zip(labels, sel, p0, alpha, std, err.void)]
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
        "dof": err.extra["dof"], "at_bound": [lab for lab, e in zip(labels, edge) if e],
        "starts": {"count": len(out.fits), "seed": seed, "scatter": scatter, "agreeing": out.agree,
                   "costs": [f.cost for f in out.fits]},
    }
    if measured is not None:
        details |= {"modal": measured.source, "modes": int(measured.lam.size),
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


def _starts(x0: Sequence[Sequence[float]] | None, seed: int, starts: int, scatter: float, q: int, lo: float,
            hi: float) -> list[np.ndarray]:
    """The starting points in ``alpha``: ``x0``, else the prior and ``starts - 1``
    draws ``N(0, scatter^2)`` clipped to the bounds (``default_rng(seed)``)."""
    if x0 is not None:
        return [np.asarray(x, dtype=float) for x in x0]
    rng = np.random.default_rng(seed)
    return [np.zeros(q)] + [np.clip(rng.normal(0.0, scatter, q), lo, hi) for _ in range(max(int(starts), 1) - 1)]


@dataclass
class Solved:
    """What :func:`_solve` found (see there)."""

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


def _solve(res: Any, from_start: Any, labels: list[str], lower: np.ndarray, upper: np.ndarray,
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


def _modal_path(traces: Sequence[Any], given: str | None) -> Path:
    folder = traces[0].path.parent if traces else Path.cwd()
    folder = folder.parent if folder.name == "traces" else folder
    if given is None:
        default = folder / "results" / "modal.json"
        if default.is_file():
            return default
        raise IdentificationError(NEEDED + f"; found no {default}", field="modal")
    for candidate in (Path(given), folder / given, folder / "results" / given):
        if candidate.is_file():
            return candidate
    raise IdentificationError(f"no modal data file {given!r} (looked in the working folder and in {folder})",
                              field="modal")


DATA = ("auto", "modal", "frf", "both")
FRF_ONLY = ("modes", "shape_std", "localise", "level")  # options of the modal data only


def _default_modal(traces: Sequence[Any]) -> bool:
    folder = traces[0].path.parent if traces else Path.cwd()
    folder = folder.parent if folder.name == "traces" else folder
    return (folder / "results" / "modal.json").is_file()


def identify(traces: Sequence[Any], model: Structure, modal: str | None = None, data: str = "auto",
             **options: Any) -> Identification:
    """The registry's call: update ``model`` (the prior) to the run of ``traces``.

    ``data``: ``modal`` (the modes of the run in ``modal``, a results or
    modal-data file; default ``DIR/results/modal.json`` of the campaign
    folder), ``frf`` (FRFs formed from the run's traces, :mod:`.frf_data`),
    ``both``, or ``auto``: modal when ``modal`` is given or
    ``DIR/results/modal.json`` exists, else frf when a trace of the run has a
    force and a response, else modal (an error saying what is needed).
    Options as :func:`update` (``update_frf`` for frf)."""
    if data not in DATA:
        raise IdentificationError(f"data must be one of {', '.join(DATA)}, got {data!r}", field="data")
    tests = [t.test for t in traces]
    repetition = traces[0].repetition if traces else 0
    if data == "auto":
        data = "modal" if (modal is not None or _default_modal(traces) or not has_force(traces)) else "frf"
    if data == "modal":
        found = modal_data.load(_modal_path(traces, modal), tests, repetition)
        return update(model, found, repetition=repetition, tests=tests, **options)
    if options.get("localise"):
        raise IdentificationError("localise works on modal data only (data=modal)", field="localise")
    if not has_force(traces):
        raise IdentificationError("FRF residuals need a force: no trace of the run has a force channel or a "
                                  "commanded /excitation force (use data=modal with identified modes)", field="data")
    measured = None
    if data == "both":
        measured = modal_data.load(_modal_path(traces, modal), tests, repetition)
    frf = frf_from_traces(traces, model)
    extra = {k: options.pop(k) for k in FRF_ONLY if k in options}
    return update_frf(model, frf, modal=measured, shape_std=extra.get("shape_std"), modes=extra.get("modes"),
                      repetition=repetition, tests=tests, **options)
