"""Structures and campaigns the plan benchmarks write (not in the repository's library).

``ch5_fe_beam``: the chapter 5 beam (m = 1 kg/m, EI = 1 N m^2, L = 10 m,
simply supported) as 25 equal beam elements (26 nodes: 24 transverse and 26
rotational DOF, 50 in all) with Rayleigh damping ``C = a M + b K``.
``frame``: a 4-storey shear frame with a tuned-mass appendage (5 DOF), a
structure not in the repository.
"""
from __future__ import annotations

from pathlib import Path


def ch5_fe_beam(path: Path, elements: int = 25, rayleigh: tuple[float, float] = (0.004, 0.004)) -> Path:
    h = 10.0 / elements
    lines = [f'name = "ch5-beam-fe{elements}"', 'unknown = ["mass", "stiffness"]',
             f"rayleigh = [{rayleigh[0]}, {rayleigh[1]}]"]
    lines += [f"[[nodes]]\nid = {i + 1}\nx = {i * h!r}" for i in range(elements + 1)]
    lines += [f'[[elements]]\ntype = "beam"\nnodes = [{i + 1}, {i + 2}]\nm = 1.0\nk = {1.0 / h**3!r}'
              for i in range(elements)]
    lines += [f'[[supports]]\nnode = {n}\nfix = ["w"]' for n in (1, elements + 1)]
    path.write_text("\n".join(lines) + "\n")
    return path


def frame(path: Path) -> Path:
    """Storey masses 3, 2.5, 2.5, 2 kg; springs 900, 800, 700, 600 N/m; a 0.4 kg
    appendage on the top floor through a 60 N/m spring (node 5)."""
    masses, springs = [3.0, 2.5, 2.5, 2.0, 0.4], [(0, 1, 900.0), (1, 2, 800.0), (2, 3, 700.0), (3, 4, 600.0),
                                                   (4, 5, 60.0)]
    lines = ['name = "plan-frame-appendage"', 'unknown = ["mass", "stiffness"]',
             "[[nodes]]\nid = 0\nz = 0.0", '[[supports]]\nnode = 0\nfix = ["x"]']
    lines += [f"[[nodes]]\nid = {i + 1}\nz = {3.0 * (i + 1)}" for i in range(len(masses))]
    lines += [f'[[elements]]\ntype = "mass"\nnodes = [{i + 1}]\ndir = "x"\nm = {m}' for i, m in enumerate(masses)]
    lines += [f'[[elements]]\ntype = "spring"\nnodes = [{a}, {b}]\ndir = "x"\nk = {k}' for a, b, k in springs]
    path.write_text("\n".join(lines) + "\n")
    return path
