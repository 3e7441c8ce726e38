"""Modes the model of :mod:`identifier.modal.refine` misses, and misfit at its poles.

After the first fit the weighted
residual is searched for modes the model misses (a mode SSI did not see
leaves its signal there and, near a reported mode, biases it): the
periodogram ``sum_m 2 |DFT r_m|^2 / L`` of its first ``L = n, n/4, n/16, ...``
samples (a strongly damped mode lasts a small part of the record) is
``chi^2(2M)`` per bin under white noise; a peak further than ``NEAR`` bins
plus their decay rates from every pole, below level ``ALPHA`` Bonferroni
over the bins and lengths, gets a pole fitted there (the others held) and
joins the nuisance terms; at most ``MAX_ADDED``.

The misfit test: per pole the score test for a ``t e^(lambda t)`` term in the
weighted residual (:func:`identifier.modal.close_pairs.pair.score_statistics`).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la
from scipy.stats import chi2

from .close_pairs.free_decay_fit import Group, basis, project
from .close_pairs.pair import score_statistics
from .ml_fit import Solver, VarPro, fit_poles

ALPHA = 0.01  # level of the search for modes missing from the model (Bonferroni over bins and lengths)
NEAR = 2.0  # frequency bins around a pole (plus its decay rate) that belong to it in that search
MIN_SEARCH = 64  # shortest stretch of the record searched
MAX_ADDED = 8  # poles found in the residual (modes neither reported nor rejected) at most


def residual_peak(resids: list[np.ndarray], poles: np.ndarray, dt: float) -> tuple[float, float, float] | None:
    """The most significant peak (frequency rad/s, decay rate 1/s, p-value)
    of the residuals (n_g, M_g; unit white noise under the null) away from
    every pole, or None above ``ALPHA``. A free decay's mode lasts ``1 / sigma``,
    often a small part of the record, and its energy spreads over ``sigma``
    rad/s of the whole record's periodogram: the search runs over the first
    ``L = n, n/4, n/16, ...`` samples (down to ``MIN_SEARCH``), the periodogram
    ``P = sum_m 2 |DFT r_m|^2 / L`` of each is ``chi^2(2M)`` per bin, bins within
    ``NEAR`` bins plus a pole's decay rate of it excluded; p-values
    Bonferroni over the bins and the lengths."""
    n = max(r.shape[0] for r in resids)
    lengths = []
    length = n
    while length >= MIN_SEARCH:
        lengths.append(length)
        length //= 4
    best = None
    for length in lengths:
        power = sum(2 * np.sum(np.abs(np.fft.rfft(r[:length], axis=0)) ** 2, axis=1) / length
                    for r in resids if r.shape[0] >= length)
        columns = sum(r.shape[1] for r in resids if r.shape[0] >= length)
        step = 2 * np.pi / (length * dt)
        freq = np.arange(power.size) * step
        ok = (freq > 0) & (freq < np.pi / dt)
        ok &= np.all(np.abs(freq[:, None] - poles.imag[None, :]) > NEAR * step - poles.real[None, :], axis=1)
        if not ok.any():
            continue
        b = int(np.argmax(np.where(ok, power, -np.inf)))
        p = chi2.sf(power[b], 2 * columns) * ok.sum() * len(lengths)
        if p < ALPHA and (best is None or p < best[2]):
            best = (float(freq[b]), 1.0 / (length * dt), float(p))
    return best


def missing_poles(ts: list[np.ndarray], zs: list[np.ndarray], poles: np.ndarray, dt: float,
                  bases: list[np.ndarray] | None = None) -> np.ndarray:
    """Poles of modes the model misses: while the weighted residual has a
    significant peak away from every pole (:func:`residual_peak`), a pole
    fitted there (within a bin of the peak, the others held); at most
    ``MAX_ADDED``. ``bases``: per group ``basis(t, poles)`` where the caller has it."""
    added: list[complex] = []
    bs = [basis(t, poles) for t in ts] if bases is None else bases
    for _ in range(MAX_ADDED):
        every = np.concatenate([poles, added])
        try:
            resids = [Solver(b).coefficients(z)[1] for b, z in zip(bs, zs)]
        except la.LinAlgError:
            break
        peak = residual_peak(resids, every, dt)
        if peak is None:
            break
        w0, rate, _ = peak
        step = 2 * np.pi * rate
        lower = np.array([-2 * w0, max(w0 - step, 0.5 * w0)])
        upper = np.array([-1e-9 * w0, min(w0 + step, np.pi / dt)])
        stretch = int(np.ceil(4 / (rate * dt)))  # where the peak shows: fitted there
        part = [t[:stretch] for t in ts], [z[:stretch] for z in zs]
        lam, _, _, _ = fit_poles(*part, every, np.array([complex(-min(rate, 0.5 * w0), w0)]), lower, upper,
                                 fit=VarPro(*part, every, [b[:stretch] for b in bs]))
        added.append(complex(lam[0]))
        bs = [np.hstack([b, basis(t, lam[:1])[:, 2:]]) for b, t in zip(bs, ts)]
    return np.array(added, dtype=complex)


def misfit_pvalues(ts: list[np.ndarray], zs: list[np.ndarray], poles: np.ndarray, tested: int) -> np.ndarray:
    """Per tested pole (the first ``tested`` of ``poles``) the p-value
    (Bonferroni over them) of the score test for a ``t e^(lambda t)`` term
    in the weighted residual (:func:`identifier.modal.close_pairs.pair.score_statistics`,
    ``chi^2(2M - 2)``): an unresolved second mode or another misfit at the pole."""
    groups = [Group(t, z) for t, z in zip(ts, zs)]
    try:
        projections = [project(g, basis(g.t, poles)) for g in groups]
    except (la.LinAlgError, ValueError):
        return np.zeros(tested)
    stats, df = score_statistics(groups, projections, poles, tested)
    return np.minimum(chi2.sf(stats, df) * tested, 1.0) if df > 0 else np.ones(tested)
