"""Whether a free decay's reported mode is needed beside its neighbours:
the free-decay counterpart of the stationary pair test
(:mod:`identifier.modal.peak_pairs`), by a nested F test in the time domain.

SSI sometimes fits one heavily damped mode of a free decay with two poles
(the mode lasts a few dozen samples; its second pole lightly damped, tens
of half-widths away, passing the matched filter of
:mod:`identifier.modal.decay_snr` because the first pole's misfit of the
transient is signal, not noise). The matched filter holds the other poles
where SSI or the refinement put them; here they move.

Test of reported mode ``b`` (pole ``lambda_b``) with its reported neighbours
in frequency ``A`` (one or two) on the record model of :mod:`.refine` (every
channel of every record a sum of damped sinusoids with shared poles, free
complex amplitudes, offset and drift, each channel divided by its noise
level): the stretch of ``DECAYS`` decay times of the slowest of ``b`` and
``A`` (at least ``MIN_SAMPLES`` per basis column) is fitted by maximum
likelihood (:func:`identifier.modal.ml_fit.fit_poles`) with ``b`` and ``A``
free (cost ``f_1``) and with ``A`` alone free (``f_0``, started from the
first fit's ``A``, ``A``'s bounds reaching half-way to the poles beyond
``b``), every other reported pole and the refinement's nuisance poles held.
The models are nested (``b``'s amplitudes zero): the classical F test of
the extra sum of squares against the residual's own variance on the
stretch (which carries a misfit there that the whole record's noise level
would not),

    F = ((f_0 - f_1) / (2 M + 2)) / (f_1 / nu)  ~  F(2 M + 2, nu)

under "no mode at ``b``" (``M`` channel records; ``nu`` the residual
degrees of freedom, ``n M`` less every linear and pole parameter). With
``b``'s pole known the numerator would have ``2 M`` degrees of freedom (its
amplitudes); counting its 2 pole parameters too is conservative. Its pole
is fitted: like the matched filter, the p-value carries the look-elsewhere
factor of the stretch's ``n / 2`` independent frequencies, and Bonferroni
over the record's tested modes ``k``:

    b is needed when  k (n / 2) P(F(2 M + 2, nu) > F) < ALPHA.

``ALPHA`` 0.001: a record whose modes are all true keeps a false one with
chance at most 0.001 per record, one in 1,000 records (issue 21's target).
The least needed failing mode is dropped and the others tested again
(their neighbours change), until all are needed; but when a neighbour's
pole in the one-pole fit lands nearer the failing mode's pole than its own
(in the s-plane), that neighbour is dropped instead: the failing mode's
pole is the nearer estimate of the one mode there (the stationary pair
test's rule). The kept modes keep their values (refined or SSI's).

Assumes the refinement's model (white noise per channel, every mode in the
record among the poles or the nuisance terms); the level holds only where
it does. Fails (drops a true mode) when the mode's own extra sum of
squares is under the threshold: a mode that weak beside a neighbour is not
told from a second pole of that neighbour by this record, and strong modes
missing from the model raise the residual variance (tuning seed 1,001,994:
a true mode at p 0.066); keeps a false mode when a fit does not converge
(no verdict) or when a structured misfit (an unmodelled mode beside the
tested ones) fits a second pole better than the residual variance says.
Records of one reported mode are not tested (no neighbour: the matched
filter decides).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.stats import f as fisher

from ..io.traces import Trace
from .close_pairs.free_decay_fit import basis
from .ml_fit import VarPro, fit_poles, noise_levels, select
from .refine import DECAYS, PoleRefinement, complex_poles, free_starts, nuisance_poles, pole_bounds

ALPHA = 0.001  # chance per record that a false mode beside true ones is kept (one in 1,000 records)
MIN_SAMPLES = 16  # least samples per basis column in the fitted stretch


def extra_ss_pvalue(without: float, with_: float, m: int, nu: int, n: int) -> float:
    """The module docstring's F test of one pole's extra sum of squares
    (costs ``without`` and ``with_`` it, ``m`` channel records, ``nu``
    residual degrees of freedom) times the look-elsewhere factor ``n / 2``
    of a stretch of ``n`` samples."""
    return float(fisher.sf((without - with_) / (2 * m + 2) / (with_ / nu), 2 * m + 2, nu) * n / 2)


def _cost(fit: VarPro, free: np.ndarray, fixed: np.ndarray, dt: float) -> tuple[float, np.ndarray, bool]:
    """The weighted residual sum of squares with the poles ``free`` fitted
    by ML (bounds of :func:`identifier.modal.refine.pole_bounds`), ``fixed``
    held (``fit`` their :class:`VarPro`); the fitted poles; whether the fit converged."""
    lower, upper = pole_bounds(free, fixed, dt)
    fitted, _, ok, _ = fit_poles(fit.ts, fit.zs, fixed, free, lower, upper, fit=fit)
    return fit.cost(np.column_stack([fitted.real, fitted.imag]).ravel()), fitted, ok


def stretch(records: Sequence[np.ndarray], starts: Sequence[int], dt: float, every: np.ndarray, n: int,
            whole: np.ndarray | None = None) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """The first ``n`` free samples of every trace (``records`` (m, n_r) from
    ``starts``), grouped by length: times (n_g,) s, channels (n_g, M_g)
    divided by their noise levels (RMS residual on the poles ``every``,
    complex 1/s, with offset and drift) and that basis ``basis(t, every)``
    (its first rows of ``whole``, that basis at ``n`` or more samples, where given)."""
    free_len = [y.shape[1] - s for y, s in zip(records, starts)]
    ts, zs, bs = [], [], []
    for length in sorted({min(f, n) for f in free_len}):
        y = np.hstack([y[:, s:s + length].T for y, s, f in zip(records, starts, free_len) if min(f, n) == length])
        t = np.arange(length) * dt
        ts.append(t)
        bs.append(basis(t, every) if whole is None else whole[:length])
        zs.append(y / noise_levels(t, y, bs[-1]))
    return ts, zs, bs


def pvalues(records: Sequence[np.ndarray], starts: Sequence[int], dt: float, poles: np.ndarray,
            nuisance: np.ndarray, tested: Sequence[int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per reported pole (k,) (complex, 1/s; ``records`` (m, n) per trace from
    ``starts``) the p-value of the F test of the module docstring, before
    the Bonferroni factor ``k`` (NaN where untested: not in ``tested`` (all
    when None), no neighbour, a fit not converged, too few samples), and the pole to drop when it fails:
    itself, or the neighbour whose one-pole fit moved nearer to it (in the
    s-plane) than to the neighbour's own pole (that neighbour took its place)."""
    every = np.concatenate([poles, nuisance])
    free_len = np.array([y.shape[1] - s for y, s in zip(records, starts)])
    order = np.argsort(poles.imag)
    out, drop = np.full(poles.size, np.nan), np.arange(poles.size)
    columns = 2 + 2 * every.size
    tests = []  # per tested pole: its neighbours, the other reported poles, the stretch's samples
    for rank, b in enumerate(order):
        if tested is not None and b not in tested:
            continue
        near = np.delete(order[max(rank - 1, 0):rank + 2], 0 if rank == 0 else 1)
        slow = -np.max(poles[np.r_[b, near]].real)
        n = int(min(free_len.max(), max(np.ceil(DECAYS / slow / dt), MIN_SAMPLES * columns)))
        tests.append((b, near, np.setdiff1d(np.arange(poles.size), np.r_[b, near]), n))
    whole = basis(np.arange(max(n for *_, n in tests)) * dt, every) if tests else None  # every stretch's rows
    stretches: dict[int, tuple[list[np.ndarray], ...]] = {}  # by length: poles of one length share it
    for b, near, rest, n in tests:
        if n not in stretches:
            stretches[n] = stretch(records, starts, dt, every, n, whole)
        ts, zs, bs = stretches[n]
        m = sum(z.shape[1] for z in zs)
        nu = sum(z.size for z in zs) - m * columns - 2 * (1 + near.size)
        if nu <= 0:
            continue
        fixed = np.concatenate([poles[rest], nuisance])
        fit = VarPro(ts, zs, fixed, [select(g, np.r_[rest, poles.size + np.arange(nuisance.size)]) for g in bs])
        with_b, fitted, ok = _cost(fit, np.r_[poles[b], poles[near]], fixed, dt)
        if not ok or with_b <= 0:  # no verdict: the fit without b is not needed
            continue
        without_b, one, ok_0 = _cost(fit, fitted[1:], fixed, dt)
        if ok_0:
            out[b] = extra_ss_pvalue(without_b, with_b, m, nu, max(len(t) for t in ts))
            over = np.abs(one - poles[b]) < np.abs(one - poles[near])
            if over.any():  # the neighbour that came nearest b, relative to its own distance from it
                drop[b] = near[over][np.argmin((np.abs(one - poles[b]) / np.abs(poles[near] - poles[b]))[over])]
    return out, drop


