"""Standard errors of SSI-cov frequencies and damping ratios by the
delete-one-group jackknife.

The covariance sums are kept per sample group (``G`` groups,
:mod:`identifier.ssi_covariance`). Replicate ``g`` repeats the identification
from the covariances of every group but ``g`` at up to five model orders
spread over those that support each mode, picks at each the pole nearest the mode (frequency within
5 %, MAC > 0.8) and takes the medians, as the full-data estimate does. With
``theta_g`` the replicates and ``theta_.`` their mean,

    se^2 = (G - 1) / G sum_g (theta_g - theta_.)^2     (Quenouille-Tukey).

Assumes the groups' noise contributions are nearly independent: contiguous
segments longer than the response's correlation time (stationary records) or
interleaved blocks longer than the lags (free decay). With few groups the
estimate has ``G - 1`` degrees of freedom; a mode not found in some replicate
gets NaN (no error stated): in a free decay a mode that has died out within
the first block of samples is seen by one group only.
"""
from __future__ import annotations

import numpy as np

from .ssi_covariance import Covariances, hankel
from .ssi_poles import Poles, leading_svd, mac_matrix, poles_at, subspace

Target = tuple[tuple[int, ...], float, np.ndarray]  # (model orders, omega rad/s, complex shape (m,))


def _replicate(cov: Covariances, group: int, rows: tuple[int, int], start: np.ndarray, targets: list[Target]) -> np.ndarray:
    """(k, 2): omega and zeta of each target mode in one replicate, medians
    over the mode's orders of the matching poles (NaN if found in fewer than
    half of them); its singular vectors by one subspace step from the full
    data's ``start``."""
    m = cov.sums.shape[2]
    space = subspace(leading_svd(hankel(cov.mean(leave_out=group), *rows), start.shape[1], start), m)
    poles = {n: poles_at(space, n, cov.dt, cov.scale) for n in sorted({n for t in targets for n in t[0]})}
    out = np.full((len(targets), 2), np.nan)
    for k, (orders, omega, shape) in enumerate(targets):
        found = [_match(poles[n], omega, shape) for n in orders]
        found = [f for f in found if f is not None]
        if 2 * len(found) >= len(orders):
            out[k] = np.median(found, axis=0)
    return out


def _match(poles: Poles, omega: float, shape: np.ndarray) -> tuple[float, float] | None:
    """(omega, zeta) of the pole within 5 % of ``omega`` with the best MAC (> 0.8) to ``shape``."""
    near = np.abs(poles.omega - omega) / omega < 0.05
    if not near.any():
        return None
    score = np.where(near, mac_matrix(shape[:, None], poles.shapes)[0], -1.0)
    j = int(np.argmax(score))
    return (poles.omega[j], poles.zeta[j]) if score[j] > 0.8 else None


def jackknife(cov: Covariances, rows: tuple[int, int], start: np.ndarray, targets: list[Target]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Standard errors (k,) of omega (rad/s) and zeta of the target modes
    (``rows`` block rows and columns; ``start`` the full data's leading
    singular vectors), NaN for a mode missing from a replicate; and how many
    replicates missed each mode (k,)."""
    if not targets:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=int)
    groups = cov.sums.shape[0]
    reps = np.stack([_replicate(cov, g, rows, start, targets) for g in range(groups)])
    se = np.sqrt((groups - 1) / groups * np.sum((reps - reps.mean(axis=0)) ** 2, axis=0))
    return se[:, 0], se[:, 1], np.sum(np.isnan(reps[:, :, 0]), axis=0)
