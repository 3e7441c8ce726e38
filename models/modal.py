"""Modal (continuous) models: natural frequencies, mode shapes as functions of
position, modal damping; the response is simulated exactly mode by mode."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from .analysis import Modes
from .errors import ModelError
from .statespace import StateSpace

ShapeFunction = Callable[[np.ndarray], np.ndarray]  # x (m), shape (n,) -> (n, n_modes)


@dataclass
class ModalModel:
    """A distributed-parameter structure by its modes.

    ``omega`` (rad/s, shape (r,)), ``zeta`` (modal damping ratios, (r,)),
    ``shape_function`` giving mass-normalised shapes at positions (m), and the
    ``points`` (m, shape (n_pts,)) where forces act and sensors sit: point i
    is DOF ``(i + 1, "w")``.
    """

    name: str
    omega: np.ndarray
    shape_function: ShapeFunction
    points: np.ndarray
    zeta: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        self.omega = np.asarray(self.omega, dtype=float)
        self.points = np.asarray(self.points, dtype=float)
        self.zeta = np.zeros_like(self.omega) if self.zeta is None else np.asarray(self.zeta, dtype=float)
        if np.any(self.omega < 0) or not np.all(np.isfinite(self.omega)):
            raise ModelError("natural frequencies must be finite and non-negative", field="omega")
        if self.zeta.shape != self.omega.shape or np.any(self.zeta < 0):
            raise ModelError("need one non-negative damping ratio per mode", field="zeta")

    @property
    def n_modes(self) -> int:
        return self.omega.size

    @cached_property
    def dofs(self) -> list[tuple[int, str]]:
        return [(i + 1, "w") for i in range(self.points.size)]

    @property
    def n_dof(self) -> int:
        return self.points.size

    @property
    def nodes(self) -> dict[int, np.ndarray]:
        return {i + 1: np.array([x]) for i, x in enumerate(self.points)}

    def dof_index(self, node: int, direction: str) -> int:
        if direction != "w" or not 1 <= node <= self.points.size:
            raise ModelError(f"no DOF ({node}, {direction!r}) in {self.name}", field="dof")
        return node - 1

    @cached_property
    def shapes(self) -> np.ndarray:
        """Mode shapes at the points, shape (n_pts, r)."""
        return self.shape_function(self.points)

    def modes(self, count: int | None = None) -> Modes:
        order = np.argsort(self.omega)[:count]
        return Modes(lam=self.omega[order] ** 2, shapes=self.shapes[:, order])

    def state_space(self) -> StateSpace:
        """Modal coordinates ``q``: ``qdd + 2 zeta omega qd + omega^2 q = Phi^T f``."""
        r = self.n_modes
        return StateSpace.second_order(np.eye(r), np.diag(2 * self.zeta * self.omega),
                                       np.diag(self.omega**2), self.shapes)

    def free_response(self, t: np.ndarray, q0: np.ndarray, qd0: np.ndarray,
                      x: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form displacement and velocity at positions ``x`` (default:
        the points), shapes (n_t, n_x), from modal initial conditions."""
        t = np.asarray(t, dtype=float)[:, None]
        w, z = self.omega, self.zeta
        wd = w * np.sqrt(1 - z**2)
        decay = np.exp(-z * w * t)
        c, s = np.cos(wd * t), np.sin(wd * t)
        b = (qd0 + z * w * q0) / wd
        q = decay * (q0 * c + b * s)
        qd = decay * ((-z * w * q0 + wd * b) * c + (-z * w * b - wd * q0) * s)
        phi = self.shapes if x is None else self.shape_function(np.asarray(x, dtype=float))
        return q @ phi.T, qd @ phi.T


def simply_supported_beam_shapes(length: float, n_modes: int, mass_per_length: float = 1.0) -> ShapeFunction:
    """Mass-normalised shapes ``sqrt(2/(m L)) sin(r pi x / L)``, r = 1..n_modes."""
    r = np.arange(1, n_modes + 1)

    def phi(x: np.ndarray) -> np.ndarray:
        return np.sqrt(2.0 / (mass_per_length * length)) * np.sin(np.outer(np.atleast_1d(x), r) * np.pi / length)

    return phi
