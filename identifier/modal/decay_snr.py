"""Whether a free response carries a mode above its sensor noise: the
matched-filter test of each candidate pole against white noise.

In a free decay every mode is a damped sinusoid from the response's start,
``y_i(t) = sum_r e^(-sigma_r t) (a_ir cos(omega_dr t) + b_ir sin(omega_dr
t)) + e_i(t)`` with white sensor noise ``e_i`` of variance ``s_i^2``. With
the candidate poles ``s_r = -sigma_r + i omega_dr`` (all of them: the
modes judged and the candidates already rejected, which take up what they
fit, but for rejected ones within a kept mode's bandwidth) the records are
projected on these ``2 K`` columns, per channel and
trace. The extra sum of squares that mode ``r``'s two columns explain
beyond the others, ``ESS_ir = c_ir^T (V_rr)^-1 c_ir`` (``c_ir`` its two
coefficients, ``V_rr`` their 2 x 2 block of ``(X^T X)^-1``), over the
residual variance ``s_i^2 = |y_i - X c_i|^2 / (n - 2 K)``, summed over the channels and
traces, is

    chi2_r = sum_i ESS_ir / s_i^2  ~  chi-square(2 M)

when the pole fits only noise (``M`` channel records). SSI picks a noise
pole at whichever of the record's ``n / 2`` independent frequencies fits
the noise best, so the threshold carries that look-elsewhere factor: a
mode is supported when ``chi2_r > chi2.isf(ALPHA / (n / 2), 2 M)``.
A true mode's ``chi2_r`` is its energy over the noise's per sample, ``sum_i
|A_ir|^2 / (4 sigma_r dt s_i^2)``; a noise pole's is the noise's
own largest fluctuation.

The fit starts at the first sample where the records' standardised power
reaches a quarter of its peak within the first tenth (an impulse after a
pre-trigger; sample 0 for an initial condition). Assumes white sensor noise, independent between
channels, and a response that is a sum of the candidate poles' decays
(a mode SSI did not see, or a pole of a wrong damping, leaves a misfit
that inflates ``s_i^2``: conservative; the median over tenths of the
record instead kept one weak true mode under a strong mode's misfit in
the tuning seeds, but let a noise pole beside an unseen mode through). Fails
(keeps a noise pole) when the noise is coloured or correlated between
channels; fails (drops a true mode) when its energy is under the
look-elsewhere threshold, which no test on this record could tell from
noise.

After the ML refinement (:mod:`.refine`) the reported modes are tested again
at their refined poles (:func:`retest`, same level): a strong mode's
SSI pole a little off leaves a misfit at the record's start that a weak
noise pole beside it takes up, over the threshold at SSI's poles and under
it at the refined ones (docs/modal-method.md, issue 21's eighth round).
There a crowded pair is left untested only within ``2 pi / T``; a pole
whose damped exponential correlates with a neighbour's over ``OVERLAP``
(:func:`correlation`) is tested at the look-elsewhere factor of their
band, and one within a neighbour's half-power band that correlates less
(a lightly damped pole on a broad mode's flank) as any other.
"""
from __future__ import annotations


import numpy as np
from scipy.stats import chi2

from .refine import PoleRefinement
from .support import Verdict

ALPHA = 0.01  # chance that the record's noise alone passes one mode's test, over all frequencies
OVERLAP = 2 ** -0.5  # least correlation of two poles' damped exponentials that the record does not resolve


