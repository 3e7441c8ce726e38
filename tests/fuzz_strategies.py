"""Hypothesis strategies for the fuzz tests: mutated TOML and JSON documents,
damaged trace files and variable mappings, plus :func:`cli`, which runs the
command line in this process and returns its exit status and stderr.

A case passes when the command succeeds or exits 2 with one line naming the
file; an exception escaping ``main`` is a traceback (the fuzz tests fail on
it, benchmarks/fuzz_long.py counts it).
"""
from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import shutil
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from hypothesis import strategies as st

from structbench.cli import main

# ---- running the CLI -------------------------------------------------------


def cli(argv: list[str]) -> tuple[int, str]:
    """Exit status and stderr of ``structbench argv`` run in this process."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    return code, err.getvalue()


def assert_clean_failure(code: int, err: str, allowed: tuple[int, ...], name: str) -> None:
    """``code`` is allowed; exit 2 comes with one error line that names ``name``
    (the damaged file) or a field of it."""
    assert code in allowed, (code, err)
    if code == 2:
        lines = [line for line in err.splitlines() if "error:" in line]
        assert len(lines) == 1, err
        assert ": error: " in lines[0] and len(lines[0].split(": error: ", 1)[1]) > 3, err


# ---- values and TOML/JSON documents ---------------------------------------

WEIRD_NUMBERS = st.sampled_from([0, -1, 1e308, -1e308, 1e-320, 2**70, -(2**63), math.nan, math.inf, -math.inf])
WEIRD_STRINGS = st.one_of(st.text(max_size=12), st.sampled_from(["", " ", "é-ü", "测试", "a/b", "..", "{node}", "x" * 300]))
SCALARS = st.one_of(st.booleans(), st.integers(-10**6, 10**6), st.floats(allow_nan=True), WEIRD_NUMBERS, WEIRD_STRINGS)
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                       st.dictionaries(st.text(max_size=6), inner, max_size=3)),
                      max_leaves=6)
OPERATIONS = ("drop", "retype", "number", "string", "unknown", "huge", "nest", "duplicate")


def _slots(doc: Any, depth: int = 0) -> list[tuple[Any, Any]]:
    """(container, key) of every value in a document (lists: first 6 items)."""
    out: list[tuple[Any, Any]] = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc[:6]) if isinstance(doc, list) else ()
    for key, value in items:
        out.append((doc, key))
        if depth < 6:
            out += _slots(value, depth + 1)
    return out


@st.composite
def mutated(draw: st.DrawFn, base: Any) -> Any:
    """``base`` (parsed TOML or JSON) with 1 to 3 random mutations."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 3))):
        slots = _slots(doc)
        if not slots:
            return draw(VALUES)
        container, key = draw(st.sampled_from(slots))
        op = draw(st.sampled_from(OPERATIONS))
        value = container[key]
        if op == "drop":
            del container[key]
        elif op == "retype":
            container[key] = draw(VALUES)
        elif op == "number":
            container[key] = draw(WEIRD_NUMBERS)
        elif op == "string":
            container[key] = draw(WEIRD_STRINGS)
        elif op == "unknown" and isinstance(container, dict):
            container[draw(WEIRD_STRINGS)] = draw(VALUES)
        elif op == "huge":  # the first 6 items (those later mutations reach) are copies, not the same object
            item = value if not isinstance(value, list) else 1.0
            n = draw(st.sampled_from([1000, 20000]))
            container[key] = [copy.deepcopy(item) for _ in range(6)] + [item] * (n - 6)
        elif op == "nest":
            container[key] = draw(st.sampled_from([[value], {"value": value}, [[value, value]]]))
        elif op == "duplicate" and isinstance(container, list):
            container.append(copy.deepcopy(value))
    return doc


def _toml_key(key: Any) -> str:
    key = str(key)
    return key if key and all(c.isascii() and (c.isalnum() or c in "-_") for c in key) else json.dumps(key, ensure_ascii=False)


