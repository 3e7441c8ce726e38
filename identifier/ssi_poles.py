"""Poles and mode shapes of SSI-cov at a range of model orders.

With the SVD ``H = U S V^T`` of the block Hankel matrix
(:func:`identifier.ssi_covariance.hankel`), order ``n`` keeps the ``n``
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

import numpy as np
import scipy.linalg as la


@dataclass(frozen=True)
class Poles:
    """The poles of one model order: ``omega`` (k,) rad/s, ``zeta`` (k,),
    ``shapes`` (m, k) complex, scaled back to the channels' units, each column
    of unit norm."""

    order: int
    omega: np.ndarray
    zeta: np.ndarray
    shapes: np.ndarray


@dataclass(frozen=True)
class Subspace:
    """What every model order needs from the Hankel SVD ``H = U S V^T``: the
    first block row of ``U`` (m, N) and the Gram matrices ``G = U_up^T U_up``,
    ``K = U_up^T U_down`` (N, N) of its shifted parts (``U_up`` without the last
    block row, ``U_down`` without the first)."""

    top: np.ndarray
    gram: np.ndarray
    shift: np.ndarray


def subspace(U: np.ndarray, m: int) -> Subspace:
    """:class:`Subspace` of the leading left singular vectors ``U`` (p m, N)."""
    up, down = U[:-m], U[m:]
    return Subspace(U[:m], up.T @ up, up.T @ down)


def poles_at(space: Subspace, order: int, dt: float, scale: np.ndarray) -> Poles:
    """Poles of model order ``order`` (``dt`` s; ``scale`` (m,) the channel RMS
    that standardised the outputs). With ``O = U_n S_n^(1/2)`` the least-squares
    ``A = pinv(O_up) O_down = S^(-1/2) G_n^(-1) K_n S^(1/2)``, so the poles are
    the eigenvalues of ``G_n^(-1) K_n`` and the shapes ``C psi_A = U_top,n psi``."""
    n = order
    mu, psi = la.eig(la.solve(space.gram[:n, :n], space.shift[:n, :n], assume_a="pos"))
    upper = mu.imag > 0
    mu, psi = mu[upper], psi[:, upper]
    sc = np.log(mu) / dt
    omega = np.abs(sc)
    zeta = -sc.real / omega
    shapes = (space.top[:, :n] @ psi) * scale[:, None]
    shapes /= np.linalg.norm(shapes, axis=0)
    ascending = np.argsort(omega)
    return Poles(order, omega[ascending], zeta[ascending], shapes[:, ascending])


def mac_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC between the columns of two complex shape matrices, (k_a, k_b)."""
    cross = np.abs(a.conj().T @ b) ** 2
    return cross / np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))


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


def leading_svd(H: np.ndarray, count: int, start: np.ndarray | None = None,
                power: int = 2) -> np.ndarray:
    """The ``count`` leading left singular vectors (rows, count) of ``H`` by
    subspace iteration (Halko, Martinsson and Tropp 2011): ``power`` steps
    from ``H`` times a fixed-seed Gaussian probe (``count + 10`` columns), or
    from ``start`` (rows, >= count), the vectors of a nearby matrix (one step).
    The full SVD for small matrices."""
    if start is None and count + 10 >= min(H.shape) // 2:
        return la.svd(H, full_matrices=False, lapack_driver="gesdd")[0][:, :count]
    if start is None:
        Q = la.qr(H @ np.random.default_rng(0).standard_normal((H.shape[1], count + 10)), mode="economic")[0]
    else:
        Q, power = start, 1
    for _ in range(power):
        Q = la.qr(H @ (H.T @ Q), mode="economic")[0]
    Ub = la.svd(Q.T @ H, full_matrices=False)[0]
    return (Q @ Ub)[:, :count]
