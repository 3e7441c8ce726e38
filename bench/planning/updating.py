"""Cramer-Rao bounds of element parameters updated from the modes of a free decay.

What ``--method updating`` uses from a free decay is what an output-only
modal identification gives it: natural frequencies and mode shapes at the
sensors in unknown scale. The signal model of :mod:`.free_decay` is kept,
channel ``c`` (shape row ``c``, time-derivative order ``k_c``):

    y_c(t) = sum_r exp(-s_r t) (a_cr cos(wd_r t) + b_cr sin(wd_r t)) + n_c(t),
    (a_cr, b_cr) = phi_cr(alpha) M_r^k_c (A_r, B_r),   M_r = -s_r I + wd_r [[0, 1], [-1, 0]],

with the model's mass-normalised shapes ``phi_r(alpha)`` and eigenvalues
``lambda_r(alpha)``, ``wd_r = sqrt(lambda_r - s_r^2)``. The unknowns are the
scale factors ``alpha`` (q,) of the updated parameters (``p_j = p0_j (1 +
alpha_j)``, as the identifier has them) and, per mode, the nuisance decay
rate ``s_r`` (damping is not updated) and modal amplitudes ``(A_r, B_r)``
(the shape's scale and the initial conditions, which the identifier does
not use). Derivatives: ``dlambda_r/dalpha`` and ``dphi_r/dalpha`` at the
sensors by Nelson's method (``identifier.updating.sensitivity``); with
``Phi = [g_r, h_r]`` (m, 2R), ``Psi = t Phi`` and ``z_c = (a, b, s, wd)``,
``dy_c = [Phi, Psi L_c] dz_c`` (``L_c`` of :mod:`.free_decay`), so

    F = sum_c D_c^T [[Phi^T Phi, Phi^T Psi L_c], [L_c^T Psi^T Phi, L_c^T Psi^T Psi L_c]] D_c / sigma_c^2,

``D_c = dz_c / d(alpha, s, A, B)``. The nuisance block is eliminated (Schur
complement) and ``Cov(alpha) >= F_aa^+``; ``std(p_j) = p0_j std(alpha_j)``.

Where the modes cannot tell parameters apart (a common scale of mass and
stiffness leaves every frequency ratio and shape unchanged) the reduced
information is singular: its rank, the undetermined combinations and the
parameters loaded on them (``predicted_std`` None) are reported, as the
identifier reports them. Modes that are not visible (:mod:`.free_decay`)
carry no information. Fails (:class:`UserError`) for a modal model, a test
that is not a free decay, or noise other than ``rms``.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la

from structbench.harness.test_entries import TestSpec
from structbench.identifier.updating.sensitivity import AffineModel
from structbench.models import Model, Structure
from structbench.models.errors import UserError

from .free_decay import MAX_MODES, Decay, grams, observe

RANK_TOL = 1e-12  # least eigenvalue of the reduced information, relative to the largest (1e-6 on singular values)
LOADED = 0.01  # a parameter whose unit vector has more than this share in the undetermined subspace


def _powers(s: np.ndarray, wd: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``M^k``, ``dM^k/ds`` and ``dM^k/dwd`` (R, 2, 2) of ``M = -s I + wd J``."""
    R = s.size
    J = np.array([[0.0, 1.0], [-1.0, 0.0]])
    M = -s[:, None, None] * np.eye(2) + wd[:, None, None] * J
    power = np.broadcast_to(np.eye(2), (R, 2, 2)).copy()
    previous = np.zeros((R, 2, 2))
    for _ in range(k):
        previous, power = power, power @ M
    # M commutes with J: d(M^k)/ds = -k M^(k-1), d(M^k)/dwd = k J M^(k-1)
    return power, -k * previous, k * (J @ previous)


def _jacobian(phi: np.ndarray, dphi: np.ndarray, dlam: np.ndarray, d: Decay, order: int) -> np.ndarray:
    """``D_c`` (4R, q + 3R) of one channel: rows ``(a_r, b_r)`` interleaved then
    ``(s_r, wd_r)`` interleaved; columns ``alpha``, then ``s_r``, ``A_r``, ``B_r``.
    ``phi`` (R,) and ``dphi`` (R, q) are the channel's shape entries and their
    derivatives, ``dlam`` (R, q) the eigenvalue derivatives."""
    R, q = phi.size, dphi.shape[1]
    s, wd = d.alpha, d.wd
    v = np.stack([d.A, d.B], axis=1)                                      # (R, 2)
    Mk, dMs, dMw = _powers(s, wd, order)
    u = np.einsum("rij,rj->ri", Mk, v)                                    # (R, 2)
    dwd_dalpha = dlam / (2 * wd[:, None])                                 # (R, q)
    dwd_ds = -s / wd
    D = np.zeros((4 * R, q + 3 * R))
    r = np.arange(R)
    rows = 2 * r[:, None] + np.arange(2)                                   # (R, 2) rows of (a_r, b_r)
    du_dwd = np.einsum("rij,rj->ri", dMw, v)
    # alpha: the shape entry and, through wd, the derivative rotation
    D[rows.ravel(), :q] = (dphi[:, None, :] * u[:, :, None] + phi[:, None, None] * du_dwd[:, :, None]
                           * dwd_dalpha[:, None, :]).reshape(2 * R, q)
    du_ds = np.einsum("rij,rj->ri", dMs, v) + du_dwd * dwd_ds[:, None]
    D[rows, q + r[:, None]] = phi[:, None] * du_ds
    D[rows, q + R + r[:, None]] = phi[:, None] * Mk[:, :, 0]
    D[rows, q + 2 * R + r[:, None]] = phi[:, None] * Mk[:, :, 1]
    # (s_r, wd_r)
    D[2 * R + 2 * r, q + r] = 1.0
    D[2 * R + 2 * r + 1, :q] = dwd_dalpha
    D[2 * R + 2 * r + 1, q + r] = dwd_ds
    return D


