"""The sensor map (TOML): what a lab file lacks, per channel and per file.

    campaign = "lab-2026"          # trace attribute `campaign`
    structure = "shear-frame-3"    # trace attribute `structure` (identify's default model)
    length_unit = "mm"             # geometry (UFF 15/2411) without a units dataset 164 (default m)

    [directions]                   # UFF direction codes x y z rx ry rz -> the model's names
    z = "w"

    [[channels]]                   # matched by `name` (CSV header, SEP005 name, UFF ID line 1),
    name = "acc7"                  #   or by `dataset` (and `file`), or else by `node` + `direction`
    file = "run*.csv"              # optional: only files matching this shell pattern
    dataset = 4                    # UFF dataset / CSV column / SEP005 channel number, from 1
    quantity = "acceleration"      # displacement | velocity | acceleration | force
    node = 7
    direction = "w"
    unit = "g"                     # the file's unit; converted to SI
    sign = -1                      # -1: the sensor points along the negative axis
    location = [0.7, 0.0, 0.0]     # m
    noise_ratio = 0.01             # declared sensor noise (trace format)
    noise_mode = "rms"
    excitation = false             # true: a commanded force, written to /excitation

    [[tests]]                      # one per file (shell pattern): the trace's attributes
    file = "run1.csv"
    test = "harmonic-01"           # default: the file name without suffix
    group = "harmonic"             # default: the test
    repetition = 0
    step = 0.001                   # s, default dt
    seed = 0
    excitation = {omega = 12.5, window_start = 4.0}   # /excitation attributes
    noise = {}                                         # /noise attributes

Values the map gives override the file's (`quantity`, `node`, `direction`,
`unit`, `sign`: :data:`OVERRIDES`), so a mislabelled channel is repaired by
its entry; `location`, `noise_ratio`, `noise_mode` and `excitation` come
from the map only. :func:`map_text` writes a map that :func:`load_map` reads.
"""
from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, field
from fnmatch import fnmatch
from pathlib import Path
from typing import Any

import numpy as np

from structbench.models.errors import UserError

from structbench.models.channels import QUANTITIES

from .signals import Signal

CHANNEL_KEYS = {"name", "file", "dataset", "quantity", "node", "direction", "unit", "sign", "location",
                "noise_ratio", "noise_mode", "excitation"}
OVERRIDES = ("quantity", "node", "direction", "unit", "sign")  # map values that replace the file's
TEST_KEYS = {"file", "test", "group", "repetition", "step", "seed", "excitation", "noise"}
TOP_KEYS = {"campaign", "structure", "length_unit", "directions", "channels", "tests"}
UFF_DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True)
class SensorMap:
    """A parsed sensor map (all parts optional)."""

    campaign: str | None = None
    structure: str | None = None
    directions: dict[str, str] = field(default_factory=dict)
    channels: tuple[dict[str, Any], ...] = ()
    tests: tuple[dict[str, Any], ...] = ()
    length_unit: str | None = None

    def direction(self, code: str) -> str:
        """The model's name of a UFF direction code (``x`` .. ``rz``)."""
        return self.directions.get(code, code)

    def match(self, signal: Signal) -> tuple[int | None, dict[str, Any]]:
        """The index in ``channels`` and the entry for ``signal`` ((None, {})
        if none): by ``name`` and/or ``dataset`` (both must fit when both are
        given), else, for an entry with neither, by the file's node and direction."""
        mine = [(i, c) for i, c in enumerate(self.channels) if fnmatch(signal.file, c.get("file", "*"))]
        for i, entry in mine:
            if ("name" in entry or "dataset" in entry) and entry.get("name", signal.key) == signal.key \
                    and entry.get("dataset", signal.dataset) == signal.dataset:
                return i, entry
        for i, entry in mine:
            if ("name" not in entry and "dataset" not in entry and entry.get("node") == signal.node
                    and entry.get("direction") in (signal.direction, None)):
                return i, entry
        return None, {}

    def channel(self, signal: Signal) -> dict[str, Any]:
        """The entry for ``signal`` ({} if none), see :meth:`match`."""
        return self.match(signal)[1]

    def test(self, file: str) -> dict[str, Any]:
        """The ``[[tests]]`` entry of a file ({} if none)."""
        return next((t for t in self.tests if fnmatch(file, t.get("file", "*"))), {})


def _check(table: dict[str, Any], known: set[str], where: str) -> None:
    unknown = sorted(set(table) - known)
    if unknown:
        raise UserError(f"unknown key(s) {unknown}; known: {', '.join(sorted(known))}", field=where)


def load_map(path: str | Path | None) -> SensorMap:
    """Read a sensor map; None gives the empty map."""
    if path is None:
        return SensorMap()
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise UserError("no such sensor map", field=str(path)) from None
    except tomllib.TOMLDecodeError as err:
        raise UserError(str(err), field=path.name) from None
    _check(data, TOP_KEYS, path.name)
    for i, entry in enumerate(data.get("channels", [])):
        _check(entry, CHANNEL_KEYS, f"{path.name} channels[{i}]")
        where = f"{path.name} channels[{i}]"
        if entry.get("quantity", "force") not in QUANTITIES:
            raise UserError(f"{entry['quantity']!r} is not one of {', '.join(QUANTITIES)}", field=f"{where}.quantity")
        for key in ("dataset", "node"):
            if key in entry and (not isinstance(entry[key], int) or isinstance(entry[key], bool) or entry[key] < 0):
                raise UserError(f"{entry[key]!r} is not a non-negative integer", field=f"{where}.{key}")
        if entry.get("sign", 1) not in (1, -1):
            raise UserError(f"{entry['sign']!r} is neither 1 nor -1", field=f"{where}.sign")
        if "sign" in entry:
            entry["sign"] = float(entry["sign"])
    for i, entry in enumerate(data.get("tests", [])):
        _check(entry, TEST_KEYS, f"{path.name} tests[{i}]")
    bad = sorted(set(data.get("directions", {})) - set(UFF_DIRECTIONS))
    if bad:
        raise UserError(f"{bad} are not UFF direction codes ({', '.join(UFF_DIRECTIONS)})",
                        field=f"{path.name} directions")
    return SensorMap(data.get("campaign"), data.get("structure"), dict(data.get("directions", {})),
                     tuple(data.get("channels", [])), tuple(data.get("tests", [])), data.get("length_unit"))


def _value(value: Any) -> str:
    if isinstance(value, (np.generic, np.ndarray)):
        value = value.tolist()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("nan" if math.isnan(value) else
                                                          ("inf" if value > 0 else "-inf"))
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_value(v)}" for k, v in value.items()) + "}"
    return "[" + ", ".join(_value(v) for v in value) + "]"


def map_text(top: dict[str, Any], channels: list[dict[str, Any]], tests: list[dict[str, Any]]) -> str:
    """A sensor map as TOML text (floats written exactly, by ``repr``)."""
    lines = [f"{k} = {_value(v)}" for k, v in top.items()]
    for name, entries in (("tests", tests), ("channels", channels)):
        for entry in entries:
            lines += ["", f"[[{name}]]"] + [f"{k} = {_value(v)}" for k, v in entry.items()]
    return "\n".join(lines) + "\n"
