"""Test planning: predicted standard errors (Cramer-Rao bounds) of what a
method will identify from a campaign's test, sensor layouts, and their
Monte Carlo check (docs/plan.md).

One module per job: :mod:`.response` (noise-free responses from the
planning model), :mod:`.fisher` (least squares), :mod:`.free_decay` (modal
frequencies and damping), :mod:`.updating` (element parameters from a free
decay's modes), :mod:`.layouts` (effective independence, D-optimal and,
:mod:`.targeted`, frequency-targeted sensor layouts), :mod:`.drives`
(excitation points of a free decay's impulse), :mod:`.joint` (the point and
the layout chosen together), :mod:`.campaign_files`
(the campaign files a plan writes), :mod:`.verify` (``--verify``); the command line prints the
table (``structbench.cli.plan``).

May import: models, the harness (campaigns, excitation; the planning model's
responses), the least-squares regression of the identifier, and the API
(``--verify`` runs the campaign and identifies through it).
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from structbench.models import Model, load_model
from structbench.models.errors import UserError

METHODS = ("least-squares", "modal", "updating")
FORMAT = "structbench-plan"
BOUNDS = {"least-squares": "Cramer-Rao of the regression (noise-free responses, the campaign's noise) plus the "
                           "second-order errors-in-variables term: the spread of the bias-compensated estimator",
          "modal": "Cramer-Rao of damped sinusoids in white noise: the spread of an efficient (maximum-likelihood) "
                   "estimator; the modal method's free-decay refinement reaches it, SSI-cov alone (refine=off) lands "
                   "1-5x above it (benchmarks/plan_accuracy.py)",
          "updating": "Cramer-Rao of the element parameters from the free decay's frequencies and mode shapes in "
                      "unknown scale (damping and initial conditions nuisance): the spread of an efficient "
                      "estimator that uses the record's modes as updating does"}
__all__ = ["METHODS", "plan"]


def _chosen_tests(campaign, test: str | None):
    groups = list(dict.fromkeys(t.group for t in campaign.tests))
    name = test if test is not None else groups[0]
    specs = [t for t in campaign.tests if t.group == name]
    if not specs:
        raise UserError(f"no test {name!r} in the campaign; tests: {', '.join(groups)}", field="--test")
    return name, specs


def _least_squares(model: Model, specs) -> dict[str, Any]:
    from structbench.models import Structure
    from .fisher import least_squares_covariance, motion
    from .response import simulate_test
    if not isinstance(model, Structure):
        raise UserError(f"least squares needs a finite-element model; {model.name} is modal", field="--model")
    labels, cov = least_squares_covariance(model, [motion(model, simulate_test(model, t)) for t in specs])
    params = [p for p, keep in zip(model.parameters, model.kind_mask()) if keep]
    std = np.sqrt(np.diag(cov))
    return {"parameters": [{"label": lab, "unit": p.unit, "value": float(v), "predicted_std": float(s)}
                           for lab, p, v, s in zip(labels, params, model.values[model.kind_mask()], std)]}


def _modal(model: Model, specs) -> dict[str, Any]:
    from .free_decay import free_decay_bounds
    if len(specs) != 1:
        raise UserError("modal planning takes one free-decay test (a group of one)", field="--test")
    return free_decay_bounds(model, specs[0])


def _updating(model: Model, specs) -> dict[str, Any]:
    from .updating import updating_bounds
    if len(specs) != 1:
        raise UserError("updating planning takes one free-decay test (a group of one)", field="--test")
    return updating_bounds(model, specs[0])


def _drives(model: Model, specs, method: str, drives: str | Path, layout: dict[str, Any] | None, path: Path,
            test: str, out: str | Path | None, target_modes: int | None, document: dict[str, Any],
            candidates: str | Path | None = None) -> Path:
    """Rank the excitation points (``document["drives"]``) on the test's
    sensors, or with a layout of the ``frequencies`` criterion choose the
    point and the layout together (:mod:`.joint`; other criteria: on the
    chosen layout's sensors), and write the campaign with the best pair; its path."""
    from .campaign_files import test_campaign
    from .drives import rank_drives, read_drives
    from .free_decay import modal_channels
    if method != "modal":
        raise UserError(f"excitation points are planned for the modal method, not {method}", field="--drives")
    if len(specs) != 1:
        raise UserError("excitation points are planned for one test", field="--test")
    sensors = ([tuple(s) for s in layout["sensors"]] if layout else
               [(c.dof[0], c.dof[1], c.quantity) for c in modal_channels(specs[0])])
    if not sensors:
        raise UserError(f"test {test!r} has no motion sensor", field="sensors")
    points = read_drives(drives, model)
    if layout and layout["criterion"] == "frequencies":
        from .joint import joint_section
        section = joint_section(model, specs[0], str(candidates), int(layout["budget"]), points, sensors,
                                target_modes)
        sensors = [tuple(s) for s in section["sensors"]]
    else:
        section = rank_drives(model, specs[0], sensors, points, target_modes,
                              targets=layout["target_modes"] if layout else None)
    target = Path(out) if out is not None else Path.cwd() / f"{path.stem}-plan-{test}.toml"
    target.write_text(test_campaign(path, test, sensors=sensors if layout else None, only=False,
                                    drive=tuple(section["chosen"])), encoding="utf-8")
    document["drives"] = section | {"campaign": str(target)}
    return target


def plan(campaign: str | Path, method: str, *, model: str | Path | None = None, test: str | None = None,
         candidates: str | Path | None = None, sensors: int | None = None, layout_out: str | Path | None = None,
         criterion: str = "frequencies", target_modes: int | None = None, drives: str | Path | None = None,
         verify: int = 0, seed: int = 0,
         verify_out: str | Path | None = None, jobs: int | None = None,
         progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """The plan document (docs/plan.md) of ``method`` on ``test`` (default: the
    campaign's first test group) of ``campaign``: predicted standard errors
    (``parameters``: ``{label, unit, value, predicted_std}``; ``modes``:
    ``{omega, predicted_omega_std, zeta, predicted_zeta_std}``, SI). The planning
    model is ``model`` or the campaign's structure with its ``[parameters]``.
    With ``candidates`` and ``sensors`` (a budget K) also ``layout``: layouts by
    effective independence, D-optimal design and targeted on the frequencies
    (the lowest ``target_modes`` planned modes, default all), the one the
    ``criterion`` (``frequencies``: least predicted RMS relative frequency
    error; ``d-optimal``: largest ``log det``; ``effective-independence``)
    chooses written as a campaign file ``layout_out`` (default
    ``<campaign>-plan-<test>.toml`` in the working folder) and planned on. With
    ``drives`` (candidate excitation points, modal, a test of one impulse) also
    ``drives``: the points ranked by the predicted frequency errors on the
    plan's sensors (the test's; with a layout of criterion ``frequencies``
    each point with its own layout, the point and the layout chosen together,
    :mod:`.joint`; other criteria: the chosen layout's), the best written
    into that campaign file as the impulse's node and direction (and its
    layout) and planned on. ``verify`` > 0: that many Monte
    Carlo repetitions (seed ``seed``) through the FMU and the method, ``verify``
    holding predicted against achieved standard deviations."""
    from structbench.harness.campaign import load_campaign
    if method not in METHODS:
        raise UserError(f"no planning for method {method!r}; methods: {', '.join(METHODS)}", field="--method")
    if (candidates is None) != (sensors is None):
        raise UserError("--candidates and --sensors go together", field="--sensors")
    if verify < 0:
        raise UserError("must be >= 0", field="--verify")
    say = progress or (lambda line: None)
    path = Path(campaign)
    loaded = load_campaign(path)
    planning = load_model(model) if model is not None else (loaded.true_model or loaded.model)
    if planning is None:
        raise UserError("an external FMU has no model to plan with: give --model", field="--model")
    name, specs = _chosen_tests(loaded, test)
    document: dict[str, Any] = {"format": FORMAT, "version": 1, "campaign": loaded.name, "method": method,
                                "test": name, "model": planning.name, "parameters": [], "modes": []}
    run_file = path
    if candidates is not None:
        from .layouts import plan_layout
        document["layout"] = plan_layout(planning, specs, method, candidates, int(sensors), path, name,
                                         layout_out, criterion=criterion, target_modes=target_modes)
        run_file = Path(document["layout"]["campaign"])
        loaded = load_campaign(run_file)
        name, specs = _chosen_tests(loaded, name)
        say(f"layout: {document['layout']['chosen']} layout written to {run_file}")
    if drives is not None:
        run_file = _drives(planning, specs, method, drives, document.get("layout"), path, name, layout_out,
                           target_modes, document, candidates)
        loaded = load_campaign(run_file)
        name, specs = _chosen_tests(loaded, name)
        say(f"excitation point: node {document['drives']['chosen'][0]} {document['drives']['chosen'][1]}, "
            f"written to {run_file}")
    document |= {"least-squares": _least_squares, "modal": _modal, "updating": _updating}[method](planning, specs)
    document["bound"] = BOUNDS[method]
    if verify:
        from .verify import verify as run_verify
        document["verify"] = run_verify(run_file, name, method, verify, document,
                                        model=model, seed=seed, out=verify_out, jobs=jobs, progress=say)
    return document
