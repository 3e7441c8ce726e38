"""Geometry datasets of a Universal File: nodes (15, 2411), trace lines
(82), elements (2412), coordinate systems (18, 2420) and units (164), read
field by field from the published layouts (columns are fixed):

- 15 (nodes, single precision), one record per node ``4I10,1P3E13.5``:
  node label, definition coordinate system, displacement coordinate
  system, color, three coordinates;
- 2411 (nodes, double precision), two records per node: ``4I10`` (node
  label, export (definition) coordinate system, displacement coordinate
  system, color) and ``1P3D25.16`` (three coordinates);
- 82 (trace line): ``3I10`` (trace line number, number of nodes, color),
  ``80A1`` (identification), ``8I10`` per line: the nodes, 0 = move to the
  next node without drawing;
- 2412 (elements), per element ``6I10`` (label, FE descriptor id, physical
  and material property, color, number of nodes), for beams (descriptors
  11, 21-24) a record ``3I10`` (orientation node, cross sections), then the
  node labels ``8I10`` per line;
- 18 (coordinate systems), per system ``5I10`` (number, type 0 Cartesian /
  1 cylindrical / 2 spherical, reference system, color, method of
  definition 1), ``20A2`` (name), ``1P6E13.5`` and ``1P3E13.5``: origin,
  a point on the +x axis and a point in the +xz plane, in the reference system;
- 2420 (coordinate systems): ``1I10`` (part UID), ``40A2`` (part name),
  then per system ``3I10`` (label, type, color), ``40A2`` (name) and four
  records ``1P3D25.16``: rows 1-3 of the transformation matrix (row i the
  unit vector of local axis i in the global system), row 4 the origin;
- 164 (units): ``I10,20A1,I10`` then ``3D25.17``: the length factor (file
  units per metre: SI = value / factor).

Node coordinates given in a local system become global
(:meth:`~.geometry.CoordinateSystem.to_global`); lengths are scaled to m.
"""
from __future__ import annotations

import numpy as np

from structbench.models.errors import UserError

from .geometry import SYSTEM_TYPES, CoordinateSystem, Geometry
from .uff58 import Dataset

GEOMETRY_KINDS = (15, 2411, 82, 2412, 18, 2420)
BEAMS = {11, 21, 22, 23, 24}


