"""Modal analysis of finite-element structures: ``K phi = omega^2 M phi``, and
the damping ratio of each mode from its own pole pair (``damping_ratios``)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from scipy.optimize import linear_sum_assignment

DENSE_LIMIT = 600  # DOF up to which the dense solver is used


def lanczos_start(n: int) -> np.ndarray:
    """A fixed start vector (n,) for ARPACK (``eigsh(..., v0=...)``): normal
    draws of a fixed seed, so that the same matrices give the same modes to
    the last digit whatever ARPACK computed before in the process (its own
    default start is a random vector from a generator it keeps across
    calls); a draw, not a constant vector, so that no mode is orthogonal to it."""
    return np.random.default_rng(20240607).standard_normal(n)


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
        lam, vec = sla.eigsh(k, k=count, M=m, sigma=shift, which="LM", v0=lanczos_start(n))
        order = np.argsort(lam)
        lam, vec = lam[order], vec[:, order]
    scale = max(abs(lam).max(), 1e-300)
    lam = np.where(lam < rigid_tol * scale, 0.0, lam)
    return Modes(lam=lam, shapes=vec)


def damping_ratios(damping: sp.spmatrix | np.ndarray, found: Modes) -> np.ndarray:
    """Damping ratio (r,) of each undamped mode of ``found`` (a complete
    mass-normalised set, shapes (n, n)) under the damping matrix ``C`` (N s/m).

    In modal coordinates ``q'' + Phi^T C Phi q' + diag(omega^2) q = 0``, state
    form ``[[0, I], [-diag(omega^2), -Phi^T C Phi]]``, each pole ``s_j`` has an
    eigenvector whose displacement part ``q_j`` weighs mode r by
    ``|q_jr|^2 / |q_j|^2``. Each mode gets its own pair of poles, one-to-one
    by that weight: a complex pair ``s, conj(s)``, else two real poles
    (assignment over complex pairs first, then the real poles two per left
    mode). From its pair, ``s^2 + 2 zeta w s + w^2 = (s - s1)(s - s2)``:
    ``zeta = -(s1 + s2) / (2 sqrt(s1 s2))`` (= ``-Re s / |s|`` for a complex
    pair). NaN for rigid-body modes (omega = 0) and overdamped ones
    (``zeta > 1 + 1e-9``: both poles real), never a neighbour's value.
    """
    phi, lam = found.shapes, found.lam
    n = phi.shape[0]
    if phi.shape != (n, n):
        raise ValueError(f"need all {n} modes, got {phi.shape[1]}")
    c = damping.toarray() if sp.issparse(damping) else np.asarray(damping, dtype=float)
    state = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(lam), -(phi.T @ c @ phi)]])
    s, vec = la.eig(state)  # real matrix: conjugate poles are exact pairs, real ones have Im = 0
    q = np.abs(vec[:n]) ** 2
    weight = q / q.sum(axis=0)  # (mode r, pole j)
    pair = np.zeros((n, 2), dtype=complex)
    upper, real = np.flatnonzero(s.imag > 0), np.flatnonzero(s.imag == 0)
    rows, cols = linear_sum_assignment(-weight[:, upper].T)
    pair[cols] = np.stack([s[upper[rows]], s[upper[rows]].conj()], axis=1)
    left = np.setdiff1d(np.arange(n), cols)
    if left.size:
        slots = np.repeat(left, 2)
        rows, cols = linear_sum_assignment(-weight[np.ix_(slots, real)])
        pair[slots[rows], rows % 2] = s[real[cols]]
    product, total = (pair[:, 0] * pair[:, 1]).real, (pair[:, 0] + pair[:, 1]).real
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = -total / (2 * np.sqrt(product))
    return np.where((lam > 0) & (product > 0) & (zeta <= 1 + 1e-9), zeta, np.nan)