def screen(traces: Sequence[Trace], records: Sequence[np.ndarray], dt: float, ml: PoleRefinement,
           rejected: Sequence[dict], refine: str) -> tuple[PoleRefinement, list[dict]]:
    """The reported modes of a free decay after the refinement ``ml``
    (:mod:`.refine`), each tested as needed beside its neighbours (module
    docstring); nuisance poles: the refinement's, or where it was not
    applied those of the ``rejected`` candidates (``details.rejected``
    entries; :func:`identifier.modal.refine.nuisance_poles`). Returns ``ml``
    without the modes not needed and their ``details.rejected`` entries;
    ``ml`` unchanged with ``refine="off"`` (SSI's answer) or when a trace
    is no free decay."""
    starts = free_starts(traces, records)
    if refine == "off" or isinstance(starts, str):
        return ml, []
    candidates = [(r["omega"], r["zeta"]) for r in rejected]
    gone: list[dict] = []
    while True:
        modelled = ml.modelled
        if modelled.sum() < 2:
            return ml, gone
        poles = complex_poles(ml.omega[modelled], ml.zeta[modelled])
        nuisance = ml.nuisance if ml.details.get("applied") else nuisance_poles(
            candidates, poles, dt, max(y.shape[1] for y in records) * dt)
        p, instead = pvalues(records, starts, dt, poles, nuisance)
        p = np.minimum(p * poles.size, 1.0)
        if not np.any(p >= ALPHA):  # NaN: no verdict
            return ml, gone
        index = np.flatnonzero(modelled)
        b = int(np.nanargmax(p))
        worst = index[instead[b]]
        why = "not needed beside its neighbours in the time-domain fit" if instead[b] == b else \
            f"one mode with {ml.omega[index[b]]:.4g} rad/s in the time-domain fit, whose pole is nearer " \
            f"their one-pole fit"
        gone.append({"omega": float(ml.omega[worst]), "zeta": float(ml.zeta[worst]),
                     "reason": f"{why} (free-decay pair test: p {p[b]:.2g}, needs {ALPHA:g})"})
        ml = ml.subset(np.arange(ml.omega.size) != worst)
