"""Modes of a free decay that SSI missed, found in the residual of the
reported ones and added when a nested F test says they are needed.

A free decay is a sum of damped sinusoids plus white noise (the model of
:mod:`.refine`), so a mode SSI never made a candidate (weak and well
damped beside strong light modes: fitted at high orders only, or not at
all; docs/modal-method.md "Findable misses") is in the residual of the
reported poles. After the refinement, the matched filter and the pair
test, the candidates are the refinement's nuisance poles (rejected SSI
candidates and the terms its residual search found) and the poles
:func:`identifier.modal.ml_residual.missing_poles` fits at the peaks of the
weighted residual of every pole so far (reported and nuisance) over the
record's first ``DECAYS`` decay times of its slowest reported mode. Tested
are those with damping in (0, 1), under Nyquist and not at an edge of the
record's band (:mod:`.band_edges`: a filter's ringing after the record's
start is a damped sinusoid too), with ``FREE_PERIODS``
periods and ``MIN_DECAYS`` decay times in the record, and resolved from
every reported pole and every nuisance pole that is no candidate
(:func:`_candidates`).

Each candidate ``c`` is tested beside its neighbours in frequency by the
free-decay pair test's nested F test
(:func:`identifier.modal.decay_pairs.pvalues`: ``c`` and its one or two
neighbours free against the neighbours alone, every other pole held, on
``DECAYS`` decay times of the slowest of them; look-elsewhere factor
``n / 2``), with every other candidate in both models as a nuisance term,
Bonferroni over the ``k`` candidates:

    c is added when  k (n / 2) P(F(2 M + 2, nu) > F) < ALPHA,

``ALPHA`` 1e-4: issue 21 asks for no false mode in 1,000 records, and a
test at 0.001 per record adds one in about every 1,000 free decays. The
most significant is added if the ML fit of it and its reported neighbours
(:func:`identifier.modal.ml_fit.fit_poles` on the refinement's stretch,
the other poles held) converges with ``c`` off the bounds with finite
errors and the matched filter at the refined poles
(:func:`identifier.modal.decay_snr.screen`) keeps it: its pole and
standard errors are that fit's (its covariance), and so are its
neighbours' (a reported mode of damping outside (0, 1), not in the
model, within ``max(2 pi / T, zeta omega)`` of it is dropped: the fitted
pole is the model's estimate of it); then the search is repeated, at
most ``MAX_ADDED`` times. Its shape is the least-squares one of
:mod:`.free_shapes` (``applied``, ``source`` -1). When any was added,
every mode goes through the pair test again (:func:`identifier.modal.decay_pairs.screen`):
an SSI pole over two modes that the search resolved is then not needed.

Assumes the refinement's model (white noise per channel, a free response
from each trace's start); the level holds only there. Fails (adds a false
mode) when a structured misfit (a mode the poles fit badly: a cluster of
heavily damped modes fitted by fewer poles) leaves a residual that one
more pole fits better than the residual variance says; misses a mode
weaker than the threshold, one not resolved from a reported pole (two
heavily damped modes closer than their bandwidths), or one of under
``MIN_DECAYS`` decay times. A record with no reported mode (in a short
record of one channel SSI has one model order and nothing is stable) is
searched from the empty model: the residual is the whole record's past the
nuisance poles, and each candidate is tested against offset, drift and
nuisance terms alone (:func:`alone`, the same F test without neighbours).
Records that are not free decays (:func:`identifier.modal.refine.free_starts`)
are not searched.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..io.traces import Trace
from . import band_edges
from .close_pairs.free_decay_fit import omega_zeta
from .decay_pairs import MIN_SAMPLES, extra_ss_pvalue, pvalues, screen, stretch
from .decay_snr import screen as matched_filter
from .ml_fit import VarPro, fit_poles, select
from .ml_residual import missing_poles
from .stabilisation import Criteria
from .refine import DECAYS, PoleRefinement, complex_poles, free_starts, nuisance_poles, pole_bounds, resolved
from .support import FREE_PERIODS, MIN_DECAYS, Verdict

ALPHA = 1e-4  # chance per record that a false mode is added
MAX_ADDED = 3  # modes added to one record at most
ZETA_MAX = Criteria.zeta_max  # an added mode's damping under the stabilisation's bound: what SSI may report


def _candidates(extra: np.ndarray, poles: np.ndarray, dt: float, length: float) -> np.ndarray:
    """Which poles ``extra`` (complex 1/s) may be modes beside the reported
    ``poles``: damping in (0, 1), under Nyquist, at least ``FREE_PERIODS``
    periods and ``MIN_DECAYS`` decay times in ``length`` s (a stationary
    record's rule: one pole over modes the record does not resolve, whose
    beat reads as a decay over a part of a short record, is not added;
    tuning seed 1,000,211), resolved from every reported pole
    (``|delta omega_d| > 2 pi / length + sigma_a + sigma_b``, the rule of
    :func:`identifier.modal.refine.nuisance_poles`: a broad pole over a
    reported one takes up its misfit; tuning seed 1,000,261)."""
    omega = np.abs(extra)
    return (extra.real < 0) & (extra.imag > 0) & (extra.imag < np.pi / dt) & resolved(extra, poles, length) & \
        (omega * length / (2 * np.pi) >= FREE_PERIODS) & (-extra.real * length >= MIN_DECAYS)


def _fit(records: Sequence[np.ndarray], starts: Sequence[int], dt: float, poles: np.ndarray, others: np.ndarray,
         c: complex, length: float) -> tuple[np.ndarray, tuple[np.ndarray, ...]] | None:
    """The candidate ``c`` and its reported neighbours in frequency (one or
    two of ``poles``) fitted jointly by ML, ``others`` and the other reported
    poles held, on ``DECAYS`` decay times of the slowest reported pole or
    ``c``: the neighbours' indices in ``poles`` and ``omega`` rad/s, ``zeta``
    and their standard errors (each (1 + neighbours,), ``c`` first); None if
    the fit does not converge, ``c`` ends on a bound, has no finite error,
    or its fitted pole is no candidate in the ``length`` s record (under
    ``FREE_PERIODS`` periods or ``MIN_DECAYS`` decay times, or damping
    ``ZETA_MAX`` or more)."""
    every = np.concatenate([poles, [c], others])
    n = int(np.ceil(DECAYS / -np.max(np.r_[poles.real, c.real]) / dt))
    ts, zs, bs = stretch(records, starts, dt, every, n)
    order = np.argsort(poles.imag)
    rank = np.searchsorted(poles.imag[order], c.imag)
    near = order[max(rank - 1, 0):rank + 1]
    free = np.r_[c, poles[near]]
    held = np.r_[np.delete(np.arange(poles.size), near), poles.size + 1 + np.arange(others.size)]
    fixed = every[held]
    lower, upper = pole_bounds(free, fixed, dt)
    fitted, cov, ok, edge = fit_poles(ts, zs, fixed, free, lower, upper,
                                      fit=VarPro(ts, zs, fixed, [select(b, held) for b in bs]))
    w, z, sw, sz = omega_zeta(fitted, cov)
    good = ~edge & np.isfinite(sw) & np.isfinite(sz) & (sw > 0) & (sz > 0) & (z > 0) & (z < 1)
    good[0] &= (z[0] < ZETA_MAX) & (w[0] * length / (2 * np.pi) >= FREE_PERIODS) & (z[0] * w[0] * length >= MIN_DECAYS)
    if not ok or not good[0]:
        return None
    return near[good[1:]], tuple(v[good] for v in (w, z, sw, sz))


def search(traces: Sequence[Trace], records: Sequence[np.ndarray], dt: float, ml: PoleRefinement,
           rejected: Sequence[dict], refine: str, edges: tuple[float, float, float, float] | None = None
           ) -> tuple[PoleRefinement, list[dict]]:
    """``ml`` (:mod:`.refine`, after :mod:`.decay_pairs`) with the modes the
    residual search adds (module docstring; ``rejected`` the
    ``details.rejected`` entries: nuisance poles where the refinement was not
    applied, fitted beside the matched filter's); their p-values in
    ``details["ml_refinement"]["search"]``; ``edges``: the records' band
    (:func:`.band_edges.band`, computed when None); and the ``details.rejected``
    entries of the modes the pair test drops afterwards. Unchanged with
    ``refine="off"`` or when a trace is no free decay."""
    starts = free_starts(traces, records)
    if refine == "off" or isinstance(starts, str):
        return ml, []
    length = max(y.shape[1] for y in records) * dt
    nuisance = ml.nuisance if ml.details.get("applied") else np.zeros(0, complex)
    added: list[dict] = []
    edges = band_edges.band(list(records), dt) if edges is None else edges
    for _ in range(MAX_ADDED):
        modelled = ml.modelled
        poles = complex_poles(ml.omega[modelled], ml.zeta[modelled])
        if not ml.details.get("applied"):
            nuisance = nuisance_poles([(r["omega"], r["zeta"]) for r in rejected], poles, dt, length)
        n = int(np.ceil(DECAYS / -np.max(poles.real) / dt)) if poles.size else max(y.shape[1] for y in records)
        ts, zs, bs = stretch(records, starts, dt, np.concatenate([poles, nuisance]), n)
        extra = np.concatenate([nuisance, missing_poles(ts, zs, np.concatenate([poles, nuisance]), dt, bs)])
        ok = _candidates(extra, poles, dt, length) & ~np.array([bool(why) for why in band_edges.at_edges(
            edges, np.abs(extra), -extra.real / np.maximum(np.abs(extra), 1e-300))], bool)
        ok &= _candidates(extra, np.concatenate([poles, extra[~ok]]), dt, length)  # and from the poles held
        # beside them (a held pole of a mode under MIN_DECAYS next to a broad one: tuning seed 1,003,278)
        if not ok.any():
            break
        tested = np.arange(poles.size, poles.size + ok.sum())
        p = pvalues(records, starts, dt, np.concatenate([poles, extra[ok]]), extra[~ok], tested)[0] if poles.size \
            else alone(records, starts, dt, extra[ok], extra[~ok])
        p = p[tested] * ok.sum()
        if not np.nanmin(p, initial=np.inf) < ALPHA:
            break
        best = int(np.nanargmin(p))
        c = extra[ok][best]
        fit = _fit(records, starts, dt, poles, np.delete(extra, np.flatnonzero(ok)[best]), c, length)
        if fit is None:
            break
        near, (w, z, sw, sz) = fit
        omega, zeta = np.append(ml.omega, w[0]), np.append(ml.zeta, z[0])
        verdict = matched_filter(list(records), dt, omega, zeta, Verdict(np.ones(omega.size, bool), [""] * omega.size),
                                 list(rejected), overlap=True)
        if not verdict.keep[-1]:
            break
        added.append({"omega": float(w[0]), "zeta": float(z[0]), "p": float(p[best])})
        nuisance = np.delete(nuisance, np.flatnonzero(nuisance == c))
        ml = _added(ml, np.flatnonzero(modelled)[near], (w, z, sw, sz), length,
                    nuisance if ml.details.get("applied") else ml.nuisance)
    if not added:
        return ml, []
    ml = dataclasses.replace(ml, details=ml.details | {"search": added})
    return screen(traces, records, dt, ml, rejected, refine)


def alone(records: Sequence[np.ndarray], starts: Sequence[int], dt: float, candidates: np.ndarray,
          nuisance: np.ndarray) -> np.ndarray:
    """Per candidate pole (complex 1/s) of a record with no reported mode the
    p-value of the F test of :mod:`.decay_pairs` without neighbours: the
    candidate free (cost ``f_1``) against the ``nuisance`` poles alone
    (``f_0``), on ``DECAYS`` decay times of it (at least ``MIN_SAMPLES`` per
    basis column), ``(n / 2) P(F(2 M + 2, nu) > F)``, before the Bonferroni
    factor; NaN where the fit does not converge or too few samples are left."""
    free_len = max(y.shape[1] - s for y, s in zip(records, starts))
    columns = 2 + 2 * (nuisance.size + 1)
    out = np.full(candidates.size, np.nan)
    for i, c in enumerate(candidates):
        n = int(min(free_len, max(np.ceil(DECAYS / -c.real / dt), MIN_SAMPLES * columns)))
        ts, zs, bs = stretch(records, starts, dt, np.r_[c, nuisance], n)
        m = sum(z.shape[1] for z in zs)
        nu = sum(z.size for z in zs) - m * columns - 2
        fit = VarPro(ts, zs, nuisance, [select(b, 1 + np.arange(nuisance.size)) for b in bs])
        lower, upper = pole_bounds(np.r_[c], nuisance, dt)
        fitted, _, converged, _ = fit_poles(ts, zs, nuisance, np.r_[c], lower, upper, fit=fit)
        with_c = fit.cost(np.column_stack([fitted.real, fitted.imag]).ravel())
        if nu <= 0 or not converged or not with_c > 0:
            continue
        without = fit.cost(np.zeros(0))
        out[i] = extra_ss_pvalue(without, with_c, m, nu, max(len(t) for t in ts))
    return out


def _added(ml: PoleRefinement, near: np.ndarray, fit: tuple[np.ndarray, ...], length: float,
           nuisance: np.ndarray) -> PoleRefinement:
    """``ml`` with the mode ``fit[.][0]`` (omega rad/s, zeta, their standard
    errors) added (``source`` -1, by frequency), its neighbours ``near``
    (indices in ``ml``) given the joint fit's values ``fit[.][1:]``, and
    a reported mode of damping outside (0, 1) (not in the model) within
    ``max(2 pi / length, zeta omega)`` of it dropped: the fitted pole is the
    model's estimate of that mode."""
    w, z, sw, sz = fit
    values = [a.copy() for a in (ml.omega, ml.zeta, ml.omega_std, ml.zeta_std)]
    for v, f in zip(values, fit):
        v[near] = f[1:]
    outside = ~ml.modelled & (np.abs(ml.omega - w[0]) < max(2 * np.pi / length, z[0] * w[0]))
    keep = ~outside
    at = int(np.searchsorted(values[0][keep], w[0]))
    new = [np.insert(v[keep], at, f[0]) for v, f in zip(values, fit)]
    return dataclasses.replace(ml, omega=new[0], zeta=new[1], omega_std=new[2], zeta_std=new[3],
                               applied=np.insert(ml.applied[keep], at, True),
                               source=np.insert(ml.source[keep], at, -1), nuisance=nuisance)
