"""Linear second-order systems in first-order form, with exact zero-order-hold
discretisation.

A :class:`StateSpace` has state ``x`` (n_x,), force input ``f`` (n_dof,) in N
(N m on rotations) and three outputs at the DOF: displacement ``Cd x``,
velocity ``Cv x`` and acceleration ``Ca x + Da f`` (SI units). For a
finite-element model ``x = [u, v]``; for a modal model ``x = [q, qdot]``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .dynamics import first_order, zoh


@dataclass
class StateSpace:
    """``xdot = A x + B f``; outputs as in the module docstring."""

    A: np.ndarray
    B: np.ndarray
    Cd: np.ndarray
    Cv: np.ndarray
    Ca: np.ndarray
    Da: np.ndarray
    _zoh: dict[float, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)

    @classmethod
    def second_order(cls, mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray,
                     shapes: np.ndarray | None = None) -> "StateSpace":
        """``M qdd + C qd + K q = shapes^T f``, physical response ``shapes q``.

        Without ``shapes`` the generalised coordinates are the DOF themselves.
        """
        return cls(*first_order(mass, damping, stiffness, shapes))

    @property
    def n_state(self) -> int:
        return self.A.shape[0]

    def discretize(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact ZOH matrices ``(Ad, Bd)`` for step ``dt`` (s), cached per step."""
        if dt not in self._zoh:
            self._zoh[dt] = zoh(self.A, self.B, dt)
        return self._zoh[dt]

    def simulate(self, force: np.ndarray, dt: float, x0: np.ndarray | None = None
                 ) -> dict[str, np.ndarray]:
        """Response to a force held constant over each step.

        ``force`` has shape (n_steps, n_dof): sample k acts on ``[k dt, (k+1) dt)``.
        Returns ``displacement``, ``velocity``, ``acceleration`` of shape
        (n_steps, n_dof) at ``t_k = k dt`` (acceleration with ``force[k]``)
        and the final ``state``.
        """
        force = np.atleast_2d(np.asarray(force, dtype=float))
        ad, bd = self.discretize(dt)
        x = np.zeros(self.n_state) if x0 is None else np.asarray(x0, dtype=float).copy()
        states = np.empty((force.shape[0], self.n_state))
        for k, f in enumerate(force):
            states[k] = x
            x = ad @ x + bd @ f
        return {"displacement": states @ self.Cd.T,
                "velocity": states @ self.Cv.T,
                "acceleration": states @ self.Ca.T + force @ self.Da.T,
                "state": x}
