"""Predicted standard errors of the least-squares element parameters.

The regression of :mod:`structbench.identifier.least_squares.regression`:
at sample ``k`` the equation errors ``e_k = B_k p_u - y_k`` (n,) N, with
``B_k`` (n, q) the columns ``dM_j a_k``, ``dC_j v_k``, ``dK_j u_k`` of the
unknown parameters. Built from the *noise-free* simulated responses
(:mod:`.response`), with the channel noise of the campaign
(``sigma^2`` per channel, 4 n channels ``[a, v, u, f]``), the equation errors
of one sample have the covariance

    S = Mt^T diag(sigma^2) Mt    (n, n),   e_k = Mt^T x_k  at the true theta,

and the regression's Fisher information (Gaussian, white in time) is

    F = sum_k B_k^T S^-1 B_k      (q, q),     Cov(p_u) >= F^-1  (Cramer-Rao),

which is the first-order covariance of the identifier's noise-whitened,
bias-compensated estimator (the sandwich collapses to ``F^-1`` when its
weighting is ``S^-1``). The regressors themselves are noisy (errors in
variables: accelerations in the mass columns), and where the parameters
are weakly determined that matters at second order; the prediction adds it,

    Cov(p_u) = F^-1 + F^-1 M2 F^-1,   M2 = sum_k Cov(delta B_k^T S^-1 delta e_k)

(:func:`regressor_noise`, Gaussian noise), which took the predicted
standard errors of a shear frame under a random force from 0.81 to 1.0 of
the Monte Carlo spread; on the chapter 3 beam it adds about 1 %. Above :data:`DENSE_DOF` DOF the identifier weights
each DOF row by ``w_r = 1 / sqrt(S_rr)``; the prediction then is the
``H^-1``, ``H = sum_k B_k^T W B_k`` (the sandwich with ``diag(S)``: the
coupling of the rows' errors through ``M`` is neglected there).

Assumptions: noise zero-mean, white, independent between channels, and (in
``proportional`` mode) replaced by its time average as the identifier's
weighting does; second-order noise terms (``sigma^4``) neglected, which
holds while the noise-to-signal ratios are small (say < 10 %). Fails
(:class:`UserError`) when the parameters are not identifiable (singular
``F``) or a DOF lacks an acceleration, velocity or displacement channel.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la

from structbench.identifier.least_squares import Motion
from structbench.identifier.least_squares import whitened
from structbench.identifier.least_squares.regression import DENSE_DOF, error_variance, gram, layout, moments
from structbench.models import Structure
from structbench.models.errors import UserError

from .response import Response

RESPONSES = ("acceleration", "velocity", "displacement")


def motion(model: Structure, response: Response) -> Motion:
    """The noise-free :class:`Motion` (every sample) with the channels' noise
    sigma; a response quantity missing at some DOF raises :class:`UserError`."""
    m, n = response.time.size, model.n_dof
    data = {q: np.zeros((m, n)) for q in (*RESPONSES, "force")}
    sigma = {q: np.zeros((m, n)) for q in data}
    seen = {q: set() for q in data}
    for c in response.channels:
        j = model.dof_index(*c.dof)
        data[c.quantity][:, j] += response.signals[c.name]
        sigma[c.quantity][:, j] = np.hypot(sigma[c.quantity][:, j], response.sigma[c.name])
        seen[c.quantity].add(j)
    for q in RESPONSES:
        if len(seen[q]) != n:
            missing = [model.dofs[j] for j in range(n) if j not in seen[q]][:3]
            raise UserError(f"least-squares planning needs the {q} of every DOF (the identifier's measured "
                            f"set-up); missing at {', '.join(f'{a}{b}' for a, b in missing)}", field="sensors")
    if not seen["force"]:
        raise UserError("least-squares planning needs a force channel (load cell) where the force acts",
                        field="sensors")
    return Motion(response.time, data["displacement"], data["velocity"], data["acceleration"], data["force"],
                  sigma)


def least_squares_covariance(model: Structure, motions: list[Motion]) -> tuple[list[str], np.ndarray]:
    """Labels and predicted covariance (q, q) of the unknown parameters
    (``model.kind_mask()``) from the noise-free ``motions`` of one run (SI units squared)."""
    mask = model.kind_mask()
    u = np.flatnonzero(mask)
    labels = [p.label for p, keep in zip(model.parameters, mask) if keep]
    theta = np.append(model.values, -1.0)
    lay = layout(model)
    total = Motion.stack(motions)
    if model.n_dof <= DENSE_DOF:
        mom = moments(lay, total, raw_gram=True)
        S = whitened.error_covariance(lay, mom.noise / mom.samples, theta)
        if not np.any(S):
            raise UserError("the campaign's test has no sensor noise: the standard errors are zero",
                            field="noise")
        S[np.diag_indices_from(S)] += 1e-12 * np.trace(S) / S.shape[0]
        omega = la.inv(S)
        G, _ = whitened.gram(lay, mom.raw_gram, mom.noise, omega)
        H = G.toarray()[np.ix_(u, u)]
        M2 = regressor_noise(lay, mom.noise / mom.samples, theta, omega, u) * mom.samples
    else:
        mom = moments(lay, total)
        var = error_variance(lay, mom, theta)
        if not np.any(var):
            raise UserError("the campaign's test has no sensor noise: the standard errors are zero",
                            field="noise")
        w = 1.0 / np.sqrt(var + 1e-12 * var.mean())
        G, _ = gram(lay, mom, w)
        H = G.toarray()[np.ix_(u, u)]
        M2 = np.zeros_like(H)
    scale = np.sqrt(np.abs(np.diag(H)))
    if np.any(scale == 0):
        bad = [labels[i] for i in np.flatnonzero(scale == 0)]
        raise UserError(f"not identifiable from this test (not excited): {', '.join(bad[:5])}", field="excitation")
    Hs = H / np.outer(scale, scale)
    eig = la.eigvalsh(Hs)
    if eig[0] <= 1e-14 * eig[-1]:
        raise UserError("the parameters are not identifiable from this test (singular Fisher information, "
                        f"condition {eig[-1] / max(eig[0], 1e-300):.3g})", field="excitation")
    Hinv = la.inv(Hs) / np.outer(scale, scale)
    return labels, Hinv + Hinv @ M2 @ Hinv


def regressor_noise(lay, noise_mean: np.ndarray, theta: np.ndarray, omega: np.ndarray,
                    u: np.ndarray) -> np.ndarray:
    """Per sample, the covariance (q, q) of the second-order score
    ``s_j = eps^T A_j eps`` (``delta B^T Omega delta e``: the regressors' own
    noise times the equation noise), ``eps`` (4 n,) the raw channel noise of
    variances ``noise_mean``:

        Cov(s_i, s_j) = tr(A_i Sig (A_j + A_j^T) Sig),   A_j = W[:, P_j] (Omega Mt^T)[row(P_j), :],

    ``P_j`` the (row, column) pairs of parameter ``j``. With ``U = s o W`` and
    ``V = (Omega Mt^T o s)[row, :]`` (``s = sqrt(noise_mean)``) both traces are
    sums over pairs: ``P^T ((V U) o (V U)^T + (U^T U) o (V V^T)) P``. Dense
    in the pairs: for models up to :data:`DENSE_DOF` DOF."""
    s = np.sqrt(noise_mean)
    live = np.flatnonzero(s > 0)
    mt = whitened.equation_matrix(lay, theta)  # (4 n, n)
    keep = np.flatnonzero(np.isin(lay.pair_col, u))
    U = (lay.W[live][:, keep].multiply(s[live][:, None])).toarray()  # (channels, pairs)
    V = (omega @ mt[live].T * s[live][None, :])[lay.pair_row[keep]]  # (pairs, channels)
    VU = V @ U
    pair_term = VU * VU.T + (U.T @ U) * (V @ V.T)
    col = np.searchsorted(u, lay.pair_col[keep])
    P = np.zeros((keep.size, u.size))
    P[np.arange(keep.size), col] = 1.0
    return P.T @ pair_term @ P

