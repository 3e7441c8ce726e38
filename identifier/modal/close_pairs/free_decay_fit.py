"""Maximum-likelihood fit of free responses by variable projection.

Model: record ``r`` (channels ``i``, samples ``t_k = k dt`` from the start of
the free response) is

    y_ri(t_k) = a_ri + b_ri t_k + sum_j Re(c_rij exp(lambda_j t_k)) + e_rik,

with the poles ``lambda_j = sigma_j + i omega_d,j = -zeta_j omega_j + i omega_j
sqrt(1 - zeta_j^2)`` shared by every record and channel, complex residues
``c_rij``, an offset and drift ``a + b t`` (sensor offsets; a rigid-body mode:
constant velocity, drifting displacement) and white Gaussian noise ``e`` of
standard deviation ``s_ri``. Each channel divided by its ``s_ri``, the
records of one length stack as ``Z = B(theta) C + E`` (n x M, one column per
channel and record) with one real basis for every column,

    B = [1, t, e^(sigma_j t) cos(omega_d,j t), e^(sigma_j t) sin(omega_d,j t), ...]   (n x (2 + 2K)),

so that for given poles the residues are linear least squares, ``C = B^+ Z``
from one QR ``B = Q U`` for all right-hand sides, ``c = C_cos - i C_sin``. The
free poles ``theta = (sigma_j, omega_d,j)`` minimise the projected residual
(Golub and Pereyra 1973)

    r(theta) = (I - Q Q^T) Z,     f = ||r||_F^2,

by ``scipy.optimize.least_squares`` with the exact Jacobian

    dr/dtheta_k = -(I - Q Q^T) D_k C - Q U^-T D_k^T r,     D_k = dB/dtheta_k,

(``dB/dsigma_j = t [u_j, v_j]``, ``dB/domega_d,j = t [-v_j, u_j]`` in pole ``j``'s two
columns ``u_j, v_j``); other poles can be held fixed (their columns projected
out first, their residues free). From a covariance of ``(sigma_j, omega_d,j)``,
``omega = |lambda|``, ``zeta = -sigma / |lambda|`` and their standard errors
follow by the delta method (:func:`omega_zeta`).

Assumes a linear structure in free response over the whole record (no force
after its start), white noise and every mode with a visible response in the
basis; a mode left out leaves its signal in the residual (raising ``s``).
Fails for poles that decay within a few samples (their columns vanish) and
for two poles closer than the record resolves (the basis is then singular).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
from scipy.optimize import least_squares

ROTATE = np.array([[0.0, 1.0], [-1.0, 0.0]])  # d[u, v]/d omega_d = t [u, v] ROTATE


@dataclass(frozen=True)
class Group:
    """Weighted records of one length: time ``t`` (n,) s from the start of
    the free response, data ``z`` (n, M) (each channel divided by its noise
    standard deviation)."""

    t: np.ndarray
    z: np.ndarray


def basis(t: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """``[1, t, e^(sigma t) cos(omega_d t), e^(sigma t) sin(omega_d t), ...]`` (n, 2 + 2K) for poles (K,)."""
    e = np.exp(np.outer(t, poles))
    cols = np.stack([e.real, e.imag], axis=2).reshape(t.size, -1)
    return np.column_stack([np.ones_like(t), t, cols])


@dataclass(frozen=True)
class Projection:
    """One group projected on the basis of all poles: ``q`` (n, N) and ``u``
    (N, N) its QR factors, ``coef`` (N, M) the linear coefficients ``C``,
    ``resid`` (n, M) the projected residual."""

    q: np.ndarray
    u: np.ndarray
    coef: np.ndarray
    resid: np.ndarray


def project(group: Group, columns: np.ndarray) -> Projection:
    """Least-squares coefficients of every data column on ``columns`` (n, N),
    e.g. the offsets, drifts and residues on :func:`basis`."""
    q, u = la.qr(columns, mode="economic")
    qz = q.T @ group.z
    return Projection(q, u, la.solve_triangular(u, qz), group.z - q @ qz)


@dataclass(frozen=True)
class FixedPart:
    """A group with the fixed poles projected out: ``qf`` (n, N_f) the
    orthonormal basis of their columns (and 1, t), ``zf`` (n, M) the data
    without them."""

    t: np.ndarray
    qf: np.ndarray
    zf: np.ndarray


def fixed_part(group: Group, fixed: np.ndarray) -> FixedPart:
    """The group with the columns of the poles ``fixed`` (and 1, t) projected out."""
    qf = la.qr(basis(group.t, fixed), mode="economic")[0]
    return FixedPart(group.t, qf, group.z - qf @ (qf.T @ group.z))


def against(fx: FixedPart, x: np.ndarray) -> np.ndarray:
    """``(I - Q_f Q_f^T) x``."""
    return x - fx.qf @ (fx.qf.T @ x)


def _state(fx: FixedPart, poles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For the free poles (p,): ``Q_v`` (n, 2p), ``U_v`` (2p, 2p) (QR of their columns
    with the fixed ones projected out), coefficients ``C_v`` (2p, M), residual (n, M)."""
    qv, uv = la.qr(against(fx, basis(fx.t, poles)[:, 2:]), mode="economic")
    qz = qv.T @ fx.zf
    return qv, uv, la.solve_triangular(uv, qz), fx.zf - qv @ qz


