"""Poles and mode shapes of SSI-cov at a range of model orders.

With the SVD ``H = U S V^T`` of the block Hankel matrix
(:mod:`identifier.modal.ssi.hankel`), order ``n`` keeps the ``n``
largest singular values: ``O_n = U_n S_n^(1/2)``, ``C = O_n[:m]`` and ``A``
from the shift structure ``O_n[m:] = O_n[:-m] A`` (least squares). The
eigenvalues ``mu`` of ``A`` give the continuous poles ``s = ln(mu) / dt``,
natural frequency ``omega = |s|`` rad/s and damping ratio
``zeta = -Re(s) / |s|``; the eigenvectors ``psi`` give the (complex) shapes
``C psi``. Only one pole of each complex-conjugate pair is kept (Im s > 0).
Poles on the real axis (no oscillation) are dropped. Undamped structures
give ``zeta`` of either sign around 0: the sign is not used to reject poles.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.linalg as la
from scipy.linalg import lapack


@dataclass(frozen=True)
class Poles:
    """The poles of one model order: ``omega`` (k,) rad/s, ``zeta`` (k,),
    ``shapes`` (m, k) complex, scaled back to the channels' units, each column
    of unit norm; and the whole eigen-decomposition ``M = Psi diag(mu) Psi^-1``
    of the order's ``M = G_n^-1 K_n`` that they come from (for the
    jackknife's perturbation): ``mu`` (n,), ``vectors`` ``Psi`` (n, n) and
    ``index`` (k,) of each kept pole in ``mu``."""

    order: int
    omega: np.ndarray
    zeta: np.ndarray
    shapes: np.ndarray
    mu: np.ndarray
    vectors: np.ndarray
    index: np.ndarray


@dataclass(frozen=True)
class Subspace:
    """What every model order needs from a basis ``B`` (p m, N) of the
    leading left singular subspace of the Hankel matrix: its first block row
    (m, N) and the Gram matrices ``G = B_up^T B_up``, ``K = B_up^T B_down``
    (N, N) of its shifted parts (``B_up`` without the last block row,
    ``B_down`` without the first)."""

    top: np.ndarray
    gram: np.ndarray
    shift: np.ndarray

    @cached_property
    def whitened(self) -> tuple[np.ndarray, np.ndarray]:
        """``L`` (N, N), the lower Cholesky factor of ``G = L L^T``, and ``T =
        L^-1 K L^-T`` (N, N): for every order ``n``, ``L_n`` (the leading
        n x n block) is the Cholesky factor of ``G_n`` and ``T_n = L_n^-1 K_n
        L_n^-T`` (``L^-1`` is lower triangular), similar to ``M_n = G_n^-1
        K_n``: one factorisation serves every order up to :attr:`orders`."""
        n = self.orders
        L = la.cholesky(self.gram[:n, :n], lower=True, check_finite=False)
        LiK = la.solve_triangular(L, self.shift[:n, :n], lower=True, check_finite=False)
        return L, la.solve_triangular(L, LiK.T, lower=True, check_finite=False).T

    @cached_property
    def orders(self) -> int:
        """The highest model order ``n`` whose ``G_n`` is positive definite: every order of the basis
        but where a basis vector lies in the last block row alone (a Hankel matrix of lower rank than
        the order: a record that holds a few sinusoids on many channels)."""
        info = lapack.dpotrf(self.gram, lower=1)[1]
        return self.gram.shape[0] if info == 0 else info - 1


def subspace(B: np.ndarray, m: int) -> Subspace:
    """:class:`Subspace` of a basis ``B`` (p m, N), in order: column ``n``
    extends the subspace of order ``n - 1``."""
    up, down = B[:-m], B[m:]
    return Subspace(B[:m], up.T @ up, up.T @ down)


def poles_at(space: Subspace, order: int, dt: float, scale: np.ndarray) -> Poles:
    """Poles of model order ``order`` (``dt`` s; ``scale`` (m,) the channel RMS
    that standardised the outputs). With ``O = U_n S_n^(1/2)`` the least-squares
    ``A = pinv(O_up) O_down = S^(-1/2) G_n^(-1) K_n S^(1/2)``, so the poles are
    the eigenvalues of ``M = G_n^(-1) K_n``, those of ``T_n = L_n^-1 K_n L_n^-T``
    (:attr:`Subspace.whitened`) with eigenvectors ``phi``; ``M``'s are ``psi
    = L_n^-T phi`` and the shapes ``C psi_A = U_top,n psi`` (any basis of the
    same span gives the same poles and shapes)."""
    n = order
    L, T = space.whitened
    mu, phi = np.linalg.eig(T[:n, :n])
    psi = la.solve_triangular(L[:n, :n], phi, trans="T", lower=True, check_finite=False)
    keep = np.flatnonzero(mu.imag > 0)
    sc = np.log(mu[keep]) / dt
    omega = np.abs(sc)
    zeta = -sc.real / omega
    shapes = (space.top[:, :n] @ psi[:, keep]) * scale[:, None]
    shapes /= np.linalg.norm(shapes, axis=0)
    ascending = np.argsort(omega)
    return Poles(order, omega[ascending], zeta[ascending], shapes[:, ascending], mu, psi, keep[ascending])


def coherence(U: np.ndarray, rows: int, vectors: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Temporal coherence (t,), 0..1, of poles ``mu`` (t,) with eigenvectors
    ``vectors`` (N, t) in the basis ``U`` (p rows, N), each zero past its
    own order (:func:`pole_columns`): how much of a pole's observability
    vector ``o = U psi`` (blocks ``o_i`` (rows,), i < p) the geometric
    sequence ``mu^i phi`` of its own eigenvalue explains,

        |sum_i conj(mu)^i o_i|^2 / (sum_i |mu|^(2i) sum_i |o_i|^2),

    the squared cosine between ``o`` and the best such sequence (after the
    extended modal amplitude coherence of ERA, Pappa et al. 1993). A pole of
    the structure is shift invariant over every block row: 1 up to noise. A
    pole that fits the covariance estimates' own noise (at orders past the
    structure's) is not: a small fraction. One product ``U [Re Psi, Im
    Psi]`` for all of them."""
    t = mu.size
    parts = U @ np.hstack([vectors.real, vectors.imag])
    o = (parts[:, :t] + 1j * parts[:, t:]).reshape(-1, rows, t)  # (p, rows, t)
    w = mu[None, :] ** np.arange(o.shape[0])[:, None]  # (p, t)
    fit = np.sum(np.abs(np.einsum("pt,prt->rt", w.conj(), o)) ** 2, axis=0)
    return fit / (np.sum(np.abs(w) ** 2, axis=0) * np.sum(np.abs(o) ** 2, axis=(0, 1)))


