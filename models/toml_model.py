"""Structures described in TOML (format: docs/model-format.md).

Every error names the offending field, e.g. ``elements[3].m``; read from a
file, also the file and the field's line (``frame.toml:12: elements[3].m:``).
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from .elements import element_type
from .errors import ModelError
from .input_text import read_input_text
from .structure import SUPPORTS, Element, Structure

TOP_KEYS = {"name", "description", "units", "unknown", "rayleigh", "nodes", "elements", "supports"}
NODE_KEYS = {"id", "x", "y", "z"}
SUPPORT_KEYS = {"node", "type", "fix"}


def _check_keys(table: dict[str, Any], allowed: set[str], where: str) -> None:
    if not isinstance(table, dict):
        raise ModelError(f"expected a table, got {table!r:.60}", field=where or "model")
    extra = sorted(set(table) - allowed)
    if extra:
        raise ModelError(f"unknown key(s) {extra}; allowed: {sorted(allowed)}", field=f"{where}.{extra[0]}" if where else extra[0])


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ModelError(f"expected a number, got {value!r}", field=where)
    return float(value)


def _node(table: dict[str, Any], i: int) -> tuple[int, np.ndarray]:
    where = f"nodes[{i}]"
    _check_keys(table, NODE_KEYS, where)
    if "id" not in table:
        raise ModelError("missing node id", field=f"{where}.id")
    node_id = table["id"]
    if isinstance(node_id, bool) or not isinstance(node_id, int):
        raise ModelError(f"node id must be an integer, got {node_id!r}", field=f"{where}.id")
    coords = np.array([_number(table.get(axis, 0.0), f"{where}.{axis}") for axis in ("x", "y", "z")])
    return node_id, coords


def _element(table: dict[str, Any], i: int) -> Element:
    where = f"elements[{i}]"
    if not isinstance(table, dict):
        raise ModelError(f"expected a table, got {table!r:.60}", field=where)
    if "type" not in table:
        raise ModelError("missing element type", field=f"{where}.type")
    if not isinstance(table["type"], str):
        raise ModelError(f"expected a string, got {table['type']!r:.60}", field=f"{where}.type")
    try:
        etype = element_type(table["type"])
    except ModelError as err:
        raise ModelError(str(err).split(": ", 1)[1], field=f"{where}.type") from None
    names = {spec.name for spec in etype.parameters}
    _check_keys(table, {"type", "nodes", "dir"} | names, where)
    nodes = table.get("nodes")
    if not isinstance(nodes, list) or not all(isinstance(n, int) and not isinstance(n, bool) for n in nodes):
        raise ModelError(f"expected a list of node ids, got {nodes!r}", field=f"{where}.nodes")
    values = {name: _number(table[name], f"{where}.{name}") for name in names if name in table}
    direction = table.get("dir")
    if direction is not None and not isinstance(direction, str):
        raise ModelError(f"expected a direction name, got {direction!r:.60}", field=f"{where}.dir")
    if etype.directions is not None and direction is not None:
        raise ModelError(f"{etype.name} has fixed directions {etype.directions}", field=f"{where}.dir")
    return Element(etype, tuple(nodes), values, direction)


def _support(table: dict[str, Any], i: int) -> tuple[int, str | tuple[str, ...]]:
    where = f"supports[{i}]"
    _check_keys(table, SUPPORT_KEYS, where)
    if "node" not in table:
        raise ModelError("missing node", field=f"{where}.node")
    if isinstance(table["node"], bool) or not isinstance(table["node"], int):
        raise ModelError(f"expected a node id, got {table['node']!r:.60}", field=f"{where}.node")
    if "fix" in table:
        fix = table["fix"]
        if not isinstance(fix, list) or not all(isinstance(d, str) for d in fix):
            raise ModelError(f"expected a list of directions, got {fix!r:.60}", field=f"{where}.fix")
        return table["node"], tuple(fix)
    kind = table.get("type", "clamped")
    if not isinstance(kind, str) or kind not in SUPPORTS:
        raise ModelError(f"unknown support {kind!r}; known: {', '.join(SUPPORTS)}", field=f"{where}.type")
    return table["node"], kind


def structure_from_dict(data: dict[str, Any], default_name: str = "model") -> Structure:
    """Build a :class:`Structure` from parsed TOML data (1-based indices in errors)."""
    _check_keys(data, TOP_KEYS, "")
    for key in ("nodes", "elements", "supports", "unknown"):
        if not isinstance(data.get(key, []), list):
            raise ModelError(f"expected a list, got {data[key]!r:.60}", field=key)
    if not all(isinstance(kind, str) for kind in data.get("unknown", [])):
        raise ModelError("expected a list of parameter kinds", field="unknown")
    if not isinstance(data.get("name", default_name), str):
        raise ModelError(f"expected a string, got {data['name']!r:.60}", field="name")
    if not data.get("nodes"):
        raise ModelError("a model needs at least one [[nodes]] entry", field="nodes")
    if not data.get("elements"):
        raise ModelError("a model needs at least one [[elements]] entry", field="elements")
    nodes: dict[int, np.ndarray] = {}
    for i, table in enumerate(data["nodes"], start=1):
        node_id, coords = _node(table, i)
        if node_id in nodes:
            raise ModelError(f"node {node_id} defined twice", field=f"nodes[{i}].id")
        nodes[node_id] = coords
    elements = [_element(t, i) for i, t in enumerate(data["elements"], start=1)]
    supports = dict(_support(t, i) for i, t in enumerate(data.get("supports", []), start=1))
    rayleigh = data.get("rayleigh", [0.0, 0.0])
    if not isinstance(rayleigh, list) or len(rayleigh) != 2:
        raise ModelError("expected [alpha (1/s), beta (s)]", field="rayleigh")
    structure = Structure(name=data.get("name", default_name), nodes=nodes, elements=elements,
                          supports=supports,
                          rayleigh=(_number(rayleigh[0], "rayleigh[0]"), _number(rayleigh[1], "rayleigh[1]")),
                          unknown=tuple(data.get("unknown", ("mass", "stiffness"))))
    _check_mass(structure)
    return structure


def _check_mass(structure: Structure) -> None:
    """Every free DOF needs mass (else the mass matrix is singular)."""
    diagonal = structure.mass().diagonal()
    massless = [structure.dofs[j] for j in np.flatnonzero(~(diagonal > 0))]
    if massless:
        node, direction = massless[0]
        raise ModelError(f"free DOF ({node}, {direction!r}) has no mass ({len(massless)} massless DOF in all); "
                         "add a mass element or a support", field="elements")


_HEADER = re.compile(r"\s*(\[\[?)\s*([A-Za-z0-9_-]+)\s*\]")
_KEY = re.compile(r"\s*([A-Za-z0-9_-]+|\"[^\"]*\"|'[^']*')\s*=")
_STRING = re.compile(r'"(?:\\.|[^"\\])*"|\'[^\']*\'')
_FIELD = re.compile(r"([A-Za-z0-9_-]+)|\[(\d+)\]")


def key_lines(text: str) -> dict[tuple[str | int, ...], int]:
    """Line (1-based) of each header and key of a model file by key path,
    arrays of tables counted from 1 as the errors name them:
    ``("elements", 3, "m")`` is ``m`` of the third ``[[elements]]``. Keys
    inside inline tables, multi-line arrays and strings are not listed."""
    lines: dict[tuple[str | int, ...], int] = {}
    counts: dict[str, int] = {}
    table: tuple[str | int, ...] = ()
    depth, quote = 0, None
    for number, line in enumerate(text.splitlines(), start=1):
        if quote is not None:  # inside a multi-line string
            quote = None if line.count(quote) % 2 else quote
            continue
        header, key = _HEADER.match(line), _KEY.match(line)
        if depth == 0 and header:
            name = header[2]
            counts[name] = counts.get(name, 0) + 1
            table = (name, counts[name]) if header[1] == "[[" else (name,)
            lines.setdefault((name,), number)
            lines.setdefault(table, number)
            continue
        if depth == 0 and key:
            lines.setdefault(table + (key[1].strip("\"'"),), number)
        quote = next((q for q in ('"""', "'''") if line.count(q) % 2), None)
        code = _STRING.sub("", line).split("#", 1)[0]
        depth = max(depth + code.count("[") - code.count("]") + code.count("{") - code.count("}"), 0)
    return lines


def field_line(text: str, field: str | None) -> int | None:
    """Line of a field named as in the errors (``elements[3].m``), or of its
    closest written ancestor (``elements[3]`` for a missing key)."""
    if not field:
        return None
    path = tuple(int(m[2]) if m[2] else m[1] for m in _FIELD.finditer(field))
    lines = key_lines(text)
    return next((lines[path[:end]] for end in range(len(path), 0, -1) if path[:end] in lines), None)


def load_structure(path: str | Path) -> Structure:
    """Read a TOML model file; an error names the file, the line and the
    field (malformed TOML: the line and column of the parser)."""
    path = Path(path)
    text = read_input_text(path, "model file", ModelError)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        line = re.search(r"at line (\d+)", str(err))
        raise ModelError(f"malformed TOML: {err}", field=f"{path.name}:{line[1]}" if line else path.name) from None
    try:
        return structure_from_dict(data, default_name=path.stem)
    except ModelError as err:
        line = field_line(text, err.field)
        raise err.at(f"{path.name}:{line}" if line else path.name) from None
