"""Modal analysis of finite-element structures: ``K phi = omega^2 M phi``."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

DENSE_LIMIT = 600  # DOF up to which the dense solver is used


@dataclass(frozen=True)
class Modes:
    """Natural frequencies ``omega`` (rad/s, ascending, rigid-body modes 0.0),
    eigenvalues ``lam = omega^2`` (rad^2/s^2) and mass-normalised shapes
    ``shapes`` of shape (n_dof, n_modes)."""

    lam: np.ndarray
    shapes: np.ndarray

    @property
    def omega(self) -> np.ndarray:
        return np.sqrt(self.lam)


def modes(mass: sp.spmatrix | np.ndarray, stiffness: sp.spmatrix | np.ndarray,
          count: int | None = None, rigid_tol: float = 1e-9) -> Modes:
    """Lowest ``count`` modes of ``(K, M)``; all of them when ``count`` is None.

    Dense LAPACK up to :data:`DENSE_LIMIT` DOF, otherwise sparse shift-invert
    Lanczos about a small negative shift (handles rigid-body modes).
    Eigenvalues below ``rigid_tol`` times the largest computed one are set to 0.
    """
    n = mass.shape[0]
    count = n if count is None else min(count, n)
    if n <= DENSE_LIMIT or count >= n - 1:
        m = mass.toarray() if sp.issparse(mass) else np.asarray(mass)
        k = stiffness.toarray() if sp.issparse(stiffness) else np.asarray(stiffness)
        lam, vec = la.eigh(k, m, subset_by_index=[0, count - 1])
    else:
        k = sp.csc_matrix(stiffness)
        m = sp.csc_matrix(mass)
        shift = -1e-6 * abs(k.diagonal()).max() / abs(m.diagonal()).max()
        lam, vec = sla.eigsh(k, k=count, M=m, sigma=shift, which="LM")
        order = np.argsort(lam)
        lam, vec = lam[order], vec[:, order]
    scale = max(abs(lam).max(), 1e-300)
    lam = np.where(lam < rigid_tol * scale, 0.0, lam)
    return Modes(lam=lam, shapes=vec)
