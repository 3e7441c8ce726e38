"""FRF estimators, coherence and random-error confidence bands from
averaged spectra ``S_ff`` (m,), ``S_xx`` (c, m), ``S_fx = <conj(F) X>`` (c, m).

- ``H1 = S_fx / S_ff``: unbiased by noise on the response, biased low by
  noise on the force (``|H1| = |H| / (1 + N_ff / S_ff)``);
- ``H2 = S_xx / S_xf`` with ``S_xf = conj(S_fx)``: unbiased by noise on the
  force, biased high by noise on the response (``|H2| = |H| (1 + N_xx / S_xx,true)``);
- ``Hv``: the total-least-squares estimate, the eigenvector of the smallest
  eigenvalue of ``[[S_ff, S_xf], [S_fx, S_xx]]``,
  ``Hv = (S_xx - S_ff + sqrt((S_xx - S_ff)^2 + 4 |S_fx|^2)) / (2 S_xf)``;
  unbiased when force and response noise have equal spectra in their SI
  units, otherwise between the two: ``|H1| <= |Hv| <= |H2|``;
- ordinary coherence ``gamma^2 = |S_fx|^2 / (S_ff S_xx)``, and
  ``H1 = gamma^2 H2``.

Random error (Bendat & Piersol, Random Data, 4th ed., ch. 9, for
``n_d`` independent averages): the normalized random error of ``|H|`` and
the standard deviation of its phase (rad) are both
``eps = sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d))``; the bands are
``|H| (1 +- z eps)`` and ``arg H +- z eps`` with ``z`` the normal quantile of
the two-sided ``confidence``. The formulas hold for small ``eps`` (roughly
``eps < 0.2``) and use the estimated coherence, itself biased high with few
averages (by about ``(1 - gamma^2)^2 / n_d``).
"""
from __future__ import annotations

import numpy as np
from scipy.special import ndtri

ESTIMATORS = ("H1", "H2", "Hv")


def frf(estimator: str, s_ff: np.ndarray, s_xx: np.ndarray, s_fx: np.ndarray) -> np.ndarray:
    """The FRF (c, m) by ``estimator`` (``H1``, ``H2`` or ``Hv``); NaN on lines
    where the needed spectra vanish."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if estimator == "H1":
            return s_fx / s_ff
        if estimator == "H2":
            return s_xx / np.conj(s_fx)
        if estimator == "Hv":
            diff = s_xx - s_ff
            return (diff + np.sqrt(diff**2 + 4.0 * np.abs(s_fx) ** 2)) / (2.0 * np.conj(s_fx))
    raise ValueError(f"unknown estimator {estimator!r}; known: {', '.join(ESTIMATORS)}")


def coherence(s_ff: np.ndarray, s_xx: np.ndarray, s_fx: np.ndarray) -> np.ndarray:
    """Ordinary coherence ``|S_fx|^2 / (S_ff S_xx)`` (c, m), clipped to [0, 1]; NaN where a spectrum is 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.clip(np.abs(s_fx) ** 2 / (s_ff * s_xx), 0.0, 1.0)


def random_error(gamma2: np.ndarray, n_effective: np.ndarray) -> np.ndarray:
    """``sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d))`` (c, m); NaN where ``n_d < 2``
    (one average: coherence is 1 by construction and says nothing)."""
    n = np.asarray(n_effective, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        eps = np.sqrt(1.0 - gamma2) / (np.sqrt(gamma2) * np.sqrt(2.0 * n))
    return np.where(n >= 2.0, eps, np.nan)


def bands(h: np.ndarray, eps: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """``(magnitude_band, phase_band)``, each (2, c, m): lower and upper bounds
    ``|H| (1 -+ z eps)`` (the lower one not below 0) and ``arg H -+ z eps`` (rad)."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    z = float(ndtri(0.5 + confidence / 2.0))
    mag, phase = np.abs(h), np.angle(h)
    magnitude_band = np.stack([np.maximum(mag * (1.0 - z * eps), 0.0), mag * (1.0 + z * eps)])
    phase_band = np.stack([phase - z * eps, phase + z * eps])
    return magnitude_band, phase_band