def pole_columns(poles: dict[int, Poles], pairs: list[tuple[int, int]], size: int) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvectors (size, t), zero past each one's order, and eigenvalues
    (t,) of the poles ``pairs`` ((order, index in that order's poles))."""
    vectors = np.zeros((size, len(pairs)), dtype=complex)
    mu = np.empty(len(pairs), dtype=complex)
    for c, (n, j) in enumerate(pairs):
        k = poles[n].index[j]
        vectors[:n, c], mu[c] = poles[n].vectors[:, k], poles[n].mu[k]
    return vectors, mu



def mpc(shapes: np.ndarray) -> np.ndarray:
    """Modal phase collinearity (k,) of complex shapes (m, k): 1 for a real
    (normal) mode, 0 for a circular one; from the eigenvalues of the 2 x 2
    covariance of the real and imaginary parts (Pappa et al. 1993)."""
    re, im = shapes.real, shapes.imag
    sxx, syy, sxy = np.sum(re**2, 0), np.sum(im**2, 0), np.sum(re * im, 0)
    root = np.sqrt((sxx - syy) ** 2 + 4 * sxy**2)
    total = sxx + syy
    return np.where(total > 0, (root / np.where(total > 0, total, 1.0)) ** 2, 1.0)


def real_shapes(shapes: np.ndarray) -> np.ndarray:
    """Real shapes (m, k): each complex column rotated to its principal
    direction in the complex plane, real part, scaled to max |.| = 1 with
    the largest entry positive."""
    re, im = shapes.real, shapes.imag
    theta = 0.5 * np.arctan2(2 * np.sum(re * im, 0), np.sum(re**2, 0) - np.sum(im**2, 0))
    rotated = (shapes * np.exp(-1j * theta)).real
    peak = rotated[np.argmax(np.abs(rotated), axis=0), np.arange(rotated.shape[1])]
    return rotated / np.where(peak == 0, 1.0, peak)