def _information(d: Decay, beta: np.ndarray, sigma: np.ndarray, phi: np.ndarray, dphi: np.ndarray,
                 dlam: np.ndarray, orders: np.ndarray) -> np.ndarray:
    """Fisher information (q + 3R, q + 3R) on ``(alpha, s, A, B)`` summed over channels."""
    PP, SP, SS = grams(d)
    R = d.omega.size
    total = np.zeros((dlam.shape[1] + 3 * R,) * 2)
    for c in np.flatnonzero(sigma > 0):
        a, b = beta[c, :, 0], beta[c, :, 1]
        L = np.zeros((2 * R, 2 * R))
        i = 2 * np.arange(R)
        L[i, i], L[i + 1, i], L[i, i + 1], L[i + 1, i + 1] = -a, -b, b, -a
        top = np.hstack([PP, SP.T @ L])
        G = np.vstack([top, np.hstack([L.T @ SP, L.T @ SS @ L])])
        D = _jacobian(phi[c], dphi[c], dlam, d, int(orders[c]))
        total += D.T @ G @ D / sigma[c] ** 2
    return total


def reduced_covariance(F: np.ndarray, q: int) -> tuple[np.ndarray, int, np.ndarray]:
    """Covariance (q, q) of ``alpha`` (pseudo-inverse of the Schur complement
    of the nuisance block of ``F``), its rank and the undetermined directions
    (q, q - rank) as columns."""
    Faa, Fan, Fnn = F[:q, :q], F[:q, q:], F[q:, q:]
    info = Faa - Fan @ la.lstsq(Fnn, Fan.T, cond=1e-14)[0]
    info = 0.5 * (info + info.T)
    w, V = la.eigh(info)
    keep = w > RANK_TOL * max(w.max(initial=0.0), 1e-300)
    cov = (V[:, keep] / w[keep]) @ V[:, keep].T
    return cov, int(keep.sum()), V[:, ~keep]


def updating_bounds(model: Model, test: TestSpec, kinds: tuple[str, ...] | None = None) -> dict:
    """Predicted standard errors (SI) of the mass and stiffness parameters
    (``kinds``: default the model's unknown kinds less damping) updated from
    the modes of the free decay ``test``: ``parameters`` ``{label, unit,
    value, predicted_std}`` (None where undetermined), ``rank``,
    ``undetermined`` (per combination its four largest components) and the
    modes used (``modes_used``, rad/s)."""
    if not isinstance(model, Structure):
        raise UserError(f"updating planning needs a finite-element model; {model.name} is modal", field="--model")
    chosen = tuple(k for k in (kinds or model.unknown) if k != "damping")
    sel = np.flatnonzero(model.kind_mask(chosen))
    if sel.size == 0:
        raise UserError(f"{model.name} has no unknown mass or stiffness parameter to update", field="--model")
    o = observe(model, test)
    d, rows = o.d, o.rows
    if not d.omega.size:
        raise UserError(f"no mode of {model.name} is visible in test {test.group!r}", field="sensors")
    affine = AffineModel(model, sel, rows)
    M, K = affine.matrices(np.zeros(sel.size))
    lam, phi_all = affine.modes(M, K, min(model.n_dof, MAX_MODES + 6))  # rigid-body modes too
    index = [int(np.argmin(np.abs(lam - w**2))) for w in d.omega]
    dlam, dphi = np.empty((d.omega.size, sel.size)), np.empty((rows.size, d.omega.size, sel.size))
    phi = np.empty((rows.size, d.omega.size))
    for r, i in enumerate(index):
        sign = np.sign(phi_all[:, i] @ d.shapes[:, r]) or 1.0
        dl, dp = affine.derivatives(M, K, lam[i], phi_all[:, i])
        dlam[r], dphi[:, r], phi[:, r] = dl, sign * dp, sign * phi_all[rows, i]
    F = _information(d, o.beta, o.sigma, phi, dphi, dlam, o.orders)
    cov, rank, null = reduced_covariance(F, sel.size)
    loaded = np.sum(null**2, axis=1) > LOADED
    labels = [model.parameters[j].label for j in sel]
    p0 = model.values[sel]
    params = [{"label": lab, "unit": model.parameters[j].unit, "value": float(v),
               "predicted_std": None if void else float(abs(v) * np.sqrt(max(c, 0.0)))}
              for lab, j, v, c, void in zip(labels, sel, p0, np.diag(cov), loaded)]
    combos = [[{"label": labels[i], "weight": float(vec[i])} for i in np.argsort(-np.abs(vec))[:4]]
              for vec in null.T]
    return {"parameters": params, "rank": rank, "undetermined": combos, "modes_used": d.omega.tolist(),
            "channels": [c.name for c in o.channels]}
