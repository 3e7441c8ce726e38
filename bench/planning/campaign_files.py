"""Campaign files written by a plan: one test of a campaign, with its
sensors replaced (a planned layout), its impulse moved (a planned
excitation point) and/or its repetitions set (``--verify``).

The campaign's own TOML is parsed (``tomllib``), the ``[[tests]]`` entry
named ``test`` kept (alone, for verification), and the result written back
as TOML that ``structbench run`` takes as is. The campaign's relative
paths (a TOML model or FMU ``structure``, ``[prior] model``, every test's
recorded signal ``file``) are made absolute, so the file works from any
folder (``--verify`` writes it into a temporary one).
"""
from __future__ import annotations

import json
import math
import re
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from structbench.models.errors import UserError

BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if BARE_KEY.match(k) else json.dumps(k)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"cannot write {v} to TOML")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise ValueError(f"cannot write {type(v).__name__} to TOML")


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def dumps(data: dict[str, Any], prefix: str = "") -> str:
    """TOML text of ``data``: scalars and inline values first, then tables,
    then arrays of tables (nested tables of those as dotted sub-tables)."""
    lines = [f"{_key(k)} = {_value(v)}" for k, v in data.items()
             if not isinstance(v, dict) and not _is_table_array(v)]
    out = "\n".join(lines) + ("\n" if lines else "")
    for k, v in data.items():
        name = f"{prefix}{_key(k)}"
        if isinstance(v, dict):
            out += f"\n[{name}]\n" + dumps(v, name + ".")
        elif _is_table_array(v):
            for item in v:
                out += f"\n[[{name}]]\n" + dumps(item, name + ".")
    return out


def test_campaign(path: str | Path, test: str, sensors: Sequence[tuple[int, str, str]] | None = None,
                  repetitions: int | None = None, seed: int | None = None, only: bool = True,
                  drive: tuple[int, str] | None = None) -> str:
    """TOML text of the campaign at ``path`` with ``[[tests]]`` entry ``test``
    changed: ``sensors`` (node, dir, quantity) replace its sensors (one entry
    each, in order), ``drive`` (node, dir) is the node and direction of its
    impulse (its one ``impulse`` excitation entry), ``repetitions`` and
    ``seed`` (the campaign's) set; ``only``: drop the other tests and the
    ``[check]`` gates."""
    path = Path(path)
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    tests = data.get("tests", [])
    chosen = [t for t in tests if t.get("name") == test]
    if not chosen:
        raise UserError(f"no test {test!r} in {path.name}; tests: {', '.join(t.get('name', '?') for t in tests)}",
                        field="--test")
    entry = chosen[0]
    if sensors is not None:
        entry["sensors"] = [{"nodes": [int(n)], "dirs": [d], "quantities": [q]} for n, d, q in sensors]
    if drive is not None:
        (item,) = [e for e in entry.get("excitation", []) if e.get("kind") == "impulse"]
        item["node"], item["dir"] = int(drive[0]), str(drive[1])
    if repetitions is not None:
        entry["repetitions"] = int(repetitions)
    if only:
        data["tests"] = [entry]
        data.pop("check", None)
    if seed is not None:
        data["seed"] = int(seed)
    structure = data.get("structure")
    if isinstance(structure, str) and (structure.endswith((".toml", ".fmu"))):
        data["structure"] = _absolute(path, structure)
    prior = data.get("prior")
    if isinstance(prior, dict) and isinstance(prior.get("model"), str) and prior["model"].endswith((".toml", ".fmu")):
        prior["model"] = _absolute(path, prior["model"])
    for item in (e for t in data.get("tests", []) for e in t.get("excitation", []) if isinstance(e, dict)):
        if isinstance(item.get("file"), str):
            item["file"] = _absolute(path, item["file"])
    return dumps(data)


def _absolute(campaign: Path, name: str) -> str:
    """``name`` (a path relative to the campaign file's folder, or absolute) as an absolute path."""
    return name if Path(name).is_absolute() else str((campaign.parent / name).resolve())
