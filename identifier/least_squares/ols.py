"""The dissertation's estimator (eqs. 3.1-3.15): least squares on the stacked
equations ``B p = c`` at chosen sample times, plain or noise-weighted.

``B`` stacks ``A(t_k)`` with columns ``dM_j a(t_k)``, ``dC_j v(t_k)``,
``dK_j u(t_k)`` (Rayleigh damping folds into mass and stiffness columns);
known parameters move to the right-hand side. Solved with column scaling:
up to :data:`DENSE_COLUMNS` unknowns by an SVD of ``B`` (rank, solution and
covariance from one factorisation), beyond by the sparse normal equations
(``splu``), the rank from the smallest eigenvalues by shift-invert Lanczos.

``weighting="noise"`` makes it generalised least squares with the declared
sensor noise: the equation error at ``t_k`` has covariance
``M Sa M + C Sv C + K Su K + Sf`` (previous estimate; two re-weightings after
plain least squares); dense whitening up to :data:`DENSE_DOF` DOF (batched
Cholesky over the sample times), diagonal beyond. Standard errors are
``s^2 (B^T B)^-1``: they ignore the noise inside ``B`` (errors in
variables), which biases the estimate; :mod:`identifier.least_squares.bias_compensated`
removes that bias.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from structbench.models import Structure
from structbench.models.analysis import lanczos_start

from ..errors import IdentificationError
from .estimate import Estimate
from .identifiability import check_count, check_excited, not_identifiable, raise_deficient
from .regression import DENSE_COLUMNS, DENSE_DOF

WEIGHTINGS = ("noise", "none")


def equations(model: Structure, motion) -> tuple[sp.csr_matrix, np.ndarray]:
    """``B`` (m n, n_par) over all parameters and ``F`` (m n,) stacked by sample time."""
    par, rows, cols, vals = model.triplets
    alpha, beta = model.rayleigh
    kind_of = np.array([{"mass": 0, "damping": 1, "stiffness": 2}[p.kind] for p in model.parameters])
    signals = np.stack([motion.acceleration + alpha * motion.velocity, motion.velocity,
                        motion.displacement + beta * motion.velocity])  # (3, m, n)
    m, n = motion.acceleration.shape
    data = vals[:, None] * signals[kind_of[par], :, cols]  # (nnz, m)
    row = rows[:, None] + n * np.arange(m)[None, :]
    col = np.broadcast_to(par[:, None], data.shape)
    B = sp.csr_matrix((data.ravel(), (row.ravel(), col.ravel())), shape=(m * n, len(model.parameters)))
    return B, motion.force.ravel()


def _covariances(model: Structure, p: np.ndarray, motion) -> np.ndarray:
    """Equation-error covariance per sample time, (m, n, n) dense or (m, n) diagonal."""
    mats = {"acceleration": model.mass(p), "velocity": model.damping(p), "displacement": model.stiffness(p)}
    if model.n_dof > DENSE_DOF:
        diag = motion.sigma["force"] ** 2
        for q, mat in mats.items():
            diag = diag + (mat.multiply(mat) @ (motion.sigma[q] ** 2).T).T
        return diag
    cov = np.zeros((motion.times.size, model.n_dof, model.n_dof))
    cov[:, np.arange(model.n_dof), np.arange(model.n_dof)] = motion.sigma["force"] ** 2
    for q, mat in mats.items():
        dense = mat.toarray()
        cov += np.einsum("ij,kj,lj->kil", dense, motion.sigma[q] ** 2, dense)
    return cov


def _whiten(model: Structure, p: np.ndarray, motion, B: sp.csr_matrix,
            c: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
    """``L_k^-1 B_k``, ``L_k^-1 c_k`` per sample time (``L_k`` the Cholesky factor of its covariance)."""
    cov = _covariances(model, p, motion)
    m, n = motion.force.shape
    if cov.ndim == 2:
        w = 1.0 / np.sqrt(cov + 1e-12 * cov.mean(axis=1, keepdims=True))
        return (sp.diags(w.ravel()) @ B).tocsr(), w.ravel() * c
    cov += 1e-12 * np.trace(cov, axis1=1, axis2=2)[:, None, None] / n * np.eye(n)
    inv = np.linalg.inv(np.linalg.cholesky(cov))  # (m, n, n)
    Bw = np.matmul(inv, B.toarray().reshape(m, n, -1)).reshape(m * n, -1)
    return sp.csr_matrix(Bw), np.matmul(inv, c.reshape(m, n, 1)).ravel()


def _solve_dense(B: np.ndarray, c: np.ndarray, labels: list[str], rcond: float) -> Estimate:
    scale = np.linalg.norm(B, axis=0)
    U, s, Vt = la.svd(B / scale, full_matrices=False)
    bad = s < rcond * s[0]
    if bad.any():
        raise_deficient(not_identifiable(Vt[bad], labels), int(np.sum(~bad)), len(labels))
    x = Vt.T @ ((U.T @ c) / s) / scale
    resid = c - B @ x
    dof = B.shape[0] - B.shape[1]
    s2 = resid @ resid / dof if dof > 0 else np.nan
    std = np.sqrt(np.sum((Vt / s[:, None]) ** 2, axis=0) * s2) / scale
    return Estimate(x, std, float(s[0] / s[-1]), float(np.sqrt(np.mean(resid**2))), B.shape[0])


def _solve_sparse(B: sp.csr_matrix, c: np.ndarray, labels: list[str], rcond: float) -> Estimate:
    scale = np.sqrt(np.asarray(B.multiply(B).sum(axis=0)).ravel())
    Bs = (B @ sp.diags(1.0 / scale)).tocsr()
    N = (Bs.T @ Bs).tocsc()
    start = lanczos_start(N.shape[0])
    lam_max = sla.eigsh(N, k=1, which="LA", return_eigenvectors=False, v0=start)[0]
    lam, vec = sla.eigsh(N, k=min(4, N.shape[0] - 1), sigma=-1e-6 * lam_max, which="LM", v0=start)
    bad = lam < rcond**2 * lam_max
    if bad.any():
        raise_deficient(not_identifiable(vec[:, bad].T, labels), N.shape[0] - int(bad.sum()), len(labels))
    lu = sla.splu(N)
    x = lu.solve(Bs.T @ c) / scale
    resid = c - B @ x
    dof = B.shape[0] - B.shape[1]
    s2 = resid @ resid / dof if dof > 0 else np.nan
    n, block = N.shape[0], 64
    diag = np.concatenate([np.diagonal(lu.solve(np.eye(n, min(block, n - j), -j))[j:j + block]).copy()
                           for j in range(0, n, block)])  # copies: a diagonal view keeps its block alive
    std = np.sqrt(diag * s2) / scale
    return Estimate(x, std, float(np.sqrt(lam_max / lam.min())), float(np.sqrt(np.mean(resid**2))), B.shape[0])


def solve(model: Structure, motion, weighting: str = "noise", rcond: float = 1e-7) -> Estimate:
    """Unknown parameters (``model.kind_mask()``) from the stacked equations of ``motion``."""
    if weighting not in WEIGHTINGS:
        raise IdentificationError(f"unknown weighting {weighting!r}; known: {', '.join(WEIGHTINGS)}",
                                  field="weighting")
    mask = model.kind_mask()
    labels = [p.label for p, u in zip(model.parameters, mask) if u]
    B_all, F = equations(model, motion)
    B = B_all.tocsc()[:, np.flatnonzero(mask)].tocsr()
    c = F - B_all.tocsc()[:, np.flatnonzero(~mask)] @ model.values[~mask]
    check_count(B.shape[0], B.shape[1])
    norms = {"mass": np.linalg.norm(motion.acceleration), "damping": np.linalg.norm(motion.velocity),
             "stiffness": np.linalg.norm(motion.displacement)}
    check_excited(model, norms, np.sqrt(np.asarray(B.multiply(B).sum(axis=0)).ravel()), labels)
    dense = B.shape[1] <= DENSE_COLUMNS

    def run(Bw: sp.csr_matrix, cw: np.ndarray) -> Estimate:
        return _solve_dense(Bw.toarray(), cw, labels, rcond) if dense else _solve_sparse(Bw, cw, labels, rcond)

    est = run(B, c)
    noisy = weighting == "noise" and any(np.any(s > 0) for s in motion.sigma.values())
    for _ in range(2 if noisy else 0):
        p = model.values.copy()
        p[mask] = est.values
        est = run(*_whiten(model, p, motion, B, c))
    est.details = {"estimator": "ols", "weighting": "noise" if noisy else "none",
                   "std_errors": "s^2 (B^T B)^-1 (noise in B ignored)"}
    return est
