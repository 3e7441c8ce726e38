"""The dissertation's structures, by name (see shared/reference/dissertation-cases.md)."""
from __future__ import annotations

from typing import Callable

import numpy as np

from .elements import Beam, Tri3Membrane
from .errors import ModelError
from .modal import ModalModel, simply_supported_beam_shapes
from .structure import Element, Structure

Model = Structure | ModalModel

CH3_MASS = [8.4, 1.6, 2.3, 4.8, 6.3, 5.2, 7.1, 4.2, 6.3, 1.6, 1.1, 2.4, 3.5, 4.6, 7.3]
CH3_STIFFNESS = [3.3, 2.3, 1.2, 1.3, 3.3, 4.2, 1.8, 1.4, 4.1, 3.6, 5.2, 3.4, 6.6, 2.5, 5.3]

# Table 4.1: (mass, stiffness) per element, actual and postulated
CH4 = {
    "case1": {"actual": ([0.92, 1.28, 1.17, 0.63, 1.11, 0.98], [1.38, 0.68, 1.24, 0.56, 0.76, 1.12]),
              "postulated": ([0.90, 1.15, 1.20, 0.50, 1.20, 0.90], [1.30, 0.60, 1.00, 0.50, 0.90, 1.00])},
    "case2": {"actual": ([0.899, 1.050, 1.149, 0.452, 1.000, 0.901], [1.042, 0.748, 1.198, 0.552, 1.101, 0.901]),
              "postulated": ([0.86, 1.01, 1.13, 0.44, 0.98, 0.90], [1.00, 0.71, 1.17, 0.54, 1.08, 0.90])},
}


def beam(name: str, mass: list[float], stiffness: list[float], length: float,
         supports: dict[int, str] | None = None, damping: list[float] | None = None,
         unknown: tuple[str, ...] = ("mass", "stiffness")) -> Structure:
    """Beam of equal elements along x; nodes 1..N+1 from x = 0.

    ``mass`` kg/m, ``stiffness`` k = EI/h^3 N/m, ``damping`` N s/m per element.
    """
    n = len(mass)
    if len(stiffness) != n or (damping is not None and len(damping) != n):
        raise ModelError(f"need {n} values per parameter list", field="parameters")
    x = np.linspace(0.0, length, n + 1)
    nodes = {i + 1: np.array([xi, 0.0]) for i, xi in enumerate(x)}
    damping = damping or [0.0] * n
    elements = [Element(Beam, (j + 1, j + 2), {"m": mass[j], "c": damping[j], "k": stiffness[j]})
                for j in range(n)]
    return Structure(name, nodes, elements, supports or {}, unknown=unknown)


def ch3_free_free_beam() -> Structure:
    """Chapter 3: free-free nonuniform beam, 15 elements of 1 m (Table 3.1)."""
    return beam("ch3-free-free-beam", CH3_MASS, CH3_STIFFNESS, 15.0)


def ch3_damped_beam() -> Structure:
    """Chapter 3 beam with element damping c_j = 0.05 k_j (N s/m), all unknown."""
    return beam("ch3-damped-beam", CH3_MASS, CH3_STIFFNESS, 15.0,
                damping=[0.05 * k for k in CH3_STIFFNESS], unknown=("mass", "damping", "stiffness"))


def ch4_cantilever(case: str, which: str = "actual") -> Structure:
    """Chapter 4 cantilever, 6 elements of 1 m clamped at x = 0 (Table 4.1)."""
    mass, stiffness = CH4[case][which]
    suffix = "" if which == "actual" else "-postulated"
    return beam(f"ch4-cantilever-{case}{suffix}", mass, stiffness, 6.0, supports={1: "clamped"})


def ch5_simply_supported_beam(n_modes: int = 15) -> ModalModel:
    """Chapter 5 uniform simply supported beam (m = 1 kg/m, EI = 1 N m^2,
    L = 10 m) by its modes ``omega_r = (r pi / L)^2``; points at x = r L / 11."""
    length = 10.0
    r = np.arange(1, n_modes + 1)
    return ModalModel("ch5-simply-supported-beam", (r * np.pi / length) ** 2,
                      simply_supported_beam_shapes(length, n_modes), r[:10] * length / 11.0)


def ch5_simply_supported_fe(n_elements: int = 20) -> Structure:
    """FE variant of the chapter 5 beam: k = EI/h^3 with h = L/N."""
    length, ei = 10.0, 1.0
    h = length / n_elements
    return beam(f"ch5-simply-supported-beam-fe{n_elements}", [1.0] * n_elements,
                [ei / h**3] * n_elements, length,
                supports={1: "simply-supported", n_elements + 1: "simply-supported"})


def ch5_membrane(cells: int = 3, side: float = 1.0) -> Structure:
    """Chapter 5 free-free square membrane: (cells+1)^2 nodes numbered row by
    row from a corner, each square cell split by parallel diagonals;
    tension 1 N/m, density 1 kg/m^2."""
    nx = cells + 1
    nodes = {j * nx + i + 1: np.array([i * side, j * side]) for j in range(nx) for i in range(nx)}
    elements = []
    for j in range(cells):
        for i in range(cells):
            a = j * nx + i + 1
            b, c, d = a + 1, a + nx + 1, a + nx
            for tri in ((a, b, c), (a, c, d)):
                elements.append(Element(Tri3Membrane, tri, {"rho": 1.0, "T": 1.0}))
    return Structure("ch5-membrane", nodes, elements)


STRUCTURES: dict[str, Callable[[], Model]] = {
    "ch3-free-free-beam": ch3_free_free_beam,
    "ch3-damped-beam": ch3_damped_beam,
    "ch4-cantilever-case1": lambda: ch4_cantilever("case1"),
    "ch4-cantilever-case1-postulated": lambda: ch4_cantilever("case1", "postulated"),
    "ch4-cantilever-case2": lambda: ch4_cantilever("case2"),
    "ch4-cantilever-case2-postulated": lambda: ch4_cantilever("case2", "postulated"),
    "ch5-simply-supported-beam": ch5_simply_supported_beam,
    "ch5-simply-supported-beam-fe": ch5_simply_supported_fe,
    "ch5-membrane": ch5_membrane,
}

DISSERTATION = ["ch3-free-free-beam", "ch4-cantilever-case1", "ch4-cantilever-case2",
                "ch5-simply-supported-beam", "ch5-membrane"]
