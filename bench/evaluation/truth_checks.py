"""Validation of ``truth.json`` as scoring reads it: each failure names the
file and the key path."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from structbench.identifier.io.json_checks import Doc, load_json


def _mode_shapes(doc: Doc) -> None:
    shapes = doc.key("mode_shapes", [])
    rows = shapes.items()
    if not rows:
        return
    dofs = doc.key("sensor_dofs").items()
    for dof in dofs:
        pair = dof.items()
        if len(pair) != 2:
            raise dof.error("expected [node, direction]")
        pair[0].integer(), pair[1].string()
    if len(rows) != len(dofs):
        raise shapes.error(f"has {len(rows)} rows, sensor_dofs has {len(dofs)}")
    width = len(rows[0].numbers())
    for row in rows:
        row.numbers(width)


def read_truth(path: Path) -> dict[str, Any]:
    """``truth.json``, checked for what scoring uses: ``parameters`` (label,
    value), ``omega``, ``sensor_dofs`` and ``mode_shapes``."""
    doc = Doc(path, load_json(path))
    for p in doc.key("parameters", []).items():
        p.key("label").string(), p.key("value").number()
    doc.key("omega", []).numbers()
    _mode_shapes(doc)
    return doc.value
