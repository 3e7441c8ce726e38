"""Campaign files (TOML): the structure under test and its tests.

The format is described in ``docs/campaign-format.md``. :func:`load_campaign`
checks everything that can be checked without simulating (structure, nodes,
directions, times, noise, the FMU variable mapping of an external FMU); every
error names the key and its line, e.g. ``ch3.toml:14: tests[1].duration: ...``.
The ``[[tests]]`` entries are read by :mod:`.test_entries`.
"""
from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from structbench.fmus.spec import parameter_names
from structbench.models import STRUCTURES, ModalModel, Model, load_model
from structbench.models.errors import UserError
from structbench.models.input_text import read_input_text

from .campaign_size import Budget, CampaignSize
from .prior import PriorSpec, damage_parameters, read_prior
from .fmu_options import FmuOptions, read_fmu_options
from .external import BUILTIN, PLACEHOLDERS, QUANTITY_KEYS, VariableMap, closest, fmu_variables, pattern_fields
from .test_entries import TEST_KEYS, TestReader, TestSpec
from .toml_lines import Path as KeyPath
from .toml_lines import key_lines
from .toml_table import CampaignError, Table, key_error

__all__ = ["Campaign", "CampaignError", "TestSpec", "load_campaign"]

TOP_KEYS = ("name", "description", "structure", "seed", "parameters", "mapping", "locations",
            "truth", "check", "limits", "defaults", "tests", "prior", "damage",
            "interface", "substeps", "solver")


@dataclass(frozen=True)
class Campaign:
    """A validated campaign. ``model`` is None for an external FMU (``fmu``);
    ``true_model`` is ``model`` with the ``[parameters]`` overrides applied."""

    name: str
    path: Path
    text: str
    structure: str
    model: Model | None
    fmu: Path | None
    tests: tuple[TestSpec, ...]
    parameters: Mapping[str, float]
    mapping: VariableMap
    locations: Mapping[int, tuple[float, float, float]]
    truth: Mapping[str, Any] | None
    check: Mapping[str, Any]
    seed: int
    variables: tuple[tuple[KeyPath, str, str], ...] = field(repr=False)  # (key, role, FMU variable)
    lines: Mapping[KeyPath, int] = field(repr=False, compare=False)
    true_model: Model | None = field(default=None, repr=False, compare=False)
    size: CampaignSize = field(default_factory=CampaignSize, compare=False)  # what a run writes and simulates
    prior: PriorSpec | None = field(default=None, compare=False)  # [prior] (prior.py)
    fmu_options: FmuOptions = field(default_factory=FmuOptions, compare=False)  # interface, substeps, [solver]

    def location(self, node: int) -> tuple[float, float, float]:
        """Node coordinates (m), padded to 3; NaN when unknown."""
        if self.model is not None:
            xyz = np.zeros(3)
            coords = np.asarray(self.model.nodes[node], dtype=float)
            xyz[:coords.size] = coords
            return tuple(float(v) for v in xyz)
        return self.locations.get(node, (math.nan,) * 3)

    def error(self, key: KeyPath, message: str) -> CampaignError:
        return key_error(self.path, self.lines, key, message)

    def check_variables(self, variables: Mapping[str, str], fmu_name: str) -> None:
        """Every mapped variable must exist in the FMU (``variables``: name ->
        causality); otherwise fail naming the key and the closest names."""
        claimed: dict[str, str] = {}  # variable -> the role that first mapped it
        for key, role, name in self.variables:
            if name not in variables:
                near = closest(name, variables)
                hint = f"; closest: {', '.join(near)}" if near else ""
                raise self.error(key, f"{role}: no variable {name!r} in {fmu_name}{hint}")
            if role.startswith("force") != (variables[name] == "input"):
                expected = "an input" if role.startswith("force") else "not an input"
                raise self.error(key, f"{role}: {name!r} in {fmu_name} has causality {variables[name]}, "
                                      f"expected {expected}")
            if claimed.setdefault(name, role) != role:
                raise self.error(key, f"{role}: {name!r} is also mapped to {claimed[name]}")



