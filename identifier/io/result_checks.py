"""Validation of a results file read back from disk (docs/results-format.md):
types, lengths and consistency between runs, each failure naming the file
and the key path, before anything computes with it."""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from .json_checks import Doc

SENSOR = re.compile(r"^[a-z]+_\d+_\S+$")
PARAMETER_KEYS = {"label", "kind", "unit", "value", "std_error", "initial"}
RUN_KEYS = {"method", "structure", "repetition", "tests", "status", "message", "parameters", "iterations",
            "history", "misfit_history", "omega", "eigenvalues", "mode_shapes", "sensors", "details",
            "damping", "omega_std", "damping_std", "mpc", "mode_shapes_complex", "mode_shapes_std"}


def _parameters(run: Doc) -> list[str]:
    labels = []
    for p in run.key("parameters", []).items():
        p.allow(PARAMETER_KEYS)
        labels.append(p.key("label").string())
        p.key("kind").string(), p.key("unit").string(), p.key("value").number()
        p.key("std_error", None).number(optional=True), p.key("initial", None).number(optional=True)
    return labels


def _run(run: Doc) -> tuple[list[str], bool]:
    """Check one run; returns its parameter labels and whether it has a history."""
    run.allow(RUN_KEYS)
    run.key("method").string(), run.key("structure").string(), run.key("repetition").integer()
    run.key("tests").strings(), run.key("status", "ok").string(), run.key("message", "").string()
    labels = _parameters(run)
    run.key("iterations", None).integer(optional=True)
    history = run.key("history", []).items()
    for row in history:
        row.numbers(len(labels))
    for key in ("misfit_history", "omega", "eigenvalues"):
        run.key(key, []).numbers()
    sensors = run.key("sensors", [])
    for s in sensors.items():
        if not SENSOR.match(s.string()):
            raise s.error(f"{s.value!r} is not a channel name <quantity>_<node>_<direction>")
    for key in ("mode_shapes", "mode_shapes_std"):  # one list per mode over the sensors (NaN allowed)
        for shape in run.key(key, []).items():
            shape.numbers(len(sensors.value))
    modes = len(run.key("omega", []).value)
    for key in ("damping", "omega_std", "damping_std", "mpc"):  # modal methods: one per mode, NaN allowed
        values = run.key(key, [])
        if values.value:
            values.numbers(modes)
    for shape in run.key("mode_shapes_complex", []).items():
        for pair in shape.items():
            pair.numbers(2)
    run.key("details", {}).obj()
    return labels, bool(history)


def check_results(path: Path, data: Any, fmt: str) -> None:
    """Raise :class:`~.json_checks.JsonError` unless ``data`` is a valid results document."""
    doc = Doc(path, data)
    if doc.key("format", None).value != fmt:
        raise doc.error(f"not a {fmt} file (format is {doc.obj().get('format')!r:.60})")
    doc.key("method").string()
    first: tuple[list[str], bool] | None = None
    for run in doc.key("runs").items():
        shape = _run(run)
        if first is not None and shape != first:
            raise run.error("parameters or history differ from those of runs[0]")
        first = first or shape