def start(y: np.ndarray) -> int:
    """The first sample of ``y`` (m, n) where the sum over channels of the
    squares of the unit-RMS channels reaches a quarter of its largest value
    within the first tenth (the response's start, not a later peak of it)."""
    z = y / np.maximum(np.sqrt(np.mean(y**2, axis=1, keepdims=True)), np.finfo(float).tiny)
    power = np.sum(z[:, :max(y.shape[1] // 10, 1)] ** 2, axis=0)
    return int(np.argmax(power >= 0.25 * power.max()))


def statistics(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray,
               others: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``chi2_r`` (k,) of the poles ``omega`` (k,) rad/s, ``zeta`` (k,) in the
    free responses ``records`` (each (m, n), sampled at ``dt`` s), fitted
    beside the nuisance poles ``others`` ((j, 2): omega, zeta), and the
    threshold (k,) each must exceed (module docstring). Zero where a pole's
    columns vanish (it has decayed before the first sample); NaN (both)
    when the records leave no degree of freedom for the noise."""
    omega, zeta = np.asarray(omega, dtype=float), np.asarray(zeta, dtype=float)
    k = omega.size
    extra = np.zeros((0, 2)) if others is None else np.asarray(others, dtype=float).reshape(-1, 2)
    w = np.r_[omega, extra[:, 0]]
    z = np.clip(np.r_[zeta, extra[:, 1]], -0.05, 0.99)
    total = np.zeros(k)
    dof = 0
    looks = 1
    for y in records:
        y = y[:, start(y):]
        n = y.shape[1]
        if n <= 2 * w.size + 2:
            return np.full(k, np.nan), np.full(k, np.nan)
        t = np.arange(n) * dt
        sigma, wd = z * w, w * np.sqrt(np.maximum(1 - z**2, 0.0))
        envelope = np.exp(-np.outer(t, sigma))  # (n, K)
        X = np.hstack([envelope * np.cos(np.outer(t, wd)), envelope * np.sin(np.outer(t, wd))])  # (n, 2K)
        norms = np.linalg.norm(X, axis=0)
        X = X / np.where(norms > 0, norms, 1.0)
        V = np.linalg.pinv(X.T @ X, rcond=1e-12, hermitian=True)  # (X^T X)^-1 of unit columns
        b = X.T @ y.T  # (2K, m)
        coef = V @ b
        s2 = np.maximum(np.sum(y**2, axis=1) - np.sum(b * coef, axis=0), 0.0) / (n - 2 * w.size)  # (m,)
        for r in range(k):
            idx = [r, r + w.size]
            c = coef[idx]  # (2, m)
            block = V[np.ix_(idx, idx)]
            ess = np.einsum("am,ab,bm->m", c, np.linalg.pinv(block), c)
            with np.errstate(over="ignore"):  # a noise-free channel's statistic is inf: the mode is kept
                total[r] += np.sum(ess / np.maximum(s2, np.finfo(float).tiny))
        dof += 2 * y.shape[0]
        looks = max(looks, n // 2)
    return total, np.full(k, chi2.isf(ALPHA / looks, dof))


def screen(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray, verdict: Verdict,
           others: list[dict], overlap: bool = False) -> Verdict:
    """``verdict`` on the candidate modes ``omega`` (k,) rad/s, ``zeta`` (k,)
    of free responses ``records`` with each mode it keeps also tested
    against the sensor noise (:func:`statistics`; the candidates it does not
    keep and ``others``, ``details.rejected`` entries, fitted beside them,
    but for those within ``max(2 pi / T, zeta_a omega_a + zeta_b omega_b)``
    of a kept mode: the same pole, which would take up its fit). Kept modes
    within that distance of each other (a close pair the record does not
    resolve: their columns share one fit) are left to the pair tests; with
    ``overlap`` only those within ``2 pi / T``: the others are tested, one
    whose damped exponential correlates with a kept neighbour's over
    ``OVERLAP`` (:func:`correlation`; for two equally damped poles the
    bandwidth bound above, and a narrow pole on a broad one's flank is
    resolved) at the look-elsewhere factor of their joint band ``2 (sigma_a
    + sigma_b)`` (``1 + 2 (sigma_a + sigma_b) T / 2 pi`` frequencies) in
    place of the record's ``n / 2``: a noise pole that close has no other
    place to be. A record leaving no degree of freedom for the noise
    changes nothing."""
    keep = verdict.keep
    if not keep.any():
        return verdict
    nuisance = np.array([(w, z) for w, z, k in zip(omega, zeta, keep) if not k]
                        + [(r["omega"], r["zeta"]) for r in others]).reshape(-1, 2)
    length = max(y.shape[1] for y in records) * dt
    near = np.abs(nuisance[:, None, 0] - omega[None, keep]) < np.maximum(
        2 * np.pi / length, np.abs(nuisance[:, None, 1]) * nuisance[:, None, 0]
        + np.abs(zeta[None, keep]) * omega[None, keep])  # within a kept mode's bandwidth: the same pole
    nuisance = nuisance[~near.any(axis=1)]
    value, needed = statistics(records, dt, omega[keep], zeta[keep], nuisance)
    w, z = omega[keep], np.abs(zeta[keep])
    crowded = np.abs(w[:, None] - w[None, :]) < np.maximum(2 * np.pi / length, z[:, None] * w[:, None] + z * w)
    np.fill_diagonal(crowded, False)  # a pair the record does not resolve shares its fit: left to the pair tests
    if overlap:  # tested beside a partner it correlates with, at the look-elsewhere factor of the partner's band
        near = crowded & (correlation(w, z, length) > OVERLAP)
        crowded &= np.abs(w[:, None] - w[None, :]) < 2 * np.pi / length
        bins = np.max(np.where(near, (z * w)[:, None] + z * w, 0.0), axis=1, initial=0.0) * length / np.pi + 1
        dof = 2 * sum(y.shape[0] for y in records)
        needed = np.where(near.any(axis=1) & np.isfinite(needed), chi2.isf(ALPHA / bins, dof), needed)
    fails = np.zeros(keep.size, dtype=bool)
    fails[keep] = (value < needed) & ~crowded.any(axis=1)  # NaN: no verdict
    reasons = [f"matched-filter chi-square {v:.3g} under the sensor noise's {t:.3g} (free response)"
               if f else r
               for r, f, v, t in zip(verdict.reasons, fails, _spread_to(value, keep), _spread_to(needed, keep))]
    return Verdict(keep & ~fails, reasons)


def _spread_to(values: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """``values`` (keep.sum(),) placed at the ``keep`` entries of a (k,) array of NaN."""
    out = np.full(keep.size, np.nan)
    out[keep] = values
    return out


def correlation(omega: np.ndarray, zeta: np.ndarray, length: float) -> np.ndarray:
    """``|<e_a, e_b>| / (|e_a| |e_b|)`` (k, k) of the poles' complex damped
    exponentials ``e_r(t) = exp(lambda_r t)``, ``lambda_r = -zeta_r omega_r +
    i omega_r`` (rad/s), over ``0 <= t <= length`` s: ``|g_ab| / sqrt(g_aa
    g_bb)`` with ``g_ab = (exp(s T) - 1) / s``, ``s = lambda_a + conj(lambda_b)``.
    Two equally damped poles (``sigma``) of a long record correlate as ``2
    sigma / sqrt(4 sigma^2 + delta omega^2)``: ``1 / sqrt 2`` at ``delta
    omega = 2 sigma``, the bandwidth rule of :func:`screen`."""
    lam = -np.abs(zeta) * omega + 1j * omega
    s = lam[:, None] + lam.conj()[None, :]
    g = np.where(np.abs(s) * length > 1e-9, np.expm1(s * length) / np.where(s == 0, 1.0, s), length)
    norm = np.sqrt(np.abs(np.diag(g)))
    return np.abs(g) / np.maximum(np.outer(norm, norm), np.finfo(float).tiny)


def retest(records: list[np.ndarray], dt: float, ml: PoleRefinement, others: list[dict]
           ) -> tuple[PoleRefinement, list[dict]]:
    """The reported modes of a free decay after the ML refinement ``ml``
    (:mod:`.refine`) tested again against the sensor noise at their refined
    poles (:func:`screen`, ``overlap``; ``others`` the ``details.rejected``
    entries, fitted beside them): SSI's poles leave a strong mode's misfit
    (its damping a little off) that leaks into weak poles beside it, the
    refined ones do not. Returns ``ml`` without the modes that fail and
    their ``details.rejected`` entries; unchanged when nothing was refined."""
    if not ml.details.get("applied"):
        return ml, []
    verdict = screen(records, dt, ml.omega, ml.zeta, Verdict(np.ones(ml.omega.size, bool), [""] * ml.omega.size),
                     others, overlap=True)
    gone = [{"omega": float(w), "zeta": float(z), "reason": f"{r} at the refined poles"}
            for w, z, r, k in zip(ml.omega, ml.zeta, verdict.reasons, verdict.keep) if not k]
    return ml.subset(verdict.keep), gone
