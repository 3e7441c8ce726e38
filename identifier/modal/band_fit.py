"""A stationary record's reported modes against their own bands: where one
oscillator term fitted to the band's periodogram puts the pole far from
SSI's, SSI's standard errors are widened by the distance (the stationary
counterpart of :mod:`identifier.modal.refine`'s widening in free decays).

For each reported mode ``c`` (``omega_c`` rad/s, damping ``zeta_c``,
standard errors ``se_omega``, ``se_zeta``), on the summed unit-RMS
periodogram of the records (:func:`identifier.modal.peak_test.summed_periodogram`)
over the band ``|omega - omega_c| <= h``
(:func:`identifier.modal.peak_test.half_width`, 10 half-power half-widths,
at least 32 lines), with the background and the reported neighbours that
the band resolves as :func:`identifier.modal.peak_test.peak_lr` models
them (``S0``), one term ``M(omega; w, z) = L(omega; w, z) sum_q a_q
(omega / w)^2q`` (displacement, velocity, acceleration; ``a_q >= 0``) is
fitted by Whittle maximum likelihood over ``(w, z)``: a grid of
``GRID`` frequencies over ``omega_c +- h / 2`` times
``peak_test.ZETA_STEPS`` x ``zeta_c``, then Nelder-Mead from the grid's
best. When the fitted pole is more than ``MOVE`` standard errors from
SSI's in ``omega`` or in ``zeta`` and the band prefers it,

    LR = 2 (log L(w_f, z_f) - log L(omega_c, zeta_c)) > chi2_2^-1(1 - ALPHA),

the two estimates disagree by more than SSI states: its errors become
``sqrt(se^2 + Delta^2)`` (``Delta``: the move in omega, in zeta). So they
do too when the band prefers its pole (``LR`` over the level) and the move
``d = (Delta_omega, Delta_zeta)`` exceeds the two estimates' combined errors,

    d^T (diag(se_omega^2, se_zeta^2) + C)^-1 d > chi2_2^-1(1 - ALPHA),

``C`` (2, 2) the band fit's covariance (:func:`curvature`: the inverse of
minus the profile log-likelihood's Hessian at its pole); under a move of
under ``MOVE`` SSI errors a biased broad pole was otherwise left with
errors that miss both estimates (held-out profile seed 1,011,930: 3.303 +-
0.076 rad/s, zeta 0.097, the band's pole 3.008, 3.9 errors away at ``LR``
45, the true mode 2.870). Independent estimates of one pole differ by
more than that with probability ``ALPHA`` (both errors' Gaussian
approximations; SSI's and the band's estimates share the record's noise,
so their difference varies less than the sum says: conservative). The
value reported stays SSI's (it uses every channel's phase; the band fit
the summed power only). ``LR`` against ``chi2(2)`` assumes the Whittle
approximation (lines independent, exponential for one channel, less
scattered for sums: conservative) and a smooth background over the band.

Applied to records that neither are nor were taken for free decays
(:mod:`identifier.modal.refine` widens those from its own fit).
Assumptions: the band is at least 3 lines; white sensor noise. Fails
(widens a good mode) where a peak that is no mode (a harmonic, a
coloured force) or an unresolved neighbour pulls the band fit, and
leaves a biased pole unwidened where the band cannot tell the two poles
apart (``LR`` under the level: a short record's flat likelihood).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np
from scipy.optimize import minimize
from scipy.stats import chi2 as chi_square

from . import peak_test
from .refine import MOVE, PoleRefinement
from .support import less_coherent_after

GRID = 21  # frequencies of the band fit's starting grid
STEP = 0.05  # finite-difference steps of the band fit's curvature, x its half-width (omega) and x its zeta
ALPHA = 0.01  # level at which the band's likelihood prefers the fitted pole to SSI's


def band_pole(summed: np.ndarray, lines: np.ndarray, T: float, omega: np.ndarray, zeta: np.ndarray,
              c: int) -> tuple[float, float, float, np.ndarray] | None:
    """``(w, z, LR, C)``: the pole (rad/s, damping ratio) of one oscillator
    term fitted to candidate ``c``'s band of the summed periodogram
    ``summed`` at ``lines`` rad/s of records ``T`` s long, its likelihood
    ratio against the term at ``(omega[c], zeta[c])`` and its covariance
    (2, 2) (:func:`curvature`); reported modes at
    ``omega`` (k,) rad/s, damping ``zeta`` (k,). None for a band of under
    3 lines."""
    z = np.maximum(np.abs(zeta), 1e-6)
    half = float(peak_test.half_width(omega[c:c + 1], z[c:c + 1], T)[0])
    inside = peak_test.band(summed, lines, omega[c], half)
    if inside is None:
        return None
    P, w, size = inside
    x = (w - omega[c]) / half
    others = [term for j in range(omega.size)
              if j != c and abs(omega[j] - omega[c]) > z[j] * omega[j] + z[c] * omega[c]
              for term in peak_test.neighbour_terms(w, omega[j], z[j])]
    X0 = np.column_stack([1.0 - x, 1.0 + x] + others)
    _, a0 = peak_test.whittle(P, X0, size)

    def loglik(w0: float, z0: float) -> float:
        X = np.column_stack([X0] + peak_test.neighbour_terms(w, w0, z0))
        return peak_test.whittle(P, X, size, np.r_[a0, np.zeros(X.shape[1] - X0.shape[1])])[0]

    grid = [(loglik(w0, z[c] * s), w0, z[c] * s)
            for w0 in omega[c] + half * np.linspace(-0.5, 0.5, GRID) for s in peak_test.ZETA_STEPS]
    _, w0, z0 = max(grid)
    best = minimize(lambda v: -loglik(v[0], np.exp(v[1])), [w0, np.log(z0)], method="Nelder-Mead",
                    options={"xatol": 1e-4, "fatol": 1e-3, "maxiter": 80})
    w_f, z_f = float(best.x[0]), float(np.exp(best.x[1]))
    return w_f, z_f, 2.0 * float(-best.fun - loglik(omega[c], z[c])), curvature(loglik, w_f, z_f)


def curvature(loglik: Callable[[float, float], float], w0: float, z0: float) -> np.ndarray:
    """(2, 2) covariance of the band fit's ``(omega, zeta)``: the inverse of
    minus the Hessian of the profile log-likelihood ``loglik(w, z)`` at its
    pole ``w0`` rad/s, ``z0``, by central differences of ``STEP`` times the
    half-power half-width ``z0 w0`` and times ``z0``; NaN where the Hessian
    is not negative definite (a pole at the edge of its band or of a flat
    likelihood)."""
    h = STEP * np.array([z0 * w0, z0])
    f = {(a, b): loglik(w0 + a * h[0], z0 + b * h[1]) for a in (-1, 0, 1) for b in (-1, 0, 1)}
    cross = (f[1, 1] - f[1, -1] - f[-1, 1] + f[-1, -1]) / (4.0 * h[0] * h[1])
    info = -np.array([[(f[1, 0] - 2.0 * f[0, 0] + f[-1, 0]) / h[0] ** 2, cross],
                      [cross, (f[0, 1] - 2.0 * f[0, 0] + f[0, -1]) / h[1] ** 2]])
    return np.linalg.inv(info) if np.all(np.linalg.eigvalsh(info) > 0) else np.full((2, 2), np.nan)


def widen(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray, omega_std: np.ndarray,
          zeta_std: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``omega_std``, ``zeta_std`` (k,) of reported modes at ``omega`` (k,)
    rad/s, damping ``zeta`` (k,) in stationary records (m, n_i) sampled at
    ``dt`` s, widened where the band fit disagrees (module docstring), and
    per mode the reason ("" where unchanged). Modes without finite
    standard errors are left alone."""
    omega_std, zeta_std = omega_std.copy(), zeta_std.copy()
    reasons = [""] * omega.size
    if omega.size == 0:
        return omega_std, zeta_std, reasons
    summed, lines, T = peak_test.spectrum(records, dt)
    level = chi_square.isf(ALPHA, 2)
    for c in np.flatnonzero(np.isfinite(omega_std) & np.isfinite(zeta_std) & (omega_std > 0) & (zeta_std > 0)):
        fitted = band_pole(summed, lines, T, omega, zeta, c)
        if fitted is None:
            continue
        w, z, lr, C = fitted
        dw, dz = abs(w - omega[c]), abs(z - abs(zeta[c]))
        d = np.array([dw, dz])
        apart = float(d @ np.linalg.solve(np.diag([omega_std[c] ** 2, zeta_std[c] ** 2]) + C, d)) \
            if np.all(np.isfinite(C)) else 0.0  # the move against both estimates' errors
        if (max(dw / omega_std[c], dz / zeta_std[c]) > MOVE or apart > level) and lr > level:
            reasons[c] = (f"errors widened: the band's one-term fit puts the pole at {w:.6g} rad/s, zeta {z:.3g} "
                          f"({dw / omega_std[c]:.3g} and {dz / zeta_std[c]:.3g} standard errors away, {apart:.3g} "
                          f"in chi2_2 against both fits' errors; likelihood ratio {lr:.3g}, over {level:.3g})")
            omega_std[c], zeta_std[c] = np.hypot(omega_std[c], dw), np.hypot(zeta_std[c], dz)
    return omega_std, zeta_std, reasons