def _jacobian(fx: FixedPart, poles: np.ndarray, qv: np.ndarray, uv: np.ndarray, coef: np.ndarray,
              resid: np.ndarray) -> np.ndarray:
    """Exact Jacobian (n M, 2p) of the flattened residual in ``(sigma_j, omega_d,j)``."""
    cols = basis(fx.t, poles)[:, 2:].reshape(fx.t.size, poles.size, 2)
    out = []
    for j in range(poles.size):
        tj = fx.t[:, None] * cols[:, j]  # (n, 2): t u_j, t v_j
        fj = against(fx, tj)
        fj -= qv @ (qv.T @ fj)  # (I - P) t [u_j, v_j]
        tr = tj.T @ resid  # (2, M)
        for rot in (np.eye(2), ROTATE):
            lifted = np.zeros_like(coef)
            lifted[2 * j:2 * j + 2] = rot.T @ tr
            term = fj @ (rot @ coef[2 * j:2 * j + 2]) + qv @ la.solve_triangular(uv, lifted, trans="T")
            out.append(-term.ravel())
    return np.column_stack(out)


def omega_zeta(poles: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``omega = |lambda|`` (p,) rad/s, ``zeta = -sigma / |lambda|`` and their
    standard errors by the delta method from the covariance (2p, 2p) of ``(sigma_j, omega_d,j)``."""
    s, w = poles.real, poles.imag
    omega = np.abs(poles)
    grad_w = np.column_stack([s, w]) / omega[:, None]
    grad_z = np.column_stack([-1.0 / omega + s**2 / omega**3, s * w / omega**3])
    blocks = np.array([cov[2 * j:2 * j + 2, 2 * j:2 * j + 2] for j in range(s.size)]).reshape(-1, 2, 2)
    var_w = np.einsum("ja,jab,jb->j", grad_w, blocks, grad_w)
    var_z = np.einsum("ja,jab,jb->j", grad_z, blocks, grad_z)
    return omega, -s / omega, np.sqrt(np.maximum(var_w, 0.0)), np.sqrt(np.maximum(var_z, 0.0))  # < 0: rounding


def fit_poles(groups: list[Group], fixed: np.ndarray, start: np.ndarray, band: tuple[float, float],
              max_nfev: int = 30) -> np.ndarray:
    """The poles (p,) complex refined from ``start`` (Im > 0) with the poles
    ``fixed`` held, every free ``omega_d`` within ``band`` (rad/s), by
    minimising the projected residual of every group."""
    fxs = [fixed_part(g, fixed) for g in groups]
    cache: dict[bytes, list[tuple]] = {}

    def states(x: np.ndarray) -> list[tuple]:
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = [_state(fx, x[0::2] + 1j * x[1::2]) for fx in fxs]
        return cache[key]

    def fun(x: np.ndarray) -> np.ndarray:
        return np.concatenate([st[3].ravel() for st in states(x)])

    def jac(x: np.ndarray) -> np.ndarray:
        return np.vstack([_jacobian(fx, x[0::2] + 1j * x[1::2], *st) for fx, st in zip(fxs, states(x))])

    p = start.size
    x0 = np.column_stack([start.real, np.clip(start.imag, *band)]).ravel()
    lower = np.tile([-np.inf, band[0]], p)
    upper = np.tile([np.inf, band[1]], p)
    sol = least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf", x_scale="jac",
                        max_nfev=max_nfev, xtol=1e-10, ftol=1e-10)
    return sol.x[0::2] + 1j * sol.x[1::2]
