"""What only the model knows: the true parameters and modes of a campaign's
structure (``truth.json``, read by scoring only) and the initial state an
exact impulse produces."""
from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as la

from models import ModalModel, Model

from .campaign import Campaign, builtin_parameters
from .excitation import Impulse
from .external import BUILTIN

TRUTH_FORMAT = "structbench-truth"


def true_model(campaign: Campaign) -> Model:
    """The campaign's model with its ``[parameters]`` overrides applied."""
    model = campaign.model
    if not campaign.parameters:
        return model
    values = dict(zip(builtin_parameters(model), _values(model)))
    values.update(campaign.parameters)
    if isinstance(model, ModalModel):
        r = range(1, model.n_modes + 1)
        return ModalModel(model.name, np.array([values[f"omega_{i}"] for i in r]), model.shape_function,
                          model.points, np.array([values[f"zeta_{i}"] for i in r]))
    return model.with_values(np.array([values[n] for n in builtin_parameters(model)]))


def _values(model: Model) -> np.ndarray:
    if isinstance(model, ModalModel):
        return np.concatenate([model.omega, model.zeta])
    return model.values


def _parameter_table(model: Model) -> list[dict[str, Any]]:
    """One entry per FMU parameter: name, label, kind, unit, element or mode, value."""
    if isinstance(model, ModalModel):
        return [{"name": f"{p}_{r}", "label": f"{p}[{r}]", "kind": kind, "unit": unit, "mode": r,
                 "value": float(v)}
                for p, kind, unit, values in (("omega", "frequency", "rad/s", model.omega),
                                              ("zeta", "damping ratio", "1", model.zeta))
                for r, v in enumerate(values, start=1)]
    return [{"name": name, "label": p.label, "kind": p.kind, "unit": p.unit, "element": p.element + 1,
             "value": float(v)} for name, p, v in zip(builtin_parameters(model), model.parameters, model.values)]


def sensor_dofs(campaign: Campaign) -> list[tuple[int, str]]:
    """DOF of every motion channel of the campaign, in the model's DOF order."""
    used = {c.dof for t in campaign.tests for c in t.channels if c.quantity != "force"}
    return [d for d in campaign.model.dofs if d in used]


def truth(campaign: Campaign) -> dict[str, Any] | None:
    """The content of ``truth.json``: true parameters and modal data
    (``omega`` rad/s ascending, ``lambda`` = omega^2, mass-normalised
    ``mode_shapes`` (n_sensor_dofs, n_modes) at ``sensor_dofs``, and
    ``mode_shapes_all`` at all free ``dofs``). External FMUs: the campaign's
    ``[truth]`` table, or None."""
    head = {"format": TRUTH_FORMAT, "format_version": 1, "campaign": campaign.name,
            "structure": campaign.structure}
    if campaign.model is None:
        return None if campaign.truth is None else head | {"source": "campaign"} | dict(campaign.truth)
    model = true_model(campaign)
    modes = model.modes()
    at = [model.dof_index(*d) for d in sensor_dofs(campaign)]
    return head | {
        "source": "model",
        "model": "modal" if isinstance(model, ModalModel) else "finite-element",
        "unknown": list(getattr(model, "unknown", ("frequency", "damping ratio"))),
        "parameters": _parameter_table(model),
        "omega": modes.omega.tolist(),
        "lambda": modes.lam.tolist(),
        "dofs": [list(d) for d in model.dofs],
        "sensor_dofs": [list(model.dofs[i]) for i in at],
        "mode_shapes": modes.shapes[at].tolist(),
        "mode_shapes_all": modes.shapes.tolist(),
    }


def impulse_states(campaign: Campaign) -> dict[tuple[int, str], dict[str, float]]:
    """Initial-condition variables per N s of an exact impulse at each DOF
    where the campaign applies an ``initial-velocity`` impulse:
    ``v0 = M^-1 e`` (finite elements), ``qd0_r = phi_r(x)`` (modal)."""
    dofs = {(i.node, i.direction) for t in campaign.tests for i in t.excitation
            if isinstance(i, Impulse) and i.method == "initial-velocity"}
    if not dofs:
        return {}
    model = true_model(campaign)
    out = {}
    for dof in sorted(dofs):
        j = model.dof_index(*dof)
        if isinstance(model, ModalModel):
            out[dof] = {f"qd0_{r + 1}": float(v) for r, v in enumerate(model.shapes[j])}
        else:
            unit = np.zeros(model.n_dof)
            unit[j] = 1.0
            v0 = la.solve(model.mass().toarray(), unit, assume_a="pos")
            out[dof] = {BUILTIN.variable("initial_velocity", n, d): float(v)
                        for (n, d), v in zip(model.dofs, v0)}
    return out
