"""Free-decay fit of a few normal modes whose residues are rank one across records.

In free response every (non-repeated) mode ``j`` moves one shape in every
record: its residues are ``c_rj = phi_j p_rj`` with the shape ``phi_j`` (m,),
real for a normal mode (classical damping), and one complex participation
``p_rj`` per record (the initial conditions' projection on the mode, with
their phase). For ``p`` free modes the model of :mod:`identifier.modal.close_pairs.free_decay_fit`
becomes, channel ``i`` of record ``r``,

    y_ri(t) = sum_a phi_ai Re(p_ra e^(lambda_a t)) + (fixed poles, offset, drift) + e_ri(t).

Nonlinear parameters: each free pole ``(sigma_a, omega_d,a)`` and its
participations (``p_ra = 1`` at one reference record, so ``2 (R - 1)`` reals);
the shapes and the fixed poles' residues (free per record) are linear. The
poles stay near one centre, so each group of records is its reduced
:class:`identifier.modal.close_pairs.local_space.Local` (``V^T Z``, the fixed poles projected
out). With ``E = V^T [Re e^(lambda_a t), Im e^(lambda_a t)]_a`` (k x 2p),
record ``r`` has the columns ``W_r = E M_r`` (``M_r`` (2p x p): ``(Re p_ra,
-Im p_ra)`` in mode ``a``'s rows) and channel ``i`` (weighted by ``1 / s_ri``)
the normal equations

    (sum_r W_r^T W_r / s_ri^2) phi_i = sum_r W_r^T z_ri / s_ri.

``scipy.optimize.least_squares`` minimises the residual ``V^T Z - E A`` (a few
dozen rows per column; finite-difference Jacobian) over the nonlinear
parameters; the residual sum of squares adds the constant part outside ``V``;
the covariance is ``s^2 (J^T J)^-1`` with ``s^2 = f / dof``.

Two poles of a close pair are separated by this structure: their first-order
sum ``(c_r + d_r t) e^(lambda t)`` (:mod:`identifier.modal.close_pairs.pair`) fixes
``delta`` only when the residues are rank one over at least two records that
move the pair in different proportions.
Fails for repeated roots (their residues are not rank one), for complex
modes (non-classical damping: the fit then leaves their imaginary part in the
residual) and for a mode absent from its reference record.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from .local_space import REACH, Local, columns


@dataclass(frozen=True)
class Layout:
    """Which records a group's columns hold (``records`` (R_g,), each ``m``
    channels in turn), their noise levels ``scale`` (R_g, m) and their
    number of samples ``length``."""

    records: np.ndarray
    scale: np.ndarray
    length: int


@dataclass(frozen=True)
class ModeFit:
    """Fitted poles (p,) complex, participations (p, R) complex (1 at each
    mode's reference record), shapes (m, p) complex in the channels' units,
    the weighted residual sum of squares, its degrees of freedom and the
    covariance (2p, 2p) of the poles' ``(sigma_a, omega_d,a)``."""

    poles: np.ndarray
    participations: np.ndarray
    shapes: np.ndarray
    rss: float
    dof: int
    cov: np.ndarray


def _blocks(part: np.ndarray) -> np.ndarray:
    """``M_r`` (R, 2p, p) from the participations (p, R): ``Re(phi p e) = phi (Re p Re e - Im p Im e)``."""
    p, records = part.shape
    out = np.zeros((records, 2 * p, p))
    for a in range(p):
        out[:, 2 * a, a], out[:, 2 * a + 1, a] = part[a].real, -part[a].imag
    return out


def fit_modes(locals_: list[Local], layouts: list[Layout], fixed: int, start: np.ndarray,
              participations: np.ndarray, max_nfev: int = 200) -> ModeFit:
    """Fit ``p`` modes with rank-one residues from the poles ``start`` (p,)
    and participations (p, R) (each mode's largest is its reference, held at
    1) in the groups reduced near one center (``fixed`` poles projected out);
    every pole stays within ``REACH / (T sqrt 2)`` of the center in real and imaginary part."""
    p, records = participations.shape
    m = layouts[0].scale.shape[1]
    refs = np.argmax(np.abs(participations), axis=1)
    part0 = participations / participations[np.arange(p), refs][:, None]
    free = [np.delete(np.arange(records), refs[a]) for a in range(p)]

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        poles, part, k = x[0:2 * p:2] + 1j * x[1:2 * p:2], np.ones((p, records), complex), 2 * p
        for a in range(p):
            part[a, free[a]] = x[k:k + 2 * free[a].size:2] + 1j * x[k + 1:k + 2 * free[a].size:2]
            k += 2 * free[a].size
        return poles, part

    def solve(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The residual (V^T part, every group) and the shapes (m, p)."""
        poles, part = unpack(x)
        blocks = _blocks(part)
        lhs, rhs, es = np.zeros((m, p, p)), np.zeros((m, p)), []
        for loc, lay in zip(locals_, layouts):
            e = columns(loc, poles)
            gram, ez = e.T @ e, e.T @ loc.zv
            es.append(e)
            for k, r in enumerate(lay.records):
                mr, s = blocks[r], lay.scale[k]
                lhs += (mr.T @ gram @ mr)[None] / s[:, None, None] ** 2
                rhs += (mr.T @ ez[:, k * m:(k + 1) * m]).T / s[:, None]
        ridge = 1e-12 * np.trace(lhs, axis1=1, axis2=2)[:, None, None] * np.eye(p)  # a mode absent from a record
        shapes = np.linalg.solve(lhs + ridge, rhs[:, :, None])[:, :, 0]
        resid = [(loc.zv - e @ np.hstack([blocks[r] @ (shapes / s[:, None]).T
                                          for r, s in zip(lay.records, lay.scale)])).ravel()
                 for loc, lay, e in zip(locals_, layouts, es)]
        return np.concatenate(resid), shapes

    x0 = [np.column_stack([start.real, start.imag]).ravel()]
    x0 += [np.column_stack([part0[a, free[a]].real, part0[a, free[a]].imag]).ravel() for a in range(p)]
    x0 = np.concatenate(x0)
    center, half = locals_[0].center, REACH / (np.sqrt(2) * max(loc.span for loc in locals_))
    lower, upper = np.full(x0.size, -np.inf), np.full(x0.size, np.inf)
    lower[:2 * p] = np.tile([center.real - half, center.imag - half], p)
    upper[:2 * p] = np.tile([center.real + half, center.imag + half], p)
    x0 = np.clip(x0, lower + 1e-3 * half, upper - 1e-3 * half)
    sol = least_squares(lambda x: solve(x)[0], x0, bounds=(lower, upper), method="trf", x_scale="jac",
                        max_nfev=max_nfev)
    rss = float(2 * sol.cost + sum(loc.outside.sum() for loc in locals_))
    linear = sum((2 + 2 * fixed) * loc.zv.shape[1] for loc in locals_) + p * m
    dof = sum(lay.length * loc.zv.shape[1] for loc, lay in zip(locals_, layouts)) - linear - x0.size
    cov = rss / dof * np.linalg.pinv(sol.jac.T @ sol.jac, hermitian=True)
    poles, part = unpack(sol.x)
    return ModeFit(poles, part, solve(sol.x)[1], rss, dof, cov[:2 * p, :2 * p])
