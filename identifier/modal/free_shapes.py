"""Mode shapes and their standard errors by least squares at the refined poles of a free decay.

Where :mod:`identifier.modal.refine` has refined a mode's pole by maximum
likelihood, its shape is taken from the same signal model: with every
reported pole ``lambda_j`` held at its reported value, each channel ``c`` of
record ``r`` (its free part, ``t_k = k dt``, truncated to ``refine.DECAYS``
decay times of the slowest mode) is fitted by linear least squares,

    y_rc(t_k) = a + b t_k + sum_j (p_rcj Re e^(lambda_j t_k) + q_rcj Im e^(lambda_j t_k)) + e_rc(t_k),

so that ``A_rcj = p_rcj - i q_rcj`` is the complex amplitude of mode ``j``
(what SSI's ``C psi`` estimates: the shape times the record's modal
amplitude), with covariance ``s_rc^2 (X^T X)^-1`` of ``(p, q)``
(``s_rc^2``: the residual's mean square over ``n - N`` degrees of
freedom, ``X`` (n, N) the basis). Per mode, the records are combined as a
rank-one fit ``A_r ~ phi a_r`` (``a_r = phi^H A_r / phi^H phi``; each
record's ``u_r = A_r / a_r`` weighted by the inverse of its 2 x 2
covariance per entry, two passes). The shape is reported as every
other (:func:`identifier.modal.ssi.poles.real_shapes`: turned by the
principal angle ``theta`` of ``phi``, real part, over its largest entry
``peak``), and the standard error of entry ``c`` is

    std_c = sqrt(g^T Cov(Re phi_c, Im phi_c) g) / |peak|,   g = (cos theta, sin theta),

the error of the entry with the shape's scale and phase held (their errors
are common to every entry: a change of scale, which updating profiles out).

The poles' own errors move every entry of a mode alike (phase and scale)
and are left out; a mode missing from the reported ones stays in the
residual and inflates ``s`` (errors too large, not too small). Assumes
white noise on every channel, like the refinement.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..io.traces import Trace
from .close_pairs.free_decay_fit import basis
from .refine import DECAYS, free_starts

PASSES = 2  # rank-one combination of several records: passes of (a_r, phi)


def _amplitudes(y: np.ndarray, t: np.ndarray, poles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Complex amplitudes (m, K) of ``poles`` (K,) in ``y`` (m, n) and the
    covariance (m, K, 2, 2) of their real and imaginary parts."""
    X = basis(t, poles)
    coef, *_ = np.linalg.lstsq(X, y.T, rcond=None)
    resid = y.T - X @ coef
    s2 = np.sum(resid**2, axis=0) / max(t.size - X.shape[1], 1)  # (m,)
    G = np.linalg.inv(X.T @ X)
    k = np.arange(poles.size)
    p, q = 2 + 2 * k, 3 + 2 * k
    amp = (coef[p] - 1j * coef[q]).T  # (m, K)
    block = np.stack([np.stack([G[p, p], -G[p, q]], -1), np.stack([-G[q, p], G[q, q]], -1)], -2)  # (K, 2, 2)
    return amp, s2[:, None, None, None] * block[None]


def _combined(amps: list[np.ndarray], covs: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """One mode's shape (m,) and its per-entry covariance (m, 2, 2) from the
    records' amplitudes (m,) and covariances (m, 2, 2): rank-one fit."""
    if len(amps) == 1:
        return amps[0], covs[0]
    phi = amps[int(np.argmax([np.linalg.norm(a) for a in amps]))]
    for _ in range(PASSES):
        info, total = np.zeros((phi.size, 2, 2)), np.zeros((phi.size, 2))
        for A, C in zip(amps, covs):
            a = np.vdot(phi, A) / np.vdot(phi, phi).real
            u = A / a
            rot = np.array([[np.cos(-np.angle(a)), -np.sin(-np.angle(a))],
                            [np.sin(-np.angle(a)), np.cos(-np.angle(a))]])  # multiplication by 1 / a's phase
            P = np.linalg.pinv(rot @ C @ rot.T / abs(a) ** 2)
            info += P
            total += np.einsum("mij,mj->mi", P, np.stack([u.real, u.imag], -1))
        cov = np.linalg.pinv(info)
        mean = np.einsum("mij,mj->mi", cov, total)
        phi = mean[:, 0] + 1j * mean[:, 1]
    return phi, cov


def free_decay_shapes(traces: Sequence[Trace], records: Sequence[np.ndarray], dt: float, omega: np.ndarray,
                      zeta: np.ndarray, applied: np.ndarray, shapes: np.ndarray,
                      shape_std: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The complex shapes (m, k) (unit norm) and their standard errors
    (m, k) in the reported normalisation, with those of the modes whose pole
    the refinement ``applied`` (k,) replaced by the least-squares fit at the
    reported poles ``omega`` (rad/s), ``zeta`` (module docstring); the
    others as given. Unchanged when no record is a free decay. ``shape_std``
    None (no standard errors wanted, ``uncertainty="off"``): NaN throughout."""
    applied = np.asarray(applied, bool)
    stated = shape_std is not None
    shape_std = np.full(shapes.shape, np.nan) if shape_std is None else shape_std
    starts = free_starts(traces, records)
    if not applied.any() or isinstance(starts, str):
        return shapes, shape_std
    modelled = (zeta > 0) & (zeta < 1)
    poles = (-zeta * omega + 1j * omega * np.sqrt(np.maximum(1 - zeta**2, 0.0)))[modelled]
    n = int(np.ceil(DECAYS / np.min((zeta * omega)[modelled]) / dt))
    fits = []
    for y, start in zip(records, starts):
        part = y[:, start:start + n]
        if part.shape[1] <= 2 + 2 * poles.size:
            return shapes, shape_std
        fits.append(_amplitudes(part, np.arange(part.shape[1]) * dt, poles))
    column = np.cumsum(modelled) - 1  # mode -> its column among the modelled poles
    shapes, shape_std = shapes.copy(), shape_std.copy()
    for i in np.flatnonzero(applied & modelled):
        j = column[i]
        phi, cov = _combined([a[:, j] for a, _ in fits], [c[:, j] for _, c in fits])
        re, im = phi.real, phi.imag
        theta = 0.5 * np.arctan2(2 * np.sum(re * im), np.sum(re**2) - np.sum(im**2))
        rotated = (phi * np.exp(-1j * theta)).real
        peak = rotated[np.argmax(np.abs(rotated))]
        g = np.array([np.cos(theta), np.sin(theta)])
        shapes[:, i] = phi / np.linalg.norm(phi)
        if stated:
            shape_std[:, i] = np.sqrt(np.maximum(np.einsum("i,mij,j->m", g, cov, g), 0.0)) / abs(peak)
    return shapes, shape_std