class _Fields:
    """Fixed-column fields of one dataset, each error naming the file, the
    dataset and the record."""

    def __init__(self, file: str, dataset: Dataset):
        self.file, self.dataset, self.pos = file, dataset, 0

    def fail(self, message: str, record: int) -> UserError:
        return UserError(message, field=f"{self.file} dataset {self.dataset.index} ({self.dataset.kind}) "
                                        f"record {record}")

    def more(self) -> bool:
        while self.pos < len(self.dataset.lines) and not self.dataset.lines[self.pos].strip():
            self.pos += 1
        return self.pos < len(self.dataset.lines)

    def line(self, record: int) -> str:
        if self.pos >= len(self.dataset.lines):
            raise self.fail("the dataset ends here (truncated)", record)
        self.pos += 1
        return self.dataset.lines[self.pos - 1]

    def _fields(self, record: int, count: int, width: int, kind: type, names: str) -> list:
        """``count`` fields of ``width`` columns; a line whose columns do not
        parse but that holds ``count`` blank-separated values is read by those."""
        text = self.line(record)
        padded = text.ljust(width * count).replace("D", "E").replace("d", "e")
        try:
            return [kind(padded[width * i:width * i + width].strip() or 0) for i in range(count)]
        except ValueError:
            words = padded.split()
            try:
                if len(words) == count:
                    return [kind(w) for w in words]
            except ValueError:
                pass
            raise self.fail(f"{names}: {text.strip()[:60]!r} are not {count} "
                            f"{'integers' if kind is int else 'numbers'} ({width} columns each)", record) from None

    def ints(self, record: int, count: int, names: str) -> list[int]:
        return self._fields(record, count, 10, int, names)

    def floats(self, record: int, count: int, width: int, names: str) -> list[float]:
        return self._fields(record, count, width, float, names)

    def node_list(self, record: int, count: int) -> list[int]:
        """``count`` node labels, ``8I10`` per line (longer lines, as pyuff
        writes them, are read to their end)."""
        nodes: list[int] = []
        while len(nodes) < count:
            text = self.dataset.lines[self.pos] if self.pos < len(self.dataset.lines) else ""
            fields = max(1, min(count - len(nodes), -(-len(text.rstrip()) // 10)))
            nodes += self.ints(record, fields, "node labels")
        return nodes


def length_factor(file: str, datasets: list[Dataset]) -> float | None:
    """Metres per file length unit from dataset 164 (None without one)."""
    for d in datasets:
        if d.kind == 164:
            f = _Fields(file, d)
            f.line(1)
            words = f.line(2).replace("D", "E").replace("d", "e").split()
            try:
                factor = float(words[0])
            except (IndexError, ValueError):
                raise f.fail("no length factor (3D25.17)", 2) from None
            if not factor > 0:
                raise f.fail(f"length factor {factor:g} is not positive", 2)
            return 1.0 / factor
    return None


def _nodes(f: _Fields, raw: dict[int, tuple[int, int, list[float], str]]) -> None:
    while f.more():
        if f.dataset.kind == 15:
            text = f.line(1)
            words = text.replace("D", "E").replace("d", "e").split()
            try:
                head = _Fields(f.file, Dataset(f.dataset.index, 15, (text[:40],)))
                label, system, displacement, _ = head.ints(1, 4, "node label, coordinate systems, color")
                xyz = _Fields(f.file, Dataset(f.dataset.index, 15, (text[40:],))).floats(1, 3, 13, "coordinates")
            except UserError:
                if len(words) != 7:
                    raise f.fail(f"{text.strip()[:60]!r} is not a node record 4I10,1P3E13.5 (label, systems, "
                                 "color, x y z)", 1) from None
                try:
                    label, system, displacement = (int(w) for w in words[:3])
                    xyz = [float(w) for w in words[4:]]
                except ValueError:
                    raise f.fail(f"{text.strip()[:60]!r} is not a node record 4I10,1P3E13.5", 1) from None
        else:
            label, system, displacement, _ = f.ints(1, 4, "node label, coordinate systems, color")
            xyz = f.floats(2, 3, 25, "coordinates")
        raw[label] = (system, displacement, xyz, f"{f.file} dataset {f.dataset.index}")


def _line(f: _Fields, geometry: Geometry) -> None:
    number, count, _ = f.ints(1, 3, "trace line number, number of nodes, color")
    name = f.line(2).strip()
    nodes = f.node_list(3, count)
    run: list[int] = []
    for node in nodes + [0]:
        if node:
            run.append(node)
            continue
        if len(run) > 1:
            geometry.lines.append({"id": number, "name": name, "nodes": run})
        run = []


def _elements(f: _Fields, geometry: Geometry) -> None:
    while f.more():
        label, descriptor, _, _, _, count = f.ints(1, 6, "element label, FE descriptor, properties, color, nodes")
        if descriptor in BEAMS:
            f.ints(2, 3, "beam orientation node, cross sections")
        geometry.elements.append({"id": label, "type": descriptor, "nodes": f.node_list(3, count)})


def _axes(origin: np.ndarray, x_point: np.ndarray, xz_point: np.ndarray) -> np.ndarray | None:
    """Rows ex, ey, ez: ex towards the +x point, ez the part of the +xz
    point's direction normal to ex, ey = ez x ex (None if they are collinear)."""
    ex = x_point - origin
    if np.linalg.norm(ex) == 0:
        return None
    ex = ex / np.linalg.norm(ex)
    v = xz_point - origin
    ez = v - (v @ ex) * ex
    if np.linalg.norm(ez) <= 1e-12 * max(np.linalg.norm(v), 1e-300):
        return None
    ez = ez / np.linalg.norm(ez)
    return np.vstack([ex, np.cross(ez, ex), ez])


def _systems18(f: _Fields, scale: float, defined: dict[int, tuple[int, str, np.ndarray, int]]) -> None:
    while f.more():
        number, kind, reference, _, method = f.ints(1, 5, "number, type, reference system, color, method")
        if kind not in (0, 1, 2):
            raise f.fail(f"coordinate system type {kind}: 0 Cartesian, 1 cylindrical or 2 spherical", 1)
        if method not in (0, 1):
            raise f.fail(f"method of definition {method}: only 1 (origin, +x axis, +xz plane) is published", 1)
        name = f.line(2).strip()
        values = f.floats(3, 6, 13, "origin, point on +x") + f.floats(4, 3, 13, "point in +xz plane")
        defined[number] = (kind, name, np.array(values).reshape(3, 3) * scale, reference)


def _systems2420(f: _Fields, scale: float, systems: dict[int, CoordinateSystem]) -> None:
    f.line(1), f.line(2)
    while f.more():
        label, kind, _ = f.ints(3, 3, "coordinate system label, type, color")
        if kind not in (0, 1, 2):
            raise f.fail(f"coordinate system type {kind}: 0 Cartesian, 1 cylindrical or 2 spherical", 3)
        name = f.line(4).strip()
        rows = np.array([f.floats(record, 3, 25, f"transformation matrix row {record - 4}") for record in (5, 6, 7, 8)])
        axes = rows[:3]
        if not np.allclose(axes @ axes.T, np.eye(3), atol=1e-6):
            raise f.fail(f"rows 1-3 of coordinate system {label}'s matrix are not orthonormal axes", 5)
        systems[label] = CoordinateSystem(label, SYSTEM_TYPES[kind], tuple(rows[3] * scale),
                                          tuple(map(tuple, axes)), name)


def _resolve18(file: str, defined: dict[int, tuple[int, str, np.ndarray, int]],
               systems: dict[int, CoordinateSystem]) -> None:
    """Dataset 18 systems in global terms, each after its reference system."""
    def resolve(number: int, chain: tuple[int, ...]) -> CoordinateSystem:
        if number == 0:
            return CoordinateSystem(0)
        if number in systems:
            return systems[number]
        if number not in defined or number in chain:
            raise UserError(f"coordinate system {number} is {'circular' if number in chain else 'not defined'}",
                            field=f"{file} dataset 18")
        kind, name, points, reference = defined[number]
        ref = resolve(reference, chain + (number,))
        origin, x_point, xz_point = ref.to_global(points)
        axes = _axes(origin, x_point, xz_point)
        if axes is None:
            raise UserError(f"coordinate system {number}: origin, +x point and +xz point are collinear",
                            field=f"{file} dataset 18 record 3")
        systems[number] = CoordinateSystem(number, SYSTEM_TYPES[kind], tuple(origin), tuple(map(tuple, axes)), name)
        return systems[number]

    for number in defined:
        resolve(number, ())


def read_geometry_datasets(file: str, datasets: list[Dataset], unit_factor: float | None = None) -> Geometry:
    """The geometry of one UFF file's datasets (others are ignored);
    ``unit_factor``: m per file length unit when the file has no dataset 164
    (default 1: metres)."""
    scale = length_factor(file, datasets) or unit_factor or 1.0
    geometry = Geometry(source=file)
    raw: dict[int, tuple[int, int, list[float], str]] = {}
    defined: dict[int, tuple[int, str, np.ndarray, int]] = {}
    for d in datasets:
        f = _Fields(file, d)
        if d.kind in (15, 2411):
            _nodes(f, raw)
        elif d.kind == 82:
            _line(f, geometry)
        elif d.kind == 2412:
            _elements(f, geometry)
        elif d.kind == 18:
            _systems18(f, scale, defined)
        elif d.kind == 2420:
            _systems2420(f, scale, geometry.systems)
    _resolve18(file, defined, geometry.systems)
    for label, (system, displacement, xyz, where) in raw.items():
        if system and system not in geometry.systems:
            raise UserError(f"node {label} is given in coordinate system {system}, which the file does not define",
                            field=where)
        frame = geometry.systems.get(system, CoordinateSystem(0))
        lengths = {"cartesian": (1, 1, 1), "cylindrical": (1, 0, 1), "spherical": (1, 0, 0)}[frame.kind]
        local = np.array([v * scale if is_length else v for v, is_length in zip(xyz, lengths)])
        geometry.nodes[label] = frame.to_global(local)[0]
        if displacement:
            if displacement not in geometry.systems:
                raise UserError(f"node {label}'s displacement coordinate system {displacement} is not defined",
                                field=where)
            geometry.displacement_systems[label] = displacement
    known = set(geometry.nodes)
    for kind, parts in (("trace line", geometry.lines), ("element", geometry.elements)):
        for part in parts:
            unknown = sorted(set(part["nodes"]) - known)
            if unknown and known:
                raise UserError(f"{kind} {part['id']} names nodes {unknown[:5]} that no dataset 15/2411 defines",
                                field=file)
    return geometry
