"""Element library: each element type declares its nodes, DOF directions and
parameters, and gives the unit matrices ("patterns") that one parameter scales.

An element's contribution is ``sum_kind p_kind * pattern_kind``; the generic
assembler in :mod:`models.structure` scatters the patterns to the global DOF.
Units are SI: lengths in m, masses in kg, forces in N.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .errors import ModelError

KINDS = ("mass", "damping", "stiffness")


@dataclass(frozen=True)
class ParameterSpec:
    """One scalar parameter of an element type.

    ``kind`` says which global matrix it scales; ``unit`` is its SI unit;
    ``positive`` demands a value > 0 (else >= 0).
    """

    name: str
    kind: str
    unit: str
    positive: bool
    default: float | None = None


class ElementType:
    """Base of the declarative element classes.

    Subclasses set ``name``, ``n_nodes`` (or ``node_counts``), ``directions``
    and ``parameters`` and implement :meth:`patterns`.
    """

    name: ClassVar[str]
    node_counts: ClassVar[tuple[int, ...]]
    directions: ClassVar[tuple[str, ...] | None]  # None: given per element ("dir")
    parameters: ClassVar[tuple[ParameterSpec, ...]]

    @classmethod
    def patterns(cls, coords: np.ndarray) -> dict[str, np.ndarray]:
        """Unit matrices per parameter name, shape (n_edof, n_edof).

        ``coords`` has shape (n_nodes, n_space) in m.
        """
        raise NotImplementedError


def _hermite_stiffness(h: float) -> np.ndarray:
    return np.array([[12, 6 * h, -12, 6 * h],
                     [6 * h, 4 * h**2, -6 * h, 2 * h**2],
                     [-12, -6 * h, 12, -6 * h],
                     [6 * h, 2 * h**2, -6 * h, 4 * h**2]], dtype=float)


def _length(coords: np.ndarray) -> float:
    h = float(np.linalg.norm(coords[1] - coords[0]))
    if h <= 0.0:
        raise ModelError("beam element has zero length (its two nodes coincide)")
    return h


class Beam(ElementType):
    """Euler-Bernoulli beam, Hermite cubics; DOF ``[w1, theta1, w2, theta2]``.

    ``m``: mass per unit length (kg/m); ``k = EI/h^3`` (N/m);
    ``c``: damping with the stiffness pattern (N s/m), dissertation eq. 2.12b.
    """

    name = "beam"
    node_counts = (2,)
    directions = ("w", "theta")
    parameters = (ParameterSpec("m", "mass", "kg/m", True),
                  ParameterSpec("c", "damping", "N s/m", False, 0.0),
                  ParameterSpec("k", "stiffness", "N/m", True))

    @classmethod
    def patterns(cls, coords: np.ndarray) -> dict[str, np.ndarray]:
        h = _length(coords)
        mass = h / 420.0 * np.array([[156, 22 * h, 54, -13 * h],
                                     [22 * h, 4 * h**2, 13 * h, -3 * h**2],
                                     [54, 13 * h, 156, -22 * h],
                                     [-13 * h, -3 * h**2, -22 * h, 4 * h**2]], dtype=float)
        stiffness = _hermite_stiffness(h)
        return {"m": mass, "c": stiffness, "k": stiffness}


class Tri3Membrane(ElementType):
    """Linear triangle of a membrane under uniform tension; DOF ``w`` per node.

    ``rho``: areal density (kg/m^2); ``T``: tension (N/m); ``c``: damping with
    the stiffness pattern (N s/m per N/m of tension). Consistent mass.
    """

    name = "tri3"
    node_counts = (3,)
    directions = ("w",)
    parameters = (ParameterSpec("rho", "mass", "kg/m^2", True),
                  ParameterSpec("c", "damping", "N s/m", False, 0.0),
                  ParameterSpec("T", "stiffness", "N/m", True))

    @classmethod
    def patterns(cls, coords: np.ndarray) -> dict[str, np.ndarray]:
        xy = np.asarray(coords, dtype=float)[:, :2]
        edge = np.array([xy[1] - xy[0], xy[2] - xy[0]])
        area = 0.5 * abs(np.linalg.det(edge))
        if area <= 0.0:
            raise ModelError("tri3 element has zero area (its nodes are collinear)")
        # gradients of the three linear shape functions, shape (3, 2)
        grad = np.linalg.solve(edge, np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])).T
        stiffness = area * grad @ grad.T
        mass = area / 12.0 * (np.ones((3, 3)) + np.eye(3))
        return {"rho": mass, "c": stiffness, "T": stiffness}


def _two_point(n_nodes: int) -> np.ndarray:
    """Pattern of a two-terminal element; one node means the other is ground."""
    if n_nodes == 1:
        return np.array([[1.0]])
    return np.array([[1.0, -1.0], [-1.0, 1.0]])


class PointMass(ElementType):
    """Lumped mass on one DOF (direction given per element); ``m`` in kg
    (kg m^2 on a rotation)."""

    name = "mass"
    node_counts = (1,)
    directions = None
    parameters = (ParameterSpec("m", "mass", "kg", True),)

    @classmethod
    def patterns(cls, coords: np.ndarray) -> dict[str, np.ndarray]:
        return {"m": np.array([[1.0]])}


class Spring(ElementType):
    """Linear spring between two DOF of one direction, or one DOF and ground
    (one node); ``k`` in N/m (N m/rad on a rotation)."""

    name = "spring"
    node_counts = (1, 2)
    directions = None
    parameters = (ParameterSpec("k", "stiffness", "N/m", True),)

    @classmethod
    def patterns(cls, coords: np.ndarray) -> dict[str, np.ndarray]:
        return {"k": _two_point(len(coords))}


class Dashpot(ElementType):
    """Viscous dashpot between two DOF, or one DOF and ground; ``c`` in N s/m."""

    name = "dashpot"
    node_counts = (1, 2)
    directions = None
    parameters = (ParameterSpec("c", "damping", "N s/m", False),)

    @classmethod
    def patterns(cls, coords: np.ndarray) -> dict[str, np.ndarray]:
        return {"c": _two_point(len(coords))}


ELEMENT_TYPES: dict[str, type[ElementType]] = {
    cls.name: cls for cls in (Beam, Tri3Membrane, PointMass, Spring, Dashpot)
}


def element_type(name: str) -> type[ElementType]:
    """Look an element type up by name; unknown names raise :class:`ModelError`."""
    try:
        return ELEMENT_TYPES[name]
    except KeyError:
        raise ModelError(f"unknown element type {name!r}; known: {', '.join(ELEMENT_TYPES)}",
                         field="type") from None