def toml_value(value: Any) -> str:
    """``value`` as an inline TOML value."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return json.dumps(str(value), ensure_ascii=False)


def toml_dumps(doc: Any) -> str:
    """A document as TOML: one ``key = inline value`` line per top-level key."""
    if not isinstance(doc, dict):
        return f"value = {toml_value(doc)}\n"
    return "".join(f"{_toml_key(k)} = {toml_value(v)}\n" for k, v in doc.items())


@st.composite
def damaged_text(draw: st.DrawFn, text: str) -> str:
    """Text-level damage: a duplicated line, a cut, or inserted garbage."""
    lines = text.splitlines(keepends=True) or [""]
    i = draw(st.integers(0, len(lines) - 1))
    kind = draw(st.sampled_from(["duplicate", "cut", "garbage"]))
    if kind == "duplicate":
        return "".join(lines[:i + 1] + [lines[i]] + lines[i + 1:])
    if kind == "cut":
        return text[:draw(st.integers(0, len(text)))]
    return "".join(lines[:i]) + draw(st.text(min_size=1, max_size=20)) + "".join(lines[i:])


def mutated_toml(base_text: str, parsed: dict) -> st.SearchStrategy[str]:
    """A shipped TOML file mutated at the value level, or damaged as text."""
    return st.one_of(mutated(parsed).map(toml_dumps), damaged_text(base_text))


def mutated_json(parsed: Any) -> st.SearchStrategy[str]:
    """A JSON document mutated at the value level (NaN/inf written as such), or damaged as text."""
    return st.one_of(mutated(parsed).map(json.dumps), damaged_text(json.dumps(parsed, indent=1)))


# ---- trace files -----------------------------------------------------------

TRACE_DAMAGE = ("truncate", "garbage", "drop-channel", "extra-channel", "length", "nonfinite", "dtype",
                "attribute", "drop-attribute", "drop-time", "channels-dataset")


@st.composite
def trace_damage(draw: st.DrawFn) -> tuple[str, dict[str, Any]]:
    """A kind of damage (:data:`TRACE_DAMAGE`) and its random details."""
    kind = draw(st.sampled_from(TRACE_DAMAGE))
    return kind, {"fraction": draw(st.floats(0.0, 0.99)), "index": draw(st.integers(0, 10**6)),
                  "value": draw(st.one_of(SCALARS, st.lists(SCALARS, max_size=4))),
                  "bad": draw(st.sampled_from([math.nan, math.inf, -math.inf])),
                  "dtype": draw(st.sampled_from(["S8", "i1", "c16", "2d", "bool", "empty"])),
                  "length": draw(st.integers(0, 3000)), "garbage": draw(st.binary(max_size=200))}


def _pick(names: list[str], index: int) -> str:
    return names[index % len(names)]


def _data_for(dtype: str, n: int) -> np.ndarray:
    return {"S8": np.array([b"abc"] * n), "i1": np.ones(n, dtype="i1"), "c16": np.ones(n, dtype=complex),
            "2d": np.ones((n, 2)), "bool": np.ones(n, dtype=bool), "empty": np.ones(0)}[dtype]


def _set_attr(obj: Any, key: str, value: Any) -> None:
    try:
        obj.attrs[key] = value
    except (TypeError, ValueError):  # h5py cannot store it (e.g. mixed list): store its text
        obj.attrs[key] = repr(value)


def damage_trace(path: Path, kind: str, d: dict[str, Any]) -> None:
    """Apply one damage to the trace file ``path``."""
    if kind == "truncate":
        data = path.read_bytes()
        path.write_bytes(data[:int(d["fraction"] * len(data))])
        return
    if kind == "garbage":
        path.write_bytes(d["garbage"])
        return
    with h5py.File(path, "a") as f:
        names = sorted(f"channels/{k}" for k in f["channels"]) + sorted(f"excitation/{k}" for k in f.get("excitation", {}))
        name = _pick(names, d["index"])
        n = f["time"].shape[0]
        if kind == "drop-channel":
            del f[name]
        elif kind == "extra-channel":
            f.copy(f[name], f"{name}_extra{d['index'] % 7}")
        elif kind in ("length", "dtype"):
            attrs = dict(f[name].attrs)
            del f[name]
            f[name] = np.ones(d["length"]) if kind == "length" else _data_for(d["dtype"], n)
            f[name].attrs.update(attrs)
        elif kind == "nonfinite":
            f[name][d["index"] % n] = d["bad"]
        elif kind in ("attribute", "drop-attribute"):
            target = _pick([f, f[name], f["time"]] + ([f["excitation"]] if "excitation" in f else []), d["index"])
            keys = sorted(target.attrs) or ["x"]
            key = _pick(keys, d["index"] // 7)
            if kind == "attribute":
                _set_attr(target, key, d["value"])
            elif key in target.attrs:
                del target.attrs[key]
        elif kind == "drop-time":
            del f["time"]
        elif kind == "channels-dataset":
            del f["channels"]
            f["channels"] = np.ones(3)


def copy_folder(src: Path, dst: Path) -> Path:
    """A fresh copy of a seed folder."""
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    return dst


# ---- external-FMU mapping --------------------------------------------------

MAPPING_PATTERNS = st.sampled_from([
    "F_{node}_{dir}", "u_{node}_{dir}", "v_{node}_{dir}", "a_{node}_{dir}",   # right, or on the wrong variable
    "X_{node}_{dir}", "u_1_z", "F_1_z", "m", "fail_kind",                      # nothing, fixed names, parameters
    "{node", "{nod}_{dir}", "{node:q}", "{0}", "{node[0]}", "{dir.upper}", "", "u_{node}_{dir}_é",
])
MAPPING_KEYS = ("force", "displacement", "velocity", "acceleration", "initial_displacement", "initial_velocity")


@st.composite
def mappings(draw: st.DrawFn) -> dict[str, Any]:
    """A random ``[mapping]`` table for the test FMU (variables F_1_z, u_1_z, v_1_z, a_1_z)."""
    table = {k: draw(MAPPING_PATTERNS) for k in draw(st.lists(st.sampled_from(MAPPING_KEYS), unique=True))}
    if draw(st.booleans()):
        channels = st.sampled_from(["force_1_z", "displacement_1_z", "acceleration_1_z", "velocity_2_z", "x_1"])
        table["table"] = draw(st.dictionaries(channels, MAPPING_PATTERNS, max_size=3))
    return table
