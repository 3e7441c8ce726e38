"""The truth of a campaign (``truth.json``, read by scoring only): the true
parameters and modes of its structure, or the ``[truth]`` table of an
external FMU's campaign."""
from __future__ import annotations

from typing import Any

import numpy as np

from structbench.fmus.spec import parameter_names
from structbench.models import ModalModel, Model
from structbench.models.analysis import Modes, damping_ratios

from .campaign import Campaign
from .disturbance import truth_table

TRUTH_FORMAT = "structbench-truth"


def _parameter_table(model: Model) -> list[dict[str, Any]]:
    """One entry per FMU parameter: name, label, kind, unit, element or mode, value."""
    if isinstance(model, ModalModel):
        return [{"name": f"{p}_{r}", "label": f"{p}[{r}]", "kind": kind, "unit": unit, "mode": r,
                 "value": float(v)}
                for p, kind, unit, values in (("omega", "frequency", "rad/s", model.omega),
                                              ("zeta", "damping ratio", "1", model.zeta))
                for r, v in enumerate(values, start=1)]
    return [{"name": name, "label": p.label, "kind": p.kind, "unit": p.unit, "element": p.element + 1,
             "value": float(v)} for name, p, v in zip(parameter_names(model), model.parameters, model.values)]


def true_damping_ratios(model: Model, modes: Modes) -> np.ndarray:
    """Damping ratio (r,) of each mode: a modal model's ``zeta``; an undamped
    finite-element model 0; a damped one from each mode's own pole pair of
    ``M u'' + C u' + K u = 0`` (:func:`models.analysis.damping_ratios`, NaN
    for rigid-body and overdamped modes, zeta > 1)."""
    if isinstance(model, ModalModel):
        return np.asarray(model.zeta, dtype=float)[:modes.omega.size]
    c = model.damping()
    return damping_ratios(c, modes) if c.count_nonzero() else np.zeros(modes.omega.size)


def sensor_dofs(campaign: Campaign) -> list[tuple[int, str]]:
    """DOF of every motion channel of the campaign, in the model's DOF order."""
    used = {c.dof for t in campaign.tests for c in t.channels if c.quantity != "force"}
    return [d for d in campaign.model.dofs if d in used]


def truth(campaign: Campaign) -> dict[str, Any] | None:
    """The content of ``truth.json``: true parameters and modal data
    (``omega`` rad/s ascending, ``zeta`` damping ratios (NaN for rigid-body or
    overdamped modes), ``lambda`` = omega^2, mass-normalised
    ``mode_shapes`` (n_sensor_dofs, n_modes) at ``sensor_dofs``, and
    ``mode_shapes_all`` at all free ``dofs``). External FMUs: the campaign's
    ``[truth]`` table, or None."""
    head = {"format": TRUTH_FORMAT, "format_version": 1, "campaign": campaign.name,
            "structure": campaign.structure}
    if harmonics := truth_table(campaign.tests):  # per test, its disturbance sinusoids (disturbance.py)
        head["harmonics"] = harmonics
    if campaign.model is None:
        return None if campaign.truth is None else head | {"source": "campaign"} | dict(campaign.truth)
    model = campaign.true_model
    modes = model.modes()
    at = [model.dof_index(*d) for d in sensor_dofs(campaign)]
    return head | {
        "source": "model",
        "model": "modal" if isinstance(model, ModalModel) else "finite-element",
        "unknown": list(getattr(model, "unknown", ("frequency", "damping ratio"))),
        "parameters": _parameter_table(model),
        "omega": modes.omega.tolist(),
        "zeta": true_damping_ratios(model, modes).tolist(),
        "lambda": modes.lam.tolist(),
        "dofs": [list(d) for d in model.dofs],
        "sensor_dofs": [list(model.dofs[i]) for i in at],
        "mode_shapes": modes.shapes[at].tolist(),
        "mode_shapes_all": modes.shapes.tolist(),
    }
