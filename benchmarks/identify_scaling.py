"""Chapter 3 least squares on nonuniform free-free beams of 15, 150 and 1,500
elements: time and peak memory of assembling and solving the equations.

The response from rest to forces 0.1 cos(omega_i t) N at every node (a single
shaker would leave the far elements of a 1,500 m beam at rest within 4 s) is
exact modal superposition (continuous forces, all modes) at t_k = 0.5 k s,
k = 1..8; every nodal displacement, velocity and acceleration is "measured". Only the
identification (:func:`identifier.least_squares.ols.solve`, the dissertation's estimator) is timed; peak memory
is what tracemalloc sees allocated during it.

    python benchmarks/identify_scaling.py [N ...]
"""
from __future__ import annotations

import sys
import time
import tracemalloc

import numpy as np
import scipy.linalg as la

from structbench.identifier.least_squares import Motion, solve
from structbench.identifier.least_squares.regression import DENSE_COLUMNS
from structbench.models.library import beam

SAMPLES = 0.5 * np.arange(1, 9)


def nonuniform_beam(n: int):
    """``n`` elements of 1 m, masses 1-8.5 kg/m and stiffnesses 1-6.6 N/m (seeded)."""
    rng = np.random.default_rng(n)
    return beam(f"free-free-{n}", list(np.round(rng.uniform(1.0, 8.5, n), 1)),
                list(np.round(rng.uniform(1.0, 6.6, n), 1)), float(n))


def exact_motion(model) -> Motion:
    """Modal superposition from rest under ``0.1 cos(omega_i t)`` N at every
    node's ``w`` (``omega_i`` spread over 0.5-1.5 rad/s, so that every element
    deforms within the 4 s), closed form per mode and force."""
    lam, phi = la.eigh(model.stiffness().toarray(), model.mass().toarray())
    lam = np.maximum(lam, 0.0)
    w = np.sqrt(lam)
    rows = np.array([model.dof_index(n, "w") for n in model.nodes])
    omega = np.linspace(0.5, 1.5, rows.size) + 1e-3 * np.sqrt(2)
    g = 0.1 * phi[rows]  # (forces, modes): modal force amplitudes
    t = SAMPLES[:, None, None]
    den = lam[None, :] - omega[:, None] ** 2  # (forces, modes)
    q = np.sum(g / den * (np.cos(omega[:, None] * t) - np.cos(w * t)), axis=1)
    qd = np.sum(g / den * (-omega[:, None] * np.sin(omega[:, None] * t) + w * np.sin(w * t)), axis=1)
    qdd = np.sum(g / den * (-omega[:, None] ** 2 * np.cos(omega[:, None] * t) + lam * np.cos(w * t)), axis=1)
    force = np.zeros((SAMPLES.size, model.n_dof))
    force[:, rows] = 0.1 * np.cos(np.outer(SAMPLES, omega))
    return Motion(SAMPLES, q @ phi.T, qd @ phi.T, qdd @ phi.T, force)


def run(n: int) -> str:
    model = nonuniform_beam(n)
    motion = exact_motion(model)
    tracemalloc.start()
    start = time.perf_counter()
    estimate = solve(model, motion)
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    truth = model.values[model.kind_mask()]
    error = np.max(np.abs(estimate.values / truth - 1))
    path = "dense SVD" if truth.size <= DENSE_COLUMNS else "sparse normal equations"
    return (f"{n:6d} {model.n_dof:6d} {truth.size:9d} {estimate.n_equations:10d} {seconds:9.3f} {peak:10.1f}"
            f" {error:12.1e}  {path}")


def main(argv: list[str]) -> None:
    sizes = [int(a) for a in argv] or [15, 150, 1500]
    print(f"{'elements':>6s} {'DOF':>6s} {'unknowns':>9s} {'equations':>10s} {'time s':>9s} {'peak MiB':>10s}"
          f" {'max rel err':>12s}  solver")
    for n in sizes:
        print(run(n), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