class CampaignReader:
    """Parses and validates one campaign text."""

    def __init__(self, path: Path, text: str):
        self.path = path
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as err:
            raise CampaignError(str(err), field=path.name) from None
        self.lines = key_lines(text)
        self.top = Table(self, data, {}, ())
        self.variables: list[tuple[KeyPath, str, str]] = []

    def error(self, key: KeyPath, message: str) -> CampaignError:
        return key_error(self.path, self.lines, key, message)

    # ---- structure ---------------------------------------------------
    def structure(self) -> tuple[str, Model | None, Path | None]:
        ref = self.top.string("structure")
        if ref in STRUCTURES:
            return ref, load_model(ref), None
        file = (self.path.parent / ref).resolve()
        if not file.exists():
            raise self.top.error("structure", f"unknown structure {ref!r}: not a built-in name "
                                              f"({', '.join(STRUCTURES)}) and no file {file}")
        if file.suffix == ".fmu":
            return file.stem, None, file
        try:
            model = load_model(file)
        except UserError as err:
            raise self.top.error("structure", f"{ref}: {err}") from None
        return model.name, model, None

    def mapping(self, external: bool) -> VariableMap:
        table = self.top.table("mapping")
        if not table.data:
            return BUILTIN
        if not external:
            raise self.top.error("mapping", "a mapping is only for external FMUs; built-in structures "
                                            "use structbench's own variable names")
        table.allow(QUANTITY_KEYS + ("table",), "mapping")
        patterns = {}
        for key in QUANTITY_KEYS:
            if key in table.data:
                pattern = table.string(key)
                try:
                    bad = pattern_fields(pattern) - PLACEHOLDERS
                    if not bad:
                        pattern.format(node=1, dir="z")  # format specs such as {node:q}
                except (ValueError, TypeError) as err:
                    raise table.error(key, f"bad pattern {pattern!r}: {err}") from None
                if bad:
                    raise table.error(key, f"unknown placeholder(s) {sorted(bad)}; use {{node}} and {{dir}}")
                patterns[key] = pattern
        explicit = table.table("table")
        return VariableMap(patterns, {k: explicit.string(k) for k in explicit.data})

    def locations(self) -> dict[int, tuple[float, float, float]]:
        table = self.top.table("locations")
        out = {}
        for key, value in table.data.items():
            if not key.isdigit():
                raise table.error(key, "node ids (integers) are the keys of [locations]")
            if not isinstance(value, list) or not 1 <= len(value) <= 3 or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                raise table.error(key, f"expected 1 to 3 coordinates (m), got {value!r}")
            out[int(key)] = tuple(float(v) for v in value) + (0.0,) * (3 - len(value))
        return out

    def parameters(self, model: Model | None, fmu: Path | None) -> dict[str, float]:
        table = self.top.table("parameters")
        values = {key: table.number(key) for key in table.data}
        known = ([n for n, c in fmu_variables(fmu).items() if c == "parameter"] if fmu is not None
                 else parameter_names(model))
        for key in values:
            if key not in known:
                near = closest(key, known)
                raise table.error(key, f"no parameter {key!r}" + (f"; closest: {', '.join(near)}" if near else ""))
        return values

    # ---- tests -------------------------------------------------------
    def tests(self, model: Model | None, locations: Mapping[int, Any], mapping: VariableMap,
              seed: int, budget: Budget) -> tuple[TestSpec, ...]:
        """The tests, counted in ``budget`` one by one (an over-limit campaign
        stops being read at the test that crosses the limit)."""
        defaults = self.top.table("defaults")
        defaults.allow(tuple(k for k in TEST_KEYS if k != "name"), "defaults")
        raw = self.top.tables("tests")
        if not raw:
            raise self.error(("tests",), "a campaign needs at least one [[tests]] entry")
        specs: dict[str, TestSpec] = {}
        for test in raw:
            merged = {**defaults.data, **test.data}
            origin = {**{k: ("defaults", k) for k in defaults.data}, **{k: test.where + (k,) for k in test.data}}
            parsed = TestReader(Table(self, merged, origin, test.where), model, locations, mapping, seed, self)
            for spec in parsed.specs():
                if spec.name in specs:
                    raise test.error("name", f"duplicate test name {spec.name!r}")
                specs[spec.name] = spec
                budget.add(spec, test.where, self.error)
        return tuple(specs.values())

    def want(self, key: KeyPath, mapping: VariableMap, quantity: str, node: int, direction: str) -> None:
        """Record the FMU variable a (quantity, DOF) needs; fail if unmapped."""
        name = mapping.variable(quantity, node, direction)
        role = f"{quantity} at ({node}, {direction!r})"
        if name is None:
            raise self.error(key, f"{role}: no mapping for {quantity!r} (add mapping.{quantity} or a mapping.table entry)")
        self.variables.append((key, role, name))


def with_parameters(model: Model, parameters: Mapping[str, float]) -> Model:
    """``model`` with some FMU parameters (``m_3``, ``omega_2``, ...) set."""
    if not parameters:
        return model
    names = parameter_names(model)
    current = np.concatenate([model.omega, model.zeta]) if isinstance(model, ModalModel) else model.values
    values = dict(zip(names, current)) | dict(parameters)
    if isinstance(model, ModalModel):
        r = range(1, model.n_modes + 1)
        return ModalModel(model.name, np.array([values[f"omega_{i}"] for i in r]), model.shape_function,
                          model.points, np.array([values[f"zeta_{i}"] for i in r]))
    return model.with_values(np.array([values[n] for n in names]))


def load_campaign(path: str | Path) -> Campaign:
    """Read and validate a campaign file; raises :class:`CampaignError`."""
    path = Path(path)
    text = read_input_text(path, "campaign file")
    reader = CampaignReader(path, text)
    top = reader.top
    top.allow(TOP_KEYS, "a campaign")
    name = top.string("name", path.stem)
    seed = top.integer("seed", 0, low=0)
    structure, model, fmu = reader.structure()
    mapping = reader.mapping(external=fmu is not None)
    locations = reader.locations()
    parameters = reader.parameters(model, fmu)
    parameters |= damage_parameters(top.table("damage"), model, parameters)  # [damage] (prior.py)
    prior = read_prior(top.table("prior"), path)
    if prior is not None and model is None:
        raise top.error("prior", "a [prior] needs a built-in or TOML structure")
    truth = top.table("truth").data or None
    if truth is not None and model is not None:
        raise top.error("truth", "the truth of a built-in or TOML structure comes from its model")
    check = top.table("check").data
    budget = Budget(top.table("limits"))
    if model is not None:
        budget.check_model(model, lambda message: top.error("structure", message))
    tests = reader.tests(model, locations, mapping, seed, budget)
    campaign = Campaign(name, path, text, structure, model, fmu, tests, parameters, mapping, locations, truth,
                        check, seed, tuple(reader.variables), reader.lines,
                        with_parameters(model, parameters) if model is not None else None, budget.size, prior,
                        read_fmu_options(top, fmu))
    if fmu is not None:
        campaign.check_variables(fmu_variables(fmu), fmu.name)
    return campaign

