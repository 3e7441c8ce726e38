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
added as eigenvalue residuals (:mod:`.frf_update`); they guide the FRF
search stages in any case (:mod:`.frf_residuals`). The solution, weight
choice, identifiability report and standard errors below are shared
(:mod:`.flow`); what follows describes the modal residuals.

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

The shapes' errors are those the modal method states per entry
(``mode_shapes_std`` of a ``modal`` results file: its shape normalisation,
the scale held, so that the least-squares scaling below profiles the scale
out) or a modal-data file's ``shape_std``. Where none is stated (a
``rayleigh`` or imported file, a close-pair fit's shape, a modal-data file
that omits them) the weights are 1 and ``details.weights`` says so;
``shape_std`` (relative to each shape's largest entry) states one for the
entries without.

Pairing and the two stages. At the prior the model modes are paired with
the measured ones by an assignment on ``1 - MAC`` (a small frequency term
breaks ties): measured mode ``i`` is the model's ``n_i``-th lowest mode.
Before that, measured modes with a shape that pair best with the same
model mode and whose shapes agree (MAC >= 0.9) are one mode reported twice:
the closest is kept, the others are left out and named
(``details.left_out``; :mod:`.pairing`), since one-to-one pairing would give
a copy another model mode, with few sensors one of many times its frequency.
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
or no parameter of the chosen kinds exists, and when every parameter ends
on a bound (no answer: the error names the misfits and the measured modes
of the largest eigenvalue residuals at the prior with their pairs). An
undetermined problem does not fail: it is reported.

Modules: :mod:`.data` (modal data in), :mod:`.sensitivity` (modes and
their derivatives), :mod:`.residuals`, :mod:`.modal_update` (updating from
modes, the stepwise change search of :mod:`.localise`),
:mod:`.pairing` (modes reported twice), :mod:`.frf_data`,
:mod:`.frf_residuals` and :mod:`.frf_update` (from FRFs),
:mod:`.flow` (the shared flow) and :mod:`.solve` (least squares, weight,
identifiability, errors). Imports only :mod:`structbench.models`,
scipy and numpy: never the harness, and never the truth.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from structbench.models import Structure

from ..errors import IdentificationError
from ..io.results import Identification
from . import data as modal_data
from .data import ModalData
from .flow import REGULARISATION
from .frf_data import FrfData, from_traces as frf_from_traces, has_force
from .frf_update import update_frf
from .modal_update import NEEDED, update

__all__ = ["FrfData", "ModalData", "identify", "update", "update_frf", "DEFAULTS", "REGULARISATION", "DATA"]

DEFAULTS: dict[str, Any] = {"modal": None, "kinds": None, "bounds": [-0.9, 3.0], "starts": 1, "scatter": 0.3,
                            "seed": 0, "regularisation": "auto", "rank_tol": 1e-6, "shape_std": None,
                            "modes": None, "parameters": None, "max_nfev": 200, "tol": 1e-10,
                            "localise": False, "level": 0.001, "data": "auto"}


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
