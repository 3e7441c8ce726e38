"""What goes into a structure FMU: its variables (names, units, descriptions,
start values, in value-reference order) and the model data the bundled
runtime needs. The naming convention is documented in docs/fmu-variables.md.

The spec is plain JSON data, read inside the FMU by the slave.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from structbench.models.modal import ModalModel
from structbench.models.structure import Structure

ROTATIONS = frozenset({"theta"})

# FMI unit name -> exponents of the SI base units (BaseUnit attributes)
BASE_UNITS: dict[str, dict[str, int]] = {
    "1": {},
    "m": {"m": 1}, "m/s": {"m": 1, "s": -1}, "m/s2": {"m": 1, "s": -2},
    "rad": {"rad": 1}, "rad/s": {"rad": 1, "s": -1}, "rad/s2": {"rad": 1, "s": -2},
    "N": {"kg": 1, "m": 1, "s": -2}, "N.m": {"kg": 1, "m": 2, "s": -2},
    "kg": {"kg": 1}, "kg/m": {"kg": 1, "m": -1}, "kg/m2": {"kg": 1, "m": -2},
    "kg.m2": {"kg": 1, "m": 2},
    "N/m": {"kg": 1, "s": -2}, "N.s/m": {"kg": 1, "s": -1},
    "N.m/rad": {"kg": 1, "m": 2, "s": -2, "rad": -1},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
}
# element parameter units on a rotational DOF (lumped elements given dir = theta)
ROTATIONAL_UNIT = {"kg": "kg.m2", "N/m": "N.m/rad", "N.s/m": "N.m.s/rad"}
# mass-normalised modal coordinates carry m kg^0.5 (no integer BaseUnit)
MODAL_UNITS = ("m.kg0.5", "m.kg0.5/s")


def dof_variable(prefix: str, node: int, direction: str) -> str:
    """Name of a DOF variable: ``dof_variable("F", 7, "w") == "F_7_w"``; prefixes
    ``F`` (input), ``u``/``v``/``a`` (outputs), ``u0``/``v0`` (initial conditions)."""
    return f"{prefix}_{node}_{direction}"


def parameter_name(name: str, element: int) -> str:
    """Element parameter by its name and 1-based element index, e.g. ``k_3``."""
    return f"{name}_{element}"


def fmi_unit(unit: str) -> str:
    """``"N s/m"`` -> ``"N.s/m"``, ``"kg/m^2"`` -> ``"kg/m2"``."""
    return unit.replace(" ", ".").replace("^", "")


def _var(name: str, causality: str, variability: str, unit: str, description: str,
         start: float = 0.0) -> dict[str, Any]:
    return {"name": name, "causality": causality, "variability": variability,
            "unit": unit, "description": description, "start": float(start)}


# variable prefix -> (quantity, unit) on a translation and on a rotation
PREFIXES = {
    "F": (("force", "N"), ("moment", "N.m")),
    "u": (("displacement", "m"), ("rotation", "rad")),
    "v": (("velocity", "m/s"), ("angular velocity", "rad/s")),
    "a": (("acceleration", "m/s2"), ("angular acceleration", "rad/s2")),
}


def _dof_variables(dofs: list[tuple[int, str]], where: list[str], prefix: str, causality: str,
                   variability: str, initial: bool = False) -> list[dict[str, Any]]:
    """One variable per DOF: ``{prefix}_{node}_{dir}`` (``{prefix}0_...`` for
    an initial condition), unit and description by :data:`PREFIXES`."""
    out = []
    for (node, d), w in zip(dofs, where):
        qty, unit = PREFIXES[prefix][d in ROTATIONS]
        name = dof_variable(f"{prefix}0" if initial else prefix, node, d)
        out.append(_var(name, causality, variability, unit, f"{'initial ' if initial else ''}{qty} at {w}"))
    return out


def _io_variables(dofs: list[tuple[int, str]], where: list[str]) -> list[dict[str, Any]]:
    """Inputs, then all displacements, velocities, accelerations."""
    return (_dof_variables(dofs, where, "F", "input", "continuous")
            + [v for prefix in "uva" for v in _dof_variables(dofs, where, prefix, "output", "continuous")])


def _structure_spec(model: Structure) -> tuple[list[dict[str, Any]], list[str], dict[str, Any]]:
    where = [f"node {n}, direction {d}" for n, d in model.dofs]
    variables = _io_variables(model.dofs, where)
    bounds = []
    for p, value in zip(model.parameters, model.values):
        el = model.elements[p.element]
        spec = next(s for s in el.type.parameters if s.name == p.name)
        unit = fmi_unit(p.unit)
        if el.type.directions is None and el.direction in ROTATIONS:
            unit = ROTATIONAL_UNIT.get(unit, unit)
        on = f"node {el.nodes[0]}" if len(el.nodes) == 1 else f"nodes {'-'.join(map(str, el.nodes))}"
        if el.type.directions is None:
            on += f", direction {el.direction}"
        variables.append(_var(parameter_name(p.name, p.element + 1), "parameter", "tunable", unit,
                              f"{p.kind} parameter {p.name} of element {p.element + 1} "
                              f"({el.type.name} on {on})", value))
        bounds.append("positive" if spec.positive else "nonnegative")
    for prefix in "uv":
        variables += _dof_variables(model.dofs, where, prefix, "parameter", "fixed", initial=True)
    par, rows, cols, vals = model.triplets
    data = {"type": "fe", "n": model.n_dof, "par": par.tolist(), "row": rows.tolist(),
            "col": cols.tolist(), "val": vals.tolist(), "kinds": [p.kind for p in model.parameters],
            "rayleigh": [float(a) for a in model.rayleigh]}
    return variables, bounds, data


def _modal_spec(model: ModalModel) -> tuple[list[dict[str, Any]], list[str], dict[str, Any]]:
    where = [f"node {n}, direction {d} (x = {x:.6g} m)" for (n, d), x in zip(model.dofs, model.points)]
    variables = _io_variables(model.dofs, where)
    modes = range(1, model.n_modes + 1)
    variables += [_var(f"omega_{r}", "parameter", "tunable", "rad/s", f"natural frequency of mode {r}", w)
                  for r, w in zip(modes, model.omega)]
    variables += [_var(f"zeta_{r}", "parameter", "tunable", "1", f"modal damping ratio of mode {r}", z)
                  for r, z in zip(modes, model.zeta)]
    variables += [_var(f"q0_{r}", "parameter", "fixed", MODAL_UNITS[0],
                       f"initial modal displacement of mode {r} (mass-normalised shapes)") for r in modes]
    variables += [_var(f"qd0_{r}", "parameter", "fixed", MODAL_UNITS[1],
                       f"initial modal velocity of mode {r} (mass-normalised shapes)") for r in modes]
    data = {"type": "modal", "shapes": np.asarray(model.shapes, dtype=float).tolist()}
    return variables, ["nonnegative"] * (2 * model.n_modes), data


def fmu_spec(model: Structure | ModalModel) -> dict[str, Any]:
    """The JSON-ready description of ``model``'s FMU (see the module docstring).

    ``blocks`` gives value-reference ranges ``[lo, hi)``: ``inputs`` (one per
    DOF), ``outputs`` (u, v, a blocks), ``parameters`` (the runtime's parameter
    vector, with ``bounds``), ``initial`` (the initial state ``[q0, qd0]``).
    """
    if isinstance(model, ModalModel):
        variables, bounds, data = _modal_spec(model)
        kind = f"modal model, {model.n_modes} modes at {model.n_dof} points"
    else:
        variables, bounds, data = _structure_spec(model)
        kind = f"finite-element model, {model.n_dof} free DOF"
    n = model.n_dof
    n_par = len(bounds)
    units = sorted({v["unit"] for v in variables})
    return {
        "format": 1,
        "name": model.name,
        "description": f"structbench {model.name}: {kind}; forces in, nodal responses out (SI)",
        "variables": variables,
        "blocks": {"inputs": [0, n], "outputs": [n, 4 * n], "parameters": [4 * n, 4 * n + n_par],
                   "initial": [4 * n + n_par, len(variables)]},
        "bounds": bounds,
        "units": {u: BASE_UNITS.get(u) for u in units},
        "model": data,
    }


def parameter_names(model: Structure | ModalModel) -> list[str]:
    """FMU parameter names of a model's unknowns, in the model's parameter
    order: ``{param}_{element}`` (``m_3``, ``k_3``, ``rho_5``), or ``omega_{r}``
    then ``zeta_{r}`` for a modal model."""
    if isinstance(model, ModalModel):
        return [f"{p}_{r + 1}" for p in ("omega", "zeta") for r in range(model.n_modes)]
    return [parameter_name(p.name, p.element + 1) for p in model.parameters]
