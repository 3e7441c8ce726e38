"""Modes of an affine finite-element model and their exact first derivatives.

The model is ``M(p) = sum_j p_j dM_j``, ``K(p) = sum_j p_j dK_j``
(:class:`structbench.models.Structure`); the updated parameters are scale
factors ``alpha`` (dimensionless, shape (q,)) of chosen entries ``sel`` of the
prior's parameter vector ``p0``: ``p[sel] = p0[sel] (1 + alpha)``, the other
entries stay at ``p0``.

Eigenvalue derivative of a simple mode (``phi`` mass-normalised)::

    dlambda/dalpha_j = phi^T (dK/dalpha_j - lambda dM/dalpha_j) phi

Eigenvector derivative by Nelson's method (exact for a simple eigenvalue,
no other mode needed): with ``f_j = -(dK_j - lambda dM_j) phi + dlambda_j M phi``
solve ``(K - lambda M) v_j = f_j`` with entry ``k`` (largest ``|phi_k|``) of
``v_j`` held at 0 (row and column ``k`` replaced by the unit vector), then
``dphi_j = v_j + c_j phi`` with ``c_j = -phi^T M v_j - phi^T dM_j phi / 2``.
Fails (a singular ``(K - lambda M)`` after the replacement) only when the
eigenvalue is repeated; the derivative of a repeated eigenvalue's vectors
does not exist.

Dense LAPACK up to :data:`DENSE_LIMIT` DOF; above, sparse matrices with
shift-invert Lanczos (``eigsh`` about a shift below the lowest eigenvalue
wanted) and a sparse LU per mode for Nelson's equations, so that the cost
grows about linearly with the DOF of a banded model.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from structbench.models import Structure
from structbench.models.analysis import lanczos_start

DENSE_LIMIT = 400
SUBSPACE_ITERATIONS = 12
GUARD = 8  # least number of extra vectors of the subspace iteration


class AffineModel:
    """Fast assembly, modes and sensitivities of ``structure`` in the scale
    factors of the parameters ``sel`` (indices into ``structure.parameters``).

    ``sensors`` (m,) are free-DOF indices where shapes are compared."""

    def __init__(self, structure: Structure, sel: np.ndarray, sensors: np.ndarray) -> None:
        self.structure = structure
        self.p0 = structure.values.astype(float)
        self.sel = np.asarray(sel, dtype=int)
        self.sensors = np.asarray(sensors, dtype=int)
        self.n = structure.n_dof
        self.dense = self.n <= DENSE_LIMIT
        par, rows, cols, vals = structure.triplets
        kinds = np.array([p.kind for p in structure.parameters])
        self._maps = {kind: self._pattern(par, rows, cols, vals, kinds[par] == kind) for kind in ("mass", "stiffness")}
        # derivative scatter: (D_j phi)[row] for the selected parameters, columns in alpha order
        position = np.full(len(structure.parameters), -1)
        position[self.sel] = np.arange(self.sel.size)
        keep = position[par] >= 0
        self._d_rows, self._d_cols = rows[keep], cols[keep]
        self._d_pos, self._d_vals = position[par[keep]], vals[keep] * self.p0[par[keep]]
        self.is_mass = kinds[self.sel] == "mass"
        self.q = self.sel.size
        self._basis: np.ndarray | None = None  # last sparse eigenvectors (n, count + GUARD)

    def _pattern(self, par: np.ndarray, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray,
                 mask: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
        """CSR structure of one matrix kind and the sparse map ``B`` (nnz, P)
        with ``data = B @ p``."""
        n, P = self.n, len(self.p0)
        key = rows[mask] * n + cols[mask]
        unique, where = np.unique(key, return_inverse=True)
        B = sp.csr_matrix((vals[mask], (where, par[mask])), shape=(unique.size, P))
        return B, unique // n, unique % n

    def values(self, alpha: np.ndarray) -> np.ndarray:
        """Parameter vector ``p`` (P,) of the scale factors ``alpha`` (q,)."""
        p = self.p0.copy()
        p[self.sel] *= 1.0 + np.asarray(alpha, dtype=float)
        return p

    def matrices(self, alpha: np.ndarray) -> tuple[np.ndarray | sp.csc_matrix, np.ndarray | sp.csc_matrix]:
        """``(M, K)``: dense arrays up to :data:`DENSE_LIMIT` DOF, else sparse CSC."""
        p = self.values(alpha)
        out = []
        for kind in ("mass", "stiffness"):
            B, r, c = self._maps[kind]
            data = B @ p
            if self.dense:
                A = np.zeros((self.n, self.n))
                A[r, c] = data
            else:
                A = sp.csc_matrix((data, (r, c)), shape=(self.n, self.n))
            out.append(A)
        return out[0], out[1]

    def modes(self, M, K, count: int, precise: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Lowest ``count`` eigenpairs ``(lam (count,), phi (n, count))``,
        ``phi^T M phi = I``; sparse: the lowest ``precise`` to a relative
        residual of 1e-10, the others 1e-6."""
        count = min(count, self.n)
        if self.dense or count >= self.n - 1:
            Md = M.toarray() if sp.issparse(M) else M
            Kd = K.toarray() if sp.issparse(K) else K
            return la.eigh(Kd, Md, subset_by_index=[0, count - 1], check_finite=False)
        shift = -1e-6 * abs(K.diagonal()).max() / abs(M.diagonal()).max()
        if self._basis is not None and self._basis.shape[1] >= count:
            found = self._subspace(M, K, shift, count, count if precise is None else min(precise, count))
            if found is not None:
                return found
        block = min(count + max(GUARD, count // 2), self.n - 1)
        lam, phi = sla.eigsh(K, k=block, M=M, sigma=shift, which="LM", v0=lanczos_start(self.n))
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
        self._basis = phi
        return lam[:count], phi[:, :count]

    def _subspace(self, M, K, shift: float, count: int, precise: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Shift-invert subspace iteration from the last modes (they change
        little between evaluations), with Rayleigh-Ritz on the block of
        ``count`` plus ``max(GUARD, count / 2)`` vectors; None when the modes
        do not converge (the step ``|x_new - x_old|_M`` below 1e-10 for the
        lowest ``precise``, 1e-6 for the rest of ``count``; a residual norm
        ``|K x - lam M x|`` is no test for the lowest modes of a stiff model,
        whose ``K x`` cancels) in :data:`SUBSPACE_ITERATIONS` steps."""
        lu = sla.splu(sp.csc_matrix(K - shift * M))
        X = self._basis
        tol = np.where(np.arange(count) < precise, 1e-10, 1e-6)
        for _ in range(SUBSPACE_ITERATIONS):
            Y = lu.solve(np.asarray(M @ X))
            lam, V = la.eigh(Y.T @ (K @ Y), Y.T @ (M @ Y), check_finite=False)
            new = Y @ V
            sign = np.sign(np.sum(X[:, :count] * (M @ new[:, :count]), axis=0))
            d = new[:, :count] - X[:, :count] * sign
            change = np.sqrt(np.abs(np.sum(d * (M @ d), axis=0)))
            X = new
            if np.all(change < tol):
                self._basis = X
                return lam[:count], X[:, :count]
        return None

    def derivatives(self, M, K, lam: float, phi: np.ndarray, shapes: bool = True
                    ) -> tuple[np.ndarray, np.ndarray | None]:
        """``dlambda/dalpha`` (q,) and, if ``shapes``, ``dphi/dalpha`` at the
        sensors (m, q) of one simple mode (Nelson's method)."""
        G = np.zeros((self.n, self.q))
        np.add.at(G, (self._d_rows, self._d_pos), self._d_vals * phi[self._d_cols])  # G_j = D_j phi
        h = np.where(self.is_mass, -lam, 1.0) * G                                # (dK_j - lam dM_j) phi
        dlam = phi @ h
        if not shapes:
            return dlam, None
        Mphi = M @ phi
        f = np.outer(Mphi, dlam) - h
        k = int(np.argmax(np.abs(phi)))
        f[k] = 0.0
        if self.dense:
            A = K - lam * M
            A[k, :] = 0.0
            A[:, k] = 0.0
            A[k, k] = 1.0
            v = la.solve(A, f, check_finite=False)
        else:
            A = sp.csc_matrix(K - lam * M)
            cut = np.repeat(np.arange(self.n), np.diff(A.indptr))  # column of every stored entry
            A.data[(cut == k) | (A.indices == k)] = 0.0
            A.data[(cut == k) & (A.indices == k)] = 1.0               # the diagonal entry (K's is stored)
            v = sla.splu(A).solve(f)
        mpart = np.where(self.is_mass, phi @ G, 0.0)
        c = -(Mphi @ v) - 0.5 * mpart
        dphi = v[self.sensors] + np.outer(phi[self.sensors], c)
        return dlam, dphi
