"""Close pairs of modes from two or more free-response records, by
maximum-likelihood fits of the whole records.

SSI-cov uses lags of a few seconds, so two modes whose poles differ by
``delta = lambda_a - lambda_b`` with ``|delta| T << 1`` over the record length
``T`` look like one (or come out as two with mixed shapes). Over the whole
record the pair shows as a ``t e^(lambda t)`` term that one pole cannot give
(:mod:`identifier.modal.close_pairs.pair`). Steps, at level ``alpha`` split over the
``K`` modes (Bonferroni, ``alpha / K`` each; ``K`` the reported modes and
those step 2 reports):

1. Each record's channels are divided by their noise level ``s_ri``: the RMS
   of the residual of the fit with the SSI poles and their ``t e^(lambda t)``
   terms (:mod:`identifier.modal.close_pairs.free_decay_fit`; these terms take up the poles'
   errors and close pairs; at least ``FLOOR`` x the channel's RMS, so that on
   noise-free records the tiny misfit of the SSI poles does not count).
2. Modes SSI did not report but that residual holds (a peak of the summed
   periodogram ``P(omega) = sum 2 |DFT r|^2 / n ~ chi^2(2M)`` over the ``M``
   weighted columns, above its ``1 - alpha / bins`` quantile, further than ``NEAR``
   bins ``2 pi / T`` from every pole) are fitted and added (at most ``K``),
   so that their signal does not leak into the tests; the noise levels are
   estimated again. Such a mode (one SSI dropped: a pair whose poles mix
   their shapes differently at every model order fails stabilisation's MAC
   test or the jackknife's) is reported when its peak's p-value (Bonferroni
   over the bins) is below ``DISCOVERY`` (noise alone passes ``alpha`` in a
   fraction ``alpha`` of the identifications: a weaker peak is fitted, not
   reported): split if it passes step 4, else as one mode fitted with
   residues of rank one across the records.
3. Candidates: a reported mode whose residual holds a ``t e^(lambda t)`` term
   (score test, :func:`identifier.modal.close_pairs.pair.score_statistics`, at level
   ``alpha``: it only picks candidates, the tests of step 4 decide), two
   reported modes with ``|delta omega| T < RESOLVED``, and the modes step 2 reports.
4. A candidate is split (or its reported pair refitted) only if the records
   move it in different proportions: the residues ``[c_1 ... c_R]`` of its
   pole (with a ``t e^(lambda t)`` term) are not rank one
   (:func:`identifier.modal.close_pairs.pair.rank_one_misfit` above its ``chi^2`` quantile).
   From the eigenvalues of ``D^+ C`` (:func:`identifier.modal.close_pairs.pair.pencil`) it
   is then fitted as one mode and as two, each with residues of rank one across
   the records (:mod:`identifier.modal.close_pairs.rank_one_fit`, poles within ``RESOLVED / T``
   of its pole, the other poles held). The pair is kept when (a) the
   likelihood ratio ``(f_1 - f_2) / s^2`` exceeds the quantile of
   ``chi^2(2 + m + 2 (R - 1))`` (the second mode's pole, shape, participations),
   (b) ``delta`` differs from 0 by the Wald test ``delta^T cov^-1 delta`` on
   ``chi^2(2)``, and (c) neither pole stops at the band's edge. A genuine single
   mode fails (a), a pair moved in one proportion by every record (no record
   tells the shapes apart) fails step 4, a repeated root (residues of rank two,
   no splitting) fails (b): each stays as SSI reported it (a mode of step 2
   as one mode).
5. With the noise levels estimated again (the pairs now in the model) each
   kept pair and each mode step 2 reports is fitted once more; its frequencies,
   damping ratios and standard errors come from that fit (Gauss-Newton
   covariance), its shapes are the fitted (real) ``phi``.

Needs two or more records: from one, a pair's shapes rest on second-order
terms alone. Assumes free response from the start of each record (a linear
structure, normal modes, white noise). Fails to split a pair whose splitting
shows less than the noise over the records; a mode SSI missed that lies
between ``RESOLVED / T`` and ``NEAR`` bins from a reported one stays missed.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
from scipy.stats import chi2

from ...errors import IdentificationError
from .pair import first_order, pencil, rank_one_misfit, score_statistics
from .free_decay_fit import Group, Projection, basis, fit_poles, omega_zeta, project
from .local_space import REACH, local_space
from .rank_one_fit import Layout, ModeFit, fit_modes
from ..runtime import one_blas_thread
from ...io.traces import Trace

ALPHA = 0.01
FLOOR = 1e-6  # least noise standard deviation, x channel RMS
NEAR = 2.0  # frequency bins (2 pi / T) around a pole that belong to it
DISCOVERY = 1e-6  # p-value below which a mode found in the residual is reported
RESOLVED = REACH / np.sqrt(2)  # rad: |delta omega| T of a pair SSI may get wrong; the fits' band is +- RESOLVED / T
FREE_KINDS = ("impulse", "initial")
REFINE = ("auto", "off")


def free_start(trace: Trace) -> int | None:
    """First sample of the free response of a trace whose excitation
    (``/excitation`` attribute ``kind``) is only impulses and initial
    conditions: after the last impulse's pulse (one force step) or at its
    time (``method = "initial-velocity"``); None for any other excitation."""
    kinds = str(trace.excitation_attrs.get("kind", "")).split("+")
    if not all(k in FREE_KINDS for k in kinds):
        return None
    items = trace.excitation_attrs.get("spec") or [{"kind": k} for k in kinds]
    end = max([it.get("time", 0.0) + (trace.step if it.get("method", "pulse") == "pulse" else 0.0)
               for it in items if it.get("kind") == "impulse"], default=0.0)
    return int(np.ceil(end / trace.dt - 1e-9))


@dataclass(frozen=True)
class Refinement:
    """The modes after splitting (k >= input count): ``omega`` rad/s,
    ``zeta``, standard errors, complex ``shapes`` (m, k) of unit norm,
    ``source`` (k,) the input mode each comes from (-1: found in the fit's
    residual, step 2), ``refined`` (k,) True for the modes whose values come
    from the free-decay fit (a split pair, a mode found in the residual)."""

    omega: np.ndarray
    zeta: np.ndarray
    omega_std: np.ndarray
    zeta_std: np.ndarray
    shapes: np.ndarray
    source: np.ndarray
    refined: np.ndarray


def weighted_groups(records: list[np.ndarray], dt: float, poles: np.ndarray
                    ) -> tuple[list[Group], list[Layout], list[Projection], list[np.ndarray]]:
    """The records (each (m, n_r)) grouped by length, each channel divided by
    its noise level; the groups' layouts, projections on ``poles`` and the
    first-order residuals (n, M_g), all weighted. The noise level is the
    RMS of the residual with ``poles`` and their ``t e^(lambda t)`` terms, which
    take up both an error of a pole and a close pair: what is left is noise
    and modes missing from ``poles``."""
    groups, layouts, projections, firsts = [], [], [], []
    for n in sorted({y.shape[1] for y in records}):
        which = np.array([r for r, y in enumerate(records) if y.shape[1] == n])
        z = np.hstack([records[r].T for r in which])
        t = np.arange(n) * dt
        b = basis(t, poles)
        first = project(Group(t, z), np.column_stack([b, t[:, None] * b[:, 2:]])).resid
        s = np.sqrt(np.sum(first**2, axis=0) / max(n - 2 - 4 * poles.size, 1))
        s = np.maximum(s, FLOOR * np.sqrt(np.mean(z**2, axis=0)) + np.finfo(float).tiny)
        groups.append(Group(t, z / s))
        layouts.append(Layout(which, s.reshape(which.size, -1), n))
        projections.append(project(groups[-1], b))
        firsts.append(first / s)
    return groups, layouts, projections, firsts


def residual_peak(resids: list[np.ndarray], poles: np.ndarray, dt: float, alpha: float
                  ) -> tuple[float, float] | None:
    """Frequency (rad/s) and p-value (Bonferroni over the bins) of the
    significant peak of the summed periodogram of the weighted residuals
    (n_g, M_g) away from every pole (module docstring, step 2), or None."""
    nfft = max(r.shape[0] for r in resids)
    power = sum(2 * np.sum(np.abs(np.fft.rfft(r, nfft, axis=0)) ** 2, axis=1) / r.shape[0] for r in resids)
    step = 2 * np.pi / (nfft * dt)
    freq = np.arange(power.size) * step
    ok = (freq > 0) & (freq < np.pi / dt)
    ok &= np.all(np.abs(freq[:, None] - poles.imag[None, :]) > NEAR * step, axis=1)
    if not ok.any():
        return None
    b = int(np.argmax(np.where(ok, power, -np.inf)))
    columns = sum(r.shape[1] for r in resids)
    p = chi2.sf(power[b], 2 * columns) * ok.sum()
    return (float(freq[b]), float(p)) if p < alpha else None


def candidates(omega: np.ndarray, flagged: np.ndarray, span: float) -> list[tuple[int, ...]]:
    """Neighbouring reported modes (ascending ``omega``) with ``|delta omega| T <
    RESOLVED``, and the flagged modes not in such a pair."""
    pairs: list[tuple[int, ...]] = []
    for j in np.flatnonzero(np.diff(omega) * span < RESOLVED):
        if not pairs or pairs[-1][1] != j:
            pairs.append((int(j), int(j) + 1))
    taken = {j for pair in pairs for j in pair}
    return pairs + [(int(j),) for j in flagged if j not in taken]


def _split(groups: list[Group], layouts: list[Layout], poles: np.ndarray, idx: tuple[int, ...], span: float,
           level: float) -> tuple[complex, ModeFit] | None:
    """The centre (the mean pole of the modes ``idx``: one, or a reported
    pair) and two-mode fit if it passes the tests of step 4, else None."""
    merged = np.concatenate([[poles[list(idx)].mean()], np.delete(poles, idx)])
    fo = first_order(groups, layouts, merged, 0)
    misfit, df = rank_one_misfit(fo)
    if chi2.sf(misfit, df) >= level:  # the records move the mode(s) in one proportion: no split
        return None
    single, start, part = pencil(fo, merged[0])
    half = RESOLVED / span
    if not np.all(np.abs(start - merged[0]) < half):
        start = poles[list(idx)] if len(idx) == 2 else merged[0] + 0.5j * half * np.array([-1.0, 1.0])
        part = np.vstack([single, single])
    locs = [local_space(g, merged[1:], merged[0]) for g in groups]
    one = fit_modes(locs, layouts, merged.size - 1, merged[:1], single)
    two = fit_modes(locs, layouts, merged.size - 1, start, part)
    m, records = two.shapes.shape[0], two.participations.shape[1]
    ratio = (one.rss - two.rss) / (two.rss / two.dof)
    diff = np.array([[1.0, 0, -1, 0], [0, 1, 0, -1]])
    delta = diff @ np.column_stack([two.poles.real, two.poles.imag]).ravel()
    wald = delta @ la.pinvh(diff @ two.cov @ diff.T) @ delta
    offset = two.poles - merged[0]
    inside = np.all(np.maximum(np.abs(offset.real), np.abs(offset.imag)) < (1 - 1e-6) * half)
    ok = ratio > chi2.isf(level, 2 + m + 2 * (records - 1)) and wald > chi2.isf(level, 2) and inside
    return (merged[0], two) if ok else None


def split_free_decays(traces: Sequence[Trace], records: list[np.ndarray], dt: float, omega: np.ndarray,
                      zeta: np.ndarray, shapes: np.ndarray, omega_std: np.ndarray, zeta_std: np.ndarray,
                      refine: str) -> Refinement:
    """:func:`split_close_modes` on the traces' free responses (``records``
    (m, n) from the first sample on) when ``refine`` is ``auto`` and there are
    at least two traces, each a free response (:func:`free_start`); else the
    modes unchanged (from one record a pair's shapes rest on second-order
    terms alone)."""
    if refine not in REFINE:
        raise IdentificationError(f"unknown refine {refine!r}; known: {', '.join(REFINE)}", field="refine")
    starts = [free_start(t) for t in traces]
    if refine == "off" or None in starts or len(traces) < 2:
        k = omega.size
        return Refinement(omega, zeta, omega_std, zeta_std, shapes, np.arange(k), np.zeros(k, dtype=bool))
    return split_close_modes([y[:, k:] for y, k in zip(records, starts)], dt, omega, zeta, shapes,
                             omega_std, zeta_std)


def split_close_modes(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray,
                      shapes: np.ndarray, omega_std: np.ndarray, zeta_std: np.ndarray,
                      alpha: float = ALPHA) -> Refinement:
    """Modes (``omega`` rad/s ascending, ``zeta``, complex ``shapes`` (m, K),
    standard errors) with every close pair refitted or split out of one mode
    (module docstring); ``records`` the free responses (m, n_r) from their start, ``dt`` s."""
    k = omega.size
    rows = [(omega[j], zeta[j], omega_std[j], zeta_std[j], shapes[:, j], j, False) for j in range(k)]
    if k:
        with one_blas_thread():  # small factorisations: threads only cost here
            rows = _refine(records, dt, omega, zeta, rows, alpha)
    rows = sorted(rows, key=lambda r: r[0])
    cols = list(zip(*rows)) if rows else [[]] * 7
    return Refinement(*(np.array(c, dtype=float) for c in cols[:4]),
                      np.column_stack(cols[4]) if rows else shapes, np.array(cols[5], dtype=int),
                      np.array(cols[6], dtype=bool))


def _single(groups: list[Group], layouts: list[Layout], poles: np.ndarray, j: int) -> tuple[complex, ModeFit]:
    """Pole ``j`` fitted as one mode with residues of rank one across the
    records (participations started from the leading singular vector of its
    first-order residues ``C``)."""
    _, sv, vh = la.svd(first_order(groups, layouts, poles, j).c, full_matrices=False)
    others = np.delete(poles, j)
    locs = [local_space(g, others, poles[j]) for g in groups]
    return poles[j], fit_modes(locs, layouts, others.size, poles[[j]], (sv[0] * vh[0])[None, :])


def _refine(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray, rows: list,
            alpha: float) -> list:
    """Steps 1-5 of the module docstring on the rows (omega, zeta, their
    errors, shape, source, refined) of the SSI modes."""
    k = omega.size
    poles = -zeta * omega + 1j * omega * np.sqrt(np.maximum(1 - zeta**2, 0.0))
    span = max(y.shape[1] for y in records) * dt
    step = 2 * np.pi / span
    found = []  # the modes of step 2: index in poles, reported (p-value below DISCOVERY)
    while True:
        groups, layouts, projections, firsts = weighted_groups(records, dt, poles)
        peak = residual_peak(firsts, poles, dt, alpha) if poles.size < 2 * k else None
        if peak is None:
            break
        found.append((poles.size, peak[1] < DISCOVERY))
        band = (peak[0] - step, peak[0] + step)
        poles = np.append(poles, fit_poles(groups, poles, np.array([1j * peak[0]]), band))
    stats, df = score_statistics(groups, projections, poles, k)
    new = [(j,) for j, report in found if report]
    level = alpha / (k + len(new))
    fits = []
    for idx in candidates(omega, np.flatnonzero(chi2.sf(stats, df) < alpha), span) + new:
        fit = _split(groups, layouts, poles, idx, span, level)
        if fit is None and idx[0] >= k:  # a mode found in the residual that does not split: one mode
            fit = _single(groups, layouts, poles, idx[0])
        if fit is not None:
            fits.append((idx, *fit))
    if not fits:
        return rows
    # the noise levels again, without the fitted modes' t e^(lambda t) terms in the residual, and the fits repeated
    taken = [j for idx, _, _ in fits for j in idx]
    poles = np.concatenate([np.delete(poles, taken)] + [fit.poles for _, _, fit in fits])
    groups, layouts, _, _ = weighted_groups(records, dt, poles)
    rows = [r for j, r in enumerate(rows) if j not in taken]
    for idx, center, fit in fits:
        others = poles[~np.isin(poles, fit.poles)]
        locs = [local_space(g, others, center) for g in groups]
        fit = fit_modes(locs, layouts, others.size, fit.poles, fit.participations)
        w, z, se_w, se_z = omega_zeta(fit.poles, fit.cov)
        rows += [(w[a], z[a], se_w[a], se_z[a], fit.shapes[:, a] / la.norm(fit.shapes[:, a]),
                  idx[0] if idx[0] < k else -1, True) for a in range(fit.poles.size)]
    return rows
