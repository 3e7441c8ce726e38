"""Exact linear second-order dynamics, numpy and scipy only.

This module is bundled verbatim into every structure FMU (under a unique
module name) by `structbench.fmus`, so it must not import structbench.
:mod:`structbench.models.statespace`
builds its matrices with the same functions, so the FMU and the reference
model share one definition of the discretisation.

System: ``M qdd + C qd + K q = Phi^T f``, response ``u = Phi q`` at the DOF,
state ``x = [q, qd]`` (shape (2 r,)), force ``f`` (shape (n,)) held over a step.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.linalg as la

Matrices = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def first_order(mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray,
                shapes: np.ndarray | None = None) -> Matrices:
    """``(A, B, Cd, Cv, Ca, Da)``: ``xdot = A x + B f``, displacement ``Cd x``,
    velocity ``Cv x``, acceleration ``Ca x + Da f``; shapes (r, r) in, ``shapes``
    (n, r) (identity when None). ``mass`` must be symmetric positive definite."""
    mass, damping, stiffness = (np.asarray(a, dtype=float) for a in (mass, damping, stiffness))
    r = mass.shape[0]
    phi = np.eye(r) if shapes is None else np.asarray(shapes, dtype=float)
    minv_k = la.solve(mass, stiffness, assume_a="pos")
    minv_c = la.solve(mass, damping, assume_a="pos")
    minv_in = la.solve(mass, phi.T, assume_a="pos")
    A = np.block([[np.zeros((r, r)), np.eye(r)], [-minv_k, -minv_c]])
    B = np.vstack([np.zeros_like(minv_in), minv_in])
    Cd = np.hstack([phi, np.zeros_like(phi)])
    Cv = np.hstack([np.zeros_like(phi), phi])
    return A, B, Cd, Cv, phi @ A[r:], phi @ minv_in


def zoh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold ``(Ad, Bd)`` for step ``dt`` (s): the matrix
    exponential of the augmented matrix ``[[A, B], [0, 0]] dt``."""
    nx, nu = B.shape
    aug = np.zeros((nx + nu, nx + nu))
    aug[:nx, :nx] = A * dt
    aug[:nx, nx:] = B * dt
    e = la.expm(aug)
    return e[:nx, :nx], e[:nx, nx:]


def assemble(n: int, par: np.ndarray, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray,
             kinds: Sequence[str], p: np.ndarray, rayleigh: Sequence[float] = (0.0, 0.0)
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dense ``(M, C, K)`` of shape (n, n) from COO triplets: entry ``i`` adds
    ``vals[i] p[par[i]]`` at ``(rows[i], cols[i])`` of the matrix of
    ``kinds[par[i]]`` (``mass``, ``damping`` or ``stiffness``); Rayleigh
    ``alpha M + beta K`` is added to C."""
    kind_of = np.asarray(kinds)[par]
    weighted = vals * np.asarray(p, dtype=float)[par]
    out = []
    for kind in ("mass", "damping", "stiffness"):
        m = np.zeros((n, n))
        sel = kind_of == kind
        np.add.at(m, (rows[sel], cols[sel]), weighted[sel])
        out.append(m)
    mass, damping, stiffness = out
    alpha, beta = rayleigh
    return mass, damping + alpha * mass + beta * stiffness, stiffness


class Propagator:
    """Exact ZOH stepping and sampling of one second-order system.

    ``outputs(x, f)`` gives ``[u, v, a]`` (shape (3 n,)) with the acceleration
    from the current state and the current force; ``step(x, f, dt)`` advances
    the state by ``dt`` s with ``f`` held, the ZOH matrices cached per ``dt``.
    """

    def __init__(self, mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray,
                 shapes: np.ndarray | None = None):
        self.A, self.B, cd, cv, ca, da = first_order(mass, damping, stiffness, shapes)
        n = da.shape[0]
        self.C_out = np.vstack([cd, cv, ca])
        self.D_acc = da
        self._acc = slice(2 * n, 3 * n)
        self._zoh: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    @property
    def n_state(self) -> int:
        return self.A.shape[0]

    def outputs(self, x: np.ndarray, f: np.ndarray, out: np.ndarray) -> None:
        """Write ``[u, v, a]`` into ``out`` (shape (3 n,))."""
        np.dot(self.C_out, x, out=out)
        out[self._acc] += self.D_acc @ f

    def step(self, x: np.ndarray, f: np.ndarray, dt: float) -> np.ndarray:
        """State after ``dt`` s under the held force ``f``."""
        mats = self._zoh.get(dt)
        if mats is None:
            mats = self._zoh[dt] = zoh(self.A, self.B, dt)
        return mats[0] @ x + mats[1] @ f
