"""Finite-element structures, affine in their element parameters.

``M(p) = sum_j p_j dM_j`` and likewise ``C`` and ``K``: every element parameter
is one entry of the parameter vector ``p`` and owns one sparse derivative
matrix over the free DOF. Rayleigh damping ``alpha M + beta K`` may be added
on top of the element damping.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from .analysis import Modes, modes
from .elements import KINDS, ElementType
from .errors import ModelError
from .statespace import StateSpace

Dof = tuple[int, str]  # (node id, direction)

SUPPORTS: dict[str, tuple[str, ...]] = {
    "free": (),
    "clamped": ("w", "theta", "x", "y", "z"),
    "simply-supported": ("w", "x", "y", "z"),
    "pinned": ("w", "x", "y", "z"),
}


@dataclass(frozen=True)
class Element:
    """An element instance: its type, node ids, parameter values and, for
    lumped elements, the DOF direction they act in."""

    type: type[ElementType]
    nodes: tuple[int, ...]
    values: dict[str, float]
    direction: str | None = None

    def dofs(self) -> list[Dof]:
        dirs = self.type.directions or (self.direction,)
        return [(n, d) for n in self.nodes for d in dirs]


@dataclass(frozen=True)
class Parameter:
    """One entry of the parameter vector: element index (0-based), the element
    parameter name (``m``, ``k``, ...), its kind and SI unit."""

    element: int
    name: str
    kind: str
    unit: str

    @property
    def label(self) -> str:
        return f"{self.kind}[{self.element + 1}]"


@dataclass
class Structure:
    """A finite-element structure.

    ``nodes`` maps node id to coordinates (m); ``supports`` maps node id to a
    support name of :data:`SUPPORTS` or an explicit tuple of fixed directions;
    ``unknown`` lists the parameter kinds an identifier should estimate.
    """

    name: str
    nodes: dict[int, np.ndarray]
    elements: list[Element]
    supports: dict[int, str | tuple[str, ...]] = field(default_factory=dict)
    rayleigh: tuple[float, float] = (0.0, 0.0)
    unknown: tuple[str, ...] = ("mass", "stiffness")

    def __post_init__(self) -> None:
        self._check()

    # ---- description -------------------------------------------------
    def _check(self) -> None:
        for i, el in enumerate(self.elements):
            where = f"elements[{i + 1}]"
            if len(el.nodes) not in el.type.node_counts:
                raise ModelError(f"{el.type.name} takes {el.type.node_counts} nodes, got {len(el.nodes)}",
                                 field=f"{where}.nodes")
            for n in el.nodes:
                if n not in self.nodes:
                    raise ModelError(f"node {n} is referenced but not defined", field=f"{where}.nodes")
            if el.type.directions is None and not el.direction:
                raise ModelError("lumped element needs a direction", field=f"{where}.dir")
            for spec in el.type.parameters:
                value = el.values.get(spec.name, spec.default)
                if value is None:
                    raise ModelError(f"missing parameter {spec.name} ({spec.unit})", field=f"{where}.{spec.name}")
                if not np.isfinite(value) or value < 0 or (spec.positive and value == 0):
                    bound = "positive" if spec.positive else "non-negative"
                    raise ModelError(f"{spec.kind} parameter must be {bound}, got {value}",
                                     field=f"{where}.{spec.name}")
        for node, support in self.supports.items():
            if node not in self.nodes:
                raise ModelError(f"node {node} is referenced but not defined", field="supports")
            if isinstance(support, str) and support not in SUPPORTS:
                raise ModelError(f"unknown support {support!r}; known: {', '.join(SUPPORTS)}",
                                 field=f"supports[{node}]")
        bad = set(self.unknown) - set(KINDS)
        if bad:
            raise ModelError(f"unknown parameter kinds {sorted(bad)}; known: {KINDS}", field="unknown")

    @cached_property
    def all_dofs(self) -> list[Dof]:
        """Every DOF the elements touch, ordered by node then first appearance."""
        seen: dict[Dof, None] = {}
        for el in self.elements:
            for d in el.dofs():
                seen.setdefault(d, None)
        rank: dict[str, int] = {}
        for _, direction in seen:
            rank.setdefault(direction, len(rank))
        return sorted(seen, key=lambda d: (d[0], rank[d[1]]))

    @cached_property
    def dofs(self) -> list[Dof]:
        """Free DOF labels ``(node, direction)``; the order of all matrices."""
        fixed = set()
        for node, support in self.supports.items():
            dirs = SUPPORTS[support] if isinstance(support, str) else support
            fixed.update((node, d) for d in dirs)
        return [d for d in self.all_dofs if d not in fixed]

    @property
    def n_dof(self) -> int:
        return len(self.dofs)

    def dof_index(self, node: int, direction: str) -> int:
        """Index of a free DOF; raises :class:`ModelError` naming it if absent."""
        try:
            return self._dof_lookup[(node, direction)]
        except KeyError:
            raise ModelError(f"no free DOF ({node}, {direction!r}) in {self.name}", field="dof") from None

    @cached_property
    def _dof_lookup(self) -> dict[Dof, int]:
        return {d: i for i, d in enumerate(self.dofs)}

    @cached_property
    def parameters(self) -> list[Parameter]:
        """Parameter vector layout: per element, its parameters in declared order."""
        return [Parameter(i, spec.name, spec.kind, spec.unit)
                for i, el in enumerate(self.elements) for spec in el.type.parameters]

    @property
    def values(self) -> np.ndarray:
        """Current parameter vector, shape (n_par,)."""
        return np.array([self.elements[p.element].values.get(p.name, self._default(p))
                         for p in self.parameters], dtype=float)

    def _default(self, p: Parameter) -> float:
        return next(s.default for s in self.elements[p.element].type.parameters if s.name == p.name)

    def kind_mask(self, kinds: tuple[str, ...] | None = None) -> np.ndarray:
        """Boolean mask over parameters whose kind is in ``kinds`` (default: unknown)."""
        kinds = self.unknown if kinds is None else kinds
        return np.array([p.kind in kinds for p in self.parameters])

    # ---- assembly ----------------------------------------------------
    @cached_property
    def triplets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Assembly in COO form: ``(param, row, col, value)`` arrays such that
        the matrix of kind k is ``sum value * p[param]`` at ``(row, col)`` over
        the entries whose parameter has kind k."""
        index = self._dof_lookup
        par, rows, cols, vals = [], [], [], []
        j = 0
        for el in self.elements:
            coords = np.array([self.nodes[n] for n in el.nodes], dtype=float)
            pats = el.type.patterns(coords)
            edofs = np.array([index.get(d, -1) for d in el.dofs()])
            keep = np.flatnonzero(edofs >= 0)
            r, c = np.meshgrid(edofs[keep], edofs[keep], indexing="ij")
            for spec in el.type.parameters:
                block = pats[spec.name][np.ix_(keep, keep)]
                par.append(np.full(block.size, j))
                rows.append(r.ravel())
                cols.append(c.ravel())
                vals.append(block.ravel())
                j += 1
        cat = (lambda a, t: np.concatenate(a).astype(t) if a else np.zeros(0, t))
        return cat(par, int), cat(rows, int), cat(cols, int), cat(vals, float)

    @cached_property
    def derivatives(self) -> list[sp.csr_matrix]:
        """``d(M|C|K)/dp_j`` over the free DOF, one sparse (n, n) matrix per parameter."""
        par, rows, cols, vals = self.triplets
        n = self.n_dof
        order = np.argsort(par, kind="stable")
        bounds = np.searchsorted(par[order], np.arange(len(self.parameters) + 1))
        return [sp.csr_matrix((vals[order[a:b]], (rows[order[a:b]], cols[order[a:b]])), shape=(n, n))
                for a, b in zip(bounds[:-1], bounds[1:])]

    @cached_property
    def _kinds(self) -> np.ndarray:
        return np.array([p.kind for p in self.parameters])

    def _assemble(self, kind: str, p: np.ndarray | None) -> sp.csr_matrix:
        p = self.values if p is None else np.asarray(p, dtype=float)
        if p.shape != (len(self.parameters),):
            raise ModelError(f"parameter vector has length {p.size}, expected {len(self.parameters)}",
                             field="parameters")
        par, rows, cols, vals = self.triplets
        weight = np.where(self._kinds == kind, p, 0.0)[par]
        return sp.csr_matrix((weight * vals, (rows, cols)), shape=(self.n_dof, self.n_dof))

    def mass(self, p: np.ndarray | None = None) -> sp.csr_matrix:
        """Mass matrix M(p), sparse (n, n), kg."""
        return self._assemble("mass", p)

    def stiffness(self, p: np.ndarray | None = None) -> sp.csr_matrix:
        """Stiffness matrix K(p), sparse (n, n), N/m."""
        return self._assemble("stiffness", p)

    def damping(self, p: np.ndarray | None = None) -> sp.csr_matrix:
        """Damping matrix C(p) plus Rayleigh ``alpha M + beta K``, sparse (n, n), N s/m."""
        alpha, beta = self.rayleigh
        c = self._assemble("damping", p)
        if alpha or beta:
            c = c + alpha * self.mass(p) + beta * self.stiffness(p)
        return c

    def with_values(self, p: np.ndarray) -> "Structure":
        """A copy with the parameter vector replaced (validated)."""
        p = np.asarray(p, dtype=float)
        if p.shape != (len(self.parameters),):
            raise ModelError(f"parameter vector has length {p.size}, expected {len(self.parameters)}",
                             field="parameters")
        new_values = [dict(el.values) for el in self.elements]
        for value, par in zip(p, self.parameters):
            new_values[par.element][par.name] = float(value)
        elements = [Element(el.type, el.nodes, v, el.direction) for el, v in zip(self.elements, new_values)]
        return Structure(self.name, self.nodes, elements, self.supports, self.rayleigh, self.unknown)

    def modes(self, count: int | None = None) -> "Modes":
        """Lowest ``count`` modes (dense or sparse shift-invert, see :func:`models.analysis.modes`)."""
        return modes(self.mass(), self.stiffness(), count)

    def state_space(self) -> StateSpace:
        """First-order form over the free DOF, state ``[u, v]``."""
        return StateSpace.second_order(self.mass().toarray(), self.damping().toarray(),
                                       self.stiffness().toarray())