def checked(records: list[np.ndarray], dt: float, modes: PoleRefinement, coherence: list[float | None],
            length: float, stationary: bool, exempt_below: float) -> tuple[PoleRefinement, list[str], list[dict]]:
    """The reported ``modes`` of records (m, n_i) sampled at ``dt`` s, of
    total ``length`` s, their errors widened by :func:`widen` (stationary
    records only; otherwise as they are); a mode of temporal coherence
    (``coherence`` (k,), None: unknown) under ``exempt_below`` that the
    widened errors leave unresolved from a more coherent reported one is
    dropped (:func:`identifier.modal.support.less_coherent_after`). Returns the
    modes kept, :func:`widen`'s reasons for them and the dropped ones as
    ``details.rejected`` entries."""
    if not stationary:
        return modes, [""] * modes.omega.size, []
    omega_std, zeta_std, reasons = widen(records, dt, modes.omega, modes.zeta, modes.omega_std, modes.zeta_std)
    modes = replace(modes, omega_std=omega_std, zeta_std=zeta_std)
    if not any(reasons):
        return modes, reasons, []
    keep, dropped = less_coherent_after(modes.omega, modes.zeta, omega_std,
                                        np.array([np.nan if c is None else c for c in coherence]), length,
                                        exempt_below)
    return modes.subset(keep), [r for r, k in zip(reasons, keep) if k], dropped
