"""The test geometry (``docs/geometry-format.md``): node coordinates in the
global Cartesian system (m), trace lines and elements between nodes, the
coordinate systems they were given in, and the unit vector of each
displacement direction, as one JSON document ``geometry.json``.

Made from a lab file's geometry datasets (UFF 15/2411, 82, 2412, 18/2420:
:mod:`.uff_geometry`) or from a model's node coordinates
(:func:`geometry_from_model`: a model object with ``nodes`` {id: coordinates
m} and, if it has them, ``elements`` with ``nodes``; this package does not
import the models themselves).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from structbench.models.errors import UserError

FORMAT = "structbench-geometry"
FORMAT_VERSION = 1
FILE_NAME = "geometry.json"
# displacement direction name -> unit vector in the node's displacement system
# (model names u v w = x y z; rotations are not drawn)
DIRECTIONS = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0),
              "u": (1.0, 0.0, 0.0), "v": (0.0, 1.0, 0.0), "w": (0.0, 0.0, 1.0)}
SYSTEM_TYPES = ("cartesian", "cylindrical", "spherical")


@dataclass(frozen=True)
class CoordinateSystem:
    """A coordinate system: ``origin`` (3,) m and ``axes`` (3, 3), row i the
    unit vector of local axis i, both in the global system; ``kind`` one of
    :data:`SYSTEM_TYPES`."""

    id: int
    kind: str = "cartesian"
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axes: tuple[tuple[float, ...], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    name: str = ""

    def to_global(self, local: np.ndarray) -> np.ndarray:
        """Global coordinates (m) of points (n, 3) given in this system
        (cylindrical: r, theta deg, z; spherical: r, theta deg from +z, phi deg)."""
        p = np.atleast_2d(np.asarray(local, dtype=float))
        if self.kind == "cylindrical":
            t = np.radians(p[:, 1])
            p = np.column_stack([p[:, 0] * np.cos(t), p[:, 0] * np.sin(t), p[:, 2]])
        elif self.kind == "spherical":
            t, f = np.radians(p[:, 1]), np.radians(p[:, 2])
            p = np.column_stack([p[:, 0] * np.sin(t) * np.cos(f), p[:, 0] * np.sin(t) * np.sin(f),
                                 p[:, 0] * np.cos(t)])
        return np.asarray(self.origin) + p @ np.asarray(self.axes)


GLOBAL = CoordinateSystem(0, name="global")


@dataclass
class Geometry:
    """Nodes {id: (3,) global m}, trace ``lines`` (each a polyline of node
    ids, with an ``id`` and ``name``), ``elements`` ({id, type, nodes}),
    coordinate ``systems`` {id: CoordinateSystem} and the displacement
    system of each node that has one other than the global (its shapes'
    x/y/z are along that system's axes)."""

    nodes: dict[int, np.ndarray] = field(default_factory=dict)
    lines: list[dict[str, Any]] = field(default_factory=list)
    elements: list[dict[str, Any]] = field(default_factory=list)
    systems: dict[int, CoordinateSystem] = field(default_factory=dict)
    displacement_systems: dict[int, int] = field(default_factory=dict)
    source: str = ""

    @property
    def empty(self) -> bool:
        return not (self.nodes or self.lines or self.elements)

    def direction(self, node: int, name: str) -> np.ndarray | None:
        """Global unit vector (3,) of a displacement direction at a node (None
        for rotations and unknown names): x y z along the node's displacement
        system's axes; in a cylindrical system radial, tangential, axial and
        in a spherical one r, theta, phi at the node's position."""
        if name not in DIRECTIONS:
            return None
        system = self.systems.get(self.displacement_systems.get(node, 0), GLOBAL)
        axes = np.asarray(system.axes)
        local = np.asarray(DIRECTIONS[name])
        if system.kind != "cartesian" and node in self.nodes:
            p = (np.asarray(self.nodes[node]) - np.asarray(system.origin)) @ axes.T
            phi = math.atan2(p[1], p[0])
            c, s = math.cos(phi), math.sin(phi)
            if system.kind == "cylindrical":
                basis = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
            else:
                t = math.atan2(math.hypot(p[0], p[1]), p[2])
                basis = np.array([[math.sin(t) * c, math.sin(t) * s, math.cos(t)],
                                  [math.cos(t) * c, math.cos(t) * s, -math.sin(t)], [-s, c, 0.0]])
            local = local @ basis
        return local @ axes

    def merge(self, other: "Geometry", where: str) -> None:
        """Add ``other``'s parts; a node given twice at different places
        (beyond 1e-9 m) is a :class:`UserError` naming ``where``."""
        for node, xyz in other.nodes.items():
            if node in self.nodes and not np.allclose(self.nodes[node], xyz, rtol=0, atol=1e-9):
                raise UserError(f"node {node} is at {list(xyz)} m here but at {list(self.nodes[node])} m in "
                                f"{self.source}", field=where)
            self.nodes[node] = xyz
        self.lines += other.lines
        self.elements += other.elements
        self.systems |= other.systems
        self.displacement_systems |= other.displacement_systems
        self.source = ", ".join(s for s in (self.source, other.source) if s)

    def document(self) -> dict[str, Any]:
        """The JSON document (docs/geometry-format.md)."""
        return {"format": FORMAT, "format_version": FORMAT_VERSION, "units": {"length": "m"}, "source": self.source,
                "nodes": [{"id": n, "xyz": [float(v) for v in xyz]}
                          | ({"displacement_system": self.displacement_systems[n]}
                             if self.displacement_systems.get(n, 0) else {})
                          for n, xyz in sorted(self.nodes.items())],
                "lines": self.lines, "elements": self.elements,
                "coordinate_systems": [{"id": c.id, "type": c.kind, "name": c.name, "origin": list(c.origin),
                                        "axes": [list(a) for a in c.axes]} for _, c in sorted(self.systems.items())],
                "directions": {k: list(v) for k, v in DIRECTIONS.items()}}


def write_geometry(path: str | Path, geometry: Geometry) -> Path:
    """Write ``geometry`` as JSON (through a temporary file); returns the path."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(geometry.document(), indent=1) + "\n")
    tmp.replace(path)
    return path


def _vector(value: Any, where: str) -> tuple[float, float, float]:
    try:
        xyz = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise UserError(f"{value!r:.60} is not a list of 3 numbers", field=where) from None
    if len(xyz) != 3 or not all(math.isfinite(v) for v in xyz):
        raise UserError(f"{list(xyz)} is not 3 finite numbers", field=where)
    return xyz  # type: ignore[return-value]


def read_geometry(path: str | Path) -> Geometry:
    """A geometry file; a malformed one is a :class:`UserError` naming the file and key."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise UserError("no such geometry file", field=str(path)) from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise UserError(f"not JSON: {err}", field=path.name) from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise UserError(f"not a {FORMAT} file", field=path.name)
    geometry = Geometry(source=str(doc.get("source", path.name)))
    try:
        for i, node in enumerate(doc.get("nodes", [])):
            geometry.nodes[int(node["id"])] = np.array(_vector(node["xyz"], f"{path.name} nodes[{i}].xyz"))
            if node.get("displacement_system"):
                geometry.displacement_systems[int(node["id"])] = int(node["displacement_system"])
        for i, c in enumerate(doc.get("coordinate_systems", [])):
            where = f"{path.name} coordinate_systems[{i}]"
            if c.get("type", "cartesian") not in SYSTEM_TYPES:
                raise UserError(f"type {c.get('type')!r} is not one of {', '.join(SYSTEM_TYPES)}", field=where)
            geometry.systems[int(c["id"])] = CoordinateSystem(
                int(c["id"]), c.get("type", "cartesian"), _vector(c["origin"], f"{where}.origin"),
                tuple(_vector(a, f"{where}.axes") for a in c["axes"]), str(c.get("name", "")))
        geometry.lines = [{"id": int(ln.get("id", 0)), "name": str(ln.get("name", "")),
                           "nodes": [int(n) for n in ln["nodes"]]} for ln in doc.get("lines", [])]
        geometry.elements = [{"id": int(e.get("id", 0)), "type": e.get("type", 0),
                              "nodes": [int(n) for n in e["nodes"]]} for e in doc.get("elements", [])]
    except (KeyError, TypeError, ValueError) as err:
        raise UserError(f"malformed geometry ({type(err).__name__}: {err})", field=path.name) from None
    check_nodes(geometry, path.name)
    return geometry


def check_nodes(geometry: Geometry, where: str) -> None:
    """Every node of a line or element must be a node of the geometry."""
    known = set(geometry.nodes)
    for kind, parts in (("lines", geometry.lines), ("elements", geometry.elements)):
        for i, part in enumerate(parts):
            unknown = sorted(set(part["nodes"]) - known)
            if unknown:
                raise UserError(f"{kind}[{i}] (id {part.get('id')}) names nodes {unknown[:5]} that are not "
                                "among the nodes", field=where)


def geometry_from_model(model: Any) -> Geometry:
    """The geometry of a model: its nodes (1-D, 2-D or 3-D coordinates, m,
    padded with zeros to x, y, z) and its elements as ``elements`` entries
    (type the element type's name; lumped elements on one node and points
    of a modal model have none; without elements one line joins the nodes
    in the order of their ids)."""
    nodes = {int(n): np.pad(np.asarray(xyz, dtype=float).ravel()[:3], (0, 3 - min(np.size(xyz), 3)))
             for n, xyz in model.nodes.items()}
    elements = [{"id": i + 1, "type": getattr(getattr(e, "type", None), "name", "element"),
                 "nodes": [int(n) for n in e.nodes]}
                for i, e in enumerate(getattr(model, "elements", []) or []) if len(e.nodes) > 1]
    lines = [] if elements else [{"id": 1, "name": "nodes in order", "nodes": sorted(nodes)}]
    return Geometry(nodes, lines, elements, {}, {}, f"model {getattr(model, 'name', '')}".strip())
