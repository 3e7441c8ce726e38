"""Bias-compensated least squares over every sample (errors in variables).

Equations. With ``theta = [p; -1]`` the equation error of sample ``k`` at DOF
``r`` is ``e_kr = (M a_k + C v_k + K u_k - f_k)_r = Y_kr theta``
(:mod:`identifier.least_squares.regression`). Plain least squares solves
``G theta = 0`` (rows of the unknowns) with ``G = Y^T Y``; when the channels
in ``Y`` are noisy, ``E[G] = G_0 + D`` with ``D = sum W^T diag(sigma^2) W``
the noise Gram matrix, so plain least squares is biased and no number of
samples removes it. Bias compensation subtracts ``D``:

    (G - D)_uu p_u = (G - D)_uf - (G - D)_uk p_k

(``u``: unknown parameters, ``k``: known ones, ``f``: the force column).
With ``weighting="noise"`` the equations are whitened by the noise at the
previous estimate (re-weighted :data:`REWEIGHTINGS` times after the
unweighted solution); ``G`` and ``D`` then carry the weights:

* up to :data:`identifier.least_squares.regression.DENSE_DOF` DOF, by the inverse of the
  DOF-coupled covariance of one sample's equation errors,
  ``Omega = (Mt^T diag(sigma^2) Mt)^-1`` (:mod:`identifier.least_squares.whitened`): this
  is what makes noisy displacements (entering through ``K``) harmless;
* beyond, one weight per DOF row, ``w_r = 1 / sqrt(mean_k var(e_kr))``.

The weights are constant in time, so re-weighting needs no further pass over
the samples: one pass accumulates the per-row blocks ``Y_r^T Y_r``, the raw
channels' ``X^T X`` (whitened case) and the channel noise; a second one the
standard errors.

Standard errors: the estimator solves ``sum_k g_k(p) = 0`` with
``g_k = B_k^T Omega e_k - E[dB_k^T Omega dB_k] theta`` (``Omega`` diagonal for
row weights, the identity unweighted), zero-mean
at the truth; with noise white in time the ``g_k`` are independent and the
sandwich ``H^-1 (sum_k g_k g_k^T) H^-1``, ``H = (G - D)_uu``, is the
covariance of ``p_u`` (to first order). Only its diagonal is formed:
``sum_k (H^-1 g_k)^2``, chunk by chunk.

Assumptions: zero-mean noise, independent between channels, white in
time, with the variances given (declared by the trace, or estimated from the
data). Fails or degrades when: the variances are wrong (the bias returns, in
proportion); displacements or velocities are integrated from noisy
accelerations (their errors are then correlated in time: the bias is still
compensated, but the standard errors are too small); the noise is so large
that ``G - D`` is ill-conditioned or indefinite; parameters are not excited
(rank deficiency, raised naming them).
"""
from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from structbench.models import Structure
from structbench.models.analysis import lanczos_start

from .estimate import Estimate
from . import whitened
from .identifiability import check_count, check_excited, not_identifiable, raise_deficient
from .regression import DENSE_COLUMNS, DENSE_DOF, Layout, error_variance, gram, layout, moments, scores

REWEIGHTINGS = 3


def _check_rank(G: sp.csr_matrix, labels: list[str], rcond: float) -> float:
    """Rank of the column-scaled ``G`` (eigenvalues below ``rcond^2`` of the
    largest are deficient: raise naming the parameters); returns the
    condition number of the scaled regression matrix, ``sqrt(cond(G))``."""
    scale = np.sqrt(G.diagonal())
    Gs = (sp.diags(1 / scale) @ G @ sp.diags(1 / scale))
    if Gs.shape[0] <= DENSE_COLUMNS:
        lam, vec = la.eigh(Gs.toarray())
        lam_max = lam[-1]
    else:
        Gs = Gs.tocsc()
        start = lanczos_start(Gs.shape[0])
        lam_max = sla.eigsh(Gs, k=1, which="LA", return_eigenvectors=False, v0=start)[0]
        lam, vec = sla.eigsh(Gs, k=min(4, Gs.shape[0] - 1), sigma=-1e-6 * lam_max, which="LM", v0=start)
    bad = lam < rcond**2 * lam_max
    if bad.any():
        raise_deficient(not_identifiable(vec[:, bad].T, labels), Gs.shape[0] - int(bad.sum()), len(labels))
    return float(np.sqrt(lam_max / max(lam.min(), np.finfo(float).tiny)))


class _Solver:
    """``H x = b`` for one (n_u, n_u) matrix: dense LU up to
    :data:`DENSE_COLUMNS` unknowns, sparse LU beyond."""

    def __init__(self, H: sp.csr_matrix):
        self.dense = H.shape[0] <= DENSE_COLUMNS
        self.lu = la.lu_factor(H.toarray()) if self.dense else sla.splu(H.tocsc())

    def __call__(self, b: np.ndarray) -> np.ndarray:
        return la.lu_solve(self.lu, b) if self.dense else self.lu.solve(b)


