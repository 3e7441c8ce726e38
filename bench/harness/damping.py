"""True modal damping ratios of a model, for ``truth.json``.

Modal models carry them (``zeta``). For a finite-element model with damping
matrix ``C`` the complex eigenproblem of ``M x'' + C x' + K x = 0`` in state
form, ``[[0, I], [-M^-1 K, -M^-1 C]]``, gives poles ``s``; each undamped
mode ``r`` (omega_r rad/s) takes the pole of ``Im s > 0`` nearest to it in
``|s|``, and ``zeta_r = -Re s / |s|``. Rigid-body modes (omega = 0) and modes
left without an oscillating pole (overdamped) get NaN; an undamped model 0.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la

from structbench.models import ModalModel, Model


def damping_ratios(model: Model, omega: np.ndarray) -> np.ndarray:
    """Damping ratio (r,) of each mode of natural frequency ``omega`` (r,) rad/s."""
    if isinstance(model, ModalModel):
        return np.asarray(model.zeta, dtype=float)[:omega.size]
    C = model.damping().toarray()
    if not np.any(C):
        return np.zeros(omega.size)
    M, K = model.mass().toarray(), model.stiffness().toarray()
    n = M.shape[0]
    state = np.block([[np.zeros((n, n)), np.eye(n)], [-la.solve(M, K), -la.solve(M, C)]])
    s = la.eigvals(state)
    s = s[s.imag > 1e-12 * np.abs(s).max()]
    out = np.full(omega.size, np.nan)
    for r, w in enumerate(omega):
        if w > 0 and s.size:
            j = int(np.argmin(np.abs(np.abs(s) - w)))
            out[r] = -s[j].real / abs(s[j])
    return out
