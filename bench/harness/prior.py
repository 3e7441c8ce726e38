"""A campaign's ``[prior]`` and ``[damage]`` tables (docs/campaign-format.md).

``[prior]``: what an identifier that needs starting values (updating,
perturbation) is given instead of the truth. Either a model file, ``model =
"prior.toml"`` (its parameter values by label), or a rule: every unknown
parameter ``p_j`` of the true model scaled by ``f_j = exp(u_j)``, ``u_j``
uniform on ``[ln lo, ln hi]`` (``scale = [lo, hi]``, log-uniform factors),
drawn by ``numpy.random.default_rng(seed)`` in the model's parameter order.
``run`` writes the result as ``DIR/prior.json`` (format ``structbench-prior``:
``structure``, ``source``, ``parameters`` = ``[{label, value}]``, SI units),
which ``identify`` reads; the truth stays in ``truth.json``.

``[damage]``: ``elements`` (1-based) whose stiffness parameters are
multiplied by ``stiffness_factor`` (0 < f <= 10) in the true model: the FMU
parameters (``k_12``, ``EI_12``, ...) and ``truth.json`` follow. Only for
built-in and TOML finite-element structures.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from structbench.fmus.spec import parameter_names
from structbench.models import Model, ModelError, Structure, load_model

from .toml_table import Table

PRIOR_FORMAT = "structbench-prior"
PRIOR_FILE = "prior.json"


@dataclass(frozen=True)
class PriorSpec:
    """``[prior]``: a model file, or a log-uniform scale rule ``(lo, hi)`` with its seed."""

    model: Path | None = None
    scale: tuple[float, float] | None = None
    seed: int = 0
    text: str = ""  # how the campaign declared it, for prior.json's ``source``


def read_prior(table: Table, campaign_path: Path) -> PriorSpec | None:
    """The ``[prior]`` table (None when absent); errors name the key and line."""
    if not table.data:
        return None
    table.allow(("model", "scale", "seed"), "[prior]")
    if ("model" in table.data) == ("scale" in table.data):
        raise table.error("model" if "model" in table.data else "scale",
                          "give either model = \"FILE.toml\" or scale = [low, high] (with seed)")
    if "model" in table.data:
        if "seed" in table.data:
            raise table.error("seed", "a seed goes with scale = [low, high], not with a model file")
        ref = table.string("model")
        file = (campaign_path.parent / ref).resolve()
        try:
            load_model(file)
        except (ModelError, OSError) as err:
            raise table.error("model", f"{ref}: {err}") from None
        return PriorSpec(model=file, text=f"[prior] model = {ref!r}")
    scale = table.get("scale")
    if (not isinstance(scale, list) or len(scale) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in scale)
            or not 0 < scale[0] <= scale[1] < np.inf):
        raise table.error("scale", f"expected [low, high] with 0 < low <= high, got {scale!r}")
    seed = table.integer("seed", 0, low=0)
    return PriorSpec(scale=(float(scale[0]), float(scale[1])), seed=seed,
                     text=f"[prior] scale = [{scale[0]}, {scale[1]}], seed = {seed}")


def damage_parameters(table: Table, model: Model | None, parameters: dict[str, float]) -> dict[str, float]:
    """FMU parameter overrides of a ``[damage]`` table: each stiffness
    parameter of the listed elements times ``stiffness_factor``, applied to
    the value ``parameters`` (the campaign's ``[parameters]``) or the model gives."""
    if not table.data:
        return {}
    table.allow(("elements", "stiffness_factor"), "[damage]")
    if not isinstance(model, Structure):
        raise table.error("elements", "damage needs a built-in or TOML finite-element structure")
    factor = table.number("stiffness_factor", positive=True)
    if factor > 10:
        raise table.error("stiffness_factor", f"must be at most 10, got {factor}")
    elements = table.get("elements")
    n = len(model.elements)
    if (not isinstance(elements, list) or not elements
            or not all(isinstance(e, int) and not isinstance(e, bool) and 1 <= e <= n for e in elements)
            or len(set(elements)) != len(elements)):
        raise table.error("elements", f"expected distinct element numbers 1..{n}, got {elements!r}")
    names = parameter_names(model)
    out = {}
    for name, par, value in zip(names, model.parameters, model.values):
        if par.kind == "stiffness" and par.element + 1 in elements:
            out[name] = factor * parameters.get(name, float(value))
    if not out:
        raise table.error("elements", f"elements {elements} have no stiffness parameter")
    return out


def prior_model(spec: PriorSpec, true_model: Structure) -> Structure:
    """The prior: the model file's values, or the true model's unknown
    parameters times log-uniform factors (see the module docstring)."""
    if spec.model is not None:
        given = load_model(spec.model)
        if not isinstance(given, Structure):
            raise ModelError(f"{spec.model}: a prior must be a finite-element model", field="prior.model")
        return given
    lo, hi = spec.scale
    mask = true_model.kind_mask()
    rng = np.random.default_rng(spec.seed)
    factors = np.exp(rng.uniform(np.log(lo), np.log(hi), int(mask.sum())))
    p = true_model.values.copy()
    p[mask] *= factors
    return true_model.with_values(p)


def prior_document(spec: PriorSpec, true_model: Model) -> dict[str, Any]:
    """The content of ``prior.json``: the prior's unknown parameters by label."""
    if not isinstance(true_model, Structure):
        raise ModelError("a [prior] needs a finite-element structure", field="prior")
    model = prior_model(spec, true_model)
    mask = model.kind_mask()
    return {"format": PRIOR_FORMAT, "format_version": 1, "structure": true_model.name, "source": spec.text,
            "parameters": [{"label": p.label, "kind": p.kind, "unit": p.unit, "value": float(v)}
                           for p, v, m in zip(model.parameters, model.values, mask) if m]}


def write_prior(root: Path, spec: PriorSpec | None, true_model: Model | None) -> None:
    """Write ``root/prior.json`` when the campaign has a ``[prior]`` table."""
    if spec is None or true_model is None:
        return
    (root / PRIOR_FILE).write_text(json.dumps(prior_document(spec, true_model), indent=1) + "\n")