def _solve(G: sp.csr_matrix, D: sp.csr_matrix, mask: np.ndarray,
           known: np.ndarray) -> tuple[np.ndarray, _Solver]:
    u, k = np.flatnonzero(mask), np.flatnonzero(~mask)
    N = (G - D).tocsr()
    H = N[u][:, u]
    rhs = np.asarray(N[u][:, [N.shape[0] - 1]].todense()).ravel() - N[u][:, k] @ known
    solver = _Solver(H)
    return solver(rhs), solver


def _theta(model: Structure, mask: np.ndarray, p_u: np.ndarray) -> np.ndarray:
    p = model.values.copy()
    p[mask] = p_u
    return np.append(p, -1.0)


class _RowWeights:
    """One weight per DOF row (any model size): ``w_r = 1 / sqrt(mean_k var(e_kr))``."""

    label = "noise (one weight per DOF row)"

    def __init__(self, lay: Layout, motion):
        self.lay, self.motion, self.mom = lay, motion, moments(lay, motion)
        self.weights: np.ndarray | None = None

    def gram(self, theta: np.ndarray | None) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """``G``, ``D`` unweighted (``theta`` None) or weighted at ``theta``."""
        if theta is not None:
            var = error_variance(self.lay, self.mom, theta)
            self.weights = 1.0 / np.sqrt(var + 1e-9 * var.mean())
        return gram(self.lay, self.mom, self.weights)

    def scores(self, theta: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        return scores(self.lay, self.motion, theta, self.weights)


class _Whitening:
    """Full whitening with the DOF-coupled equation-error covariance
    (:mod:`identifier.least_squares.whitened`), up to :data:`regression.DENSE_DOF` DOF."""

    label = "noise (full DOF covariance)"

    def __init__(self, lay: Layout, motion):
        self.lay, self.motion, self.mom = lay, motion, moments(lay, motion, raw_gram=True)
        self.omega = np.eye(lay.n_dof)

    def gram(self, theta: np.ndarray | None) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """Unweighted (``theta`` None) from the per-row blocks, which keep the
        precision of small columns (rank checks); whitened at ``theta`` from ``X^T X``."""
        if theta is None:
            return gram(self.lay, self.mom)
        S = whitened.error_covariance(self.lay, self.mom.noise / self.mom.samples, theta)
        S[np.diag_indices_from(S)] += 1e-9 * np.trace(S) / S.shape[0]
        self.omega = la.inv(S)
        return whitened.gram(self.lay, self.mom.raw_gram, self.mom.noise, self.omega)

    def scores(self, theta: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        return whitened.scores(self.lay, self.motion, theta, self.omega)


def _std_errors(scored: Iterator[tuple[np.ndarray, np.ndarray]], mask: np.ndarray,
                solver: _Solver) -> tuple[np.ndarray, float]:
    """Sandwich standard errors (n_u,) and the RMS of the unweighted equation errors (N)."""
    u = np.flatnonzero(mask)
    var = np.zeros(u.size)
    sq, count = 0.0, 0
    for g, e in scored:
        z = solver(np.ascontiguousarray(g[u]))  # (n_u, m_chunk)
        var += np.sum(z**2, axis=1)
        sq, count = sq + float(np.sum(e**2)), count + e.size
    return np.sqrt(var), float(np.sqrt(sq / count))


def solve_compensated(model: Structure, motion, weighting: str = "noise", rcond: float = 1e-7) -> Estimate:
    """Unknown parameters (``model.kind_mask()``) from every sample of ``motion``
    by bias-compensated least squares (see the module docstring)."""
    mask = model.kind_mask()
    labels = [p.label for p, u in zip(model.parameters, mask) if u]
    known = model.values[~mask]
    check_count(motion.force.size, int(mask.sum()))
    lay = layout(model)
    system = (_Whitening if model.n_dof <= DENSE_DOF else _RowWeights)(lay, motion)
    G, D = system.gram(None)
    u = np.flatnonzero(mask)
    norms = {kind: float(np.sqrt(np.einsum("ij,ij->", x, x))) for kind, x in
             (("mass", motion.acceleration), ("damping", motion.velocity), ("stiffness", motion.displacement))}
    check_excited(model, norms, np.sqrt(G.diagonal()[u]), labels)
    condition = _check_rank(G[u][:, u], labels, rcond)
    p_u, solver = _solve(G, D, mask, known)
    noisy = D.nnz > 0 and weighting == "noise"
    for _ in range(REWEIGHTINGS if noisy else 0):
        p_u, solver = _solve(*system.gram(_theta(model, mask, p_u)), mask, known)
    theta = _theta(model, mask, p_u)
    std, residual = _std_errors(system.scores(theta), mask, solver)
    return Estimate(p_u, std, condition, residual, motion.force.size,
                    {"estimator": "bias-compensated", "weighting": system.label if noisy else "none",
                     "std_errors": "sandwich (noise white in time)"})
