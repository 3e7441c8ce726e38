"""Maximum-likelihood refinement of the poles of the reported modes on free decays.

SSI-cov is not an efficient estimator: on a free decay its frequencies and
damping ratios spread 1-5 times the Cramer-Rao bound of the record
(docs/plan.md). This step fits the record itself, started from the SSI
poles, by maximum likelihood; its spread is the bound's.

Model. Record ``r`` (its free part, samples ``t_k = k dt`` from the start of
the free response, truncated as below), channel ``i``:

    y_ri(t_k) = a_ri + b_ri t_k + sum_j Re(c_rij exp(lambda_j t_k)) + e_ri(t_k),

``lambda_j = sigma_j + i omega_d,j`` shared by every record and channel,
complex amplitudes ``c_rij`` free per channel and record (what an
output-only identifier knows; displacement, velocity and acceleration
channels all carry the same poles), an offset and drift ``a + b t``
(sensor offsets, a rigid-body motion) and white Gaussian noise of standard
deviation ``s_ri``. The poles are the reported modes' and, as nuisance
terms, those of the candidate modes the support tests rejected (a mode the
record carries but SSI did not report would otherwise leave its signal in
the residual and pull the others); a close pair already fitted by
:mod:`identifier.modal.close_pairs` is held at its fit (its amplitudes
free), as is a mode refused below.

Equations (variable projection, Kaufman's Jacobian, Levenberg-Marquardt,
the covariance from the Gauss-Newton information): :mod:`.ml_fit`. The
noise levels ``s_ri`` are first the RMS of the residual of the SSI poles
with their ``t e^(lambda t)`` terms (which take up the SSI poles' errors),
then, after a first fit, of that fit's residual, and the fit is repeated
with them. After the first fit the weighted residual is searched for modes
the model misses (:mod:`.ml_residual`); they join the nuisance terms.

Cost. The record is truncated to ``DECAYS`` decay times ``1 / (zeta omega)``
of the slowest reported mode (past them every mode has lost all but
``e^-10`` of its energy: nothing is lost). Above ``BUDGET`` samples x
channels the weighted channels are first reduced to their ``2P + 2``
principal directions (the signal's rank: the rest is noise and carries
nothing on the poles), then the record is cut to the budget (a loss of
precision on the slowest modes, which the standard errors state). An
evaluation costs ``O(n N (N + M))``; on the chapter 5 beam's free decay
(20,001 samples of 10 channels, 9 modes, about 4 nuisance poles) the step
takes 0.4-0.9 s on 2 cores, about as long as SSI-cov itself (identification
1.0-1.9 s instead of 0.5-1.0 s).

Applies only to free decays: every trace a free response by its
``/excitation`` ``kind`` (``impulse`` or ``initial``, from the end of the
last impulse on; :func:`identifier.modal.close_pairs.free_start`), or,
without an excitation record, by its decay
(:func:`identifier.modal.ssi.covariance.is_free_decay`). A trace with any other
excitation (a force acting during the record) is refused.
Refused, the SSI answer kept (``details["ml_refinement"]`` says why):
``refine="off"``; not a free decay; too few samples for the poles; the fit
does not converge in ``ml_fit.MAX_ITERATIONS``. Per mode, the SSI answer is kept
(and the pole held at it in a refit of the others; a mode of damping ratio
outside (0, 1) is left out of the model) when its refined pole
moves more than ``MOVE`` SSI standard errors in ``omega`` or ``zeta``, ends
on a bound (half-way to the neighbouring poles in ``omega_d``; zero damping),
has no finite standard error, or when the residual says the model is wrong
there: a ``t e^(lambda t)`` term at the pole (a second mode within its
bandwidth that neither SSI nor the search resolved, whose signal the fit
would bend the pole to) by the score test of
:func:`identifier.modal.close_pairs.pair.score_statistics` (``chi^2(2M -
2)``, p-value below ``MISFIT`` Bonferroni over the modes; one channel of
one record has no such test). A move over ``MOVE`` is accepted when a
term found in the residual explains it (``_partner``): within ``BAND``
``zeta omega`` of SSI's pole, on the other side of it from the refined
pole, no other reported mode nearer. SSI's pole was then one fitted over
two modes (its frequency between theirs); both refined poles are reported
with their ML standard errors, the second as a new mode (``source`` -1, its
shape by least squares). Its evidence is the residual search's
(``ml_residual.ALPHA`` 0.01, Bonferroni over bins and lengths). A move over ``MOVE`` that nothing
explains keeps SSI's pole with errors ``sqrt(se^2 + Delta^2)`` in
``omega`` and ``zeta`` (``Delta`` the move): two estimates of one pole
that differ by more than their errors say the model is wrong there, and
their difference is the only measure of that error the record gives
(tuning seed 1,002,218: one SSI pole over two unresolved modes). With
``uncertainty="off"`` SSI states no errors: the refined values are
reported (the same as the default run's wherever that run's move test
passes) without errors (NaN), and only the bounds limit a move (no split).

Assumptions and failures: a linear structure in free response from the
record's start (no force after it), white noise on every channel, every
mode with signal in the record among the poles or found by the search. A
mode too weak for the search stays in the residual: it inflates ``s`` (the
errors get larger) and, if near a reported mode, biases it; so does a mode
the search fits badly (two close unseen modes as one pole). Non-white noise
(a filtered sensor) makes the stated errors too small. The stated errors
are the bound's (no scatter over model orders, no bias term): the fit is
efficient only where the model holds. Shapes are SSI's.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.linalg as la

from ..io.traces import Trace
from .close_pairs import free_start
from .close_pairs.free_decay_fit import basis, omega_zeta
from .ml_fit import fit_poles, noise_levels
from .ml_residual import missing_poles, misfit_pvalues
from .runtime import one_blas_thread
from .ssi.covariance import decay_shown

DECAYS = 5.0  # record used: this many decay times 1 / (zeta omega) of the slowest reported mode
MOVE = 4.0  # largest move of a refined pole from SSI's, in SSI standard errors (omega and zeta each)
BUDGET = 4_000_000  # samples x channels fitted at most
MAX_NUISANCE_ZETA = 0.5  # rejected candidates more damped than this are no nuisance terms
MISFIT = 1e-3  # a refined pole whose residual holds a t e^(lambda t) term at this p-value keeps SSI's answer
ROUNDS = 3  # fits at most: a refused pole is held at SSI's and the others fitted again
BAND = 2.0  # a term found in the residual within this many zeta omega of a moved SSI pole explains the move


@dataclass(frozen=True)
class PoleRefinement:
    """The modes after the refinement (k' >= k: the input's order, a split
    merger's two by ``omega``): ``omega`` rad/s, ``zeta``, their standard
    errors, ``applied`` (k',) True where they come from the fit, ``source``
    (k',) the input mode each comes from (-1: the second mode of a split
    merger), ``details`` (``details["ml_refinement"]`` of the results) and
    ``nuisance`` the fit's nuisance poles (complex, 1/s; empty when not applied)."""

    omega: np.ndarray
    zeta: np.ndarray
    omega_std: np.ndarray
    zeta_std: np.ndarray
    applied: np.ndarray
    source: np.ndarray
    details: dict[str, Any] = field(default_factory=dict)
    nuisance: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))

    @property
    def modelled(self) -> np.ndarray:  # (k',) bool: damping in (0, 1), the modes a free-decay fit models
        return (self.zeta > 0) & (self.zeta < 1)

    def subset(self, keep: np.ndarray) -> PoleRefinement:
        """The modes ``keep`` ((k',) bool) only; details and nuisance poles as they are."""
        return replace(self, omega=self.omega[keep], zeta=self.zeta[keep], omega_std=self.omega_std[keep],
                       zeta_std=self.zeta_std[keep], applied=self.applied[keep], source=self.source[keep])


def resolved(extra: np.ndarray, poles: np.ndarray, span: float) -> np.ndarray:
    """(k,) bool: ``extra`` (k,) 1/s resolved from all ``poles``, ``|d omega_d| > 2 pi / span + sigma_a + sigma_b``."""
    gap = np.abs(extra.imag[:, None] - poles.imag[None, :])
    return np.all(gap > 2 * np.pi / span - extra.real[:, None] - poles.real[None, :], axis=1)


def free_starts(traces: Sequence[Trace], records: Sequence[np.ndarray]) -> list[int] | str:
    """The first sample of each trace's free response, or why a trace is no
    free decay: by the ``/excitation`` ``kind`` when the trace has one
    (``impulse``/``initial`` only), else by a channel's decay (:func:`decay_shown`, so ``is_free_decay``)."""
    starts = []
    for trace, y in zip(traces, records):
        start = free_start(trace)
        if start is None:
            kind = str(trace.excitation_attrs.get("kind", ""))
            if kind:
                return f"{trace.path.name}: excitation {kind!r} is no free decay"
            if not decay_shown(y):  # implies is_free_decay
                return f"{trace.path.name}: the record does not decay (no free decay; no channel's F test shows it)"
            start = 0
        if y.shape[1] - start < 4:
            return f"{trace.path.name}: no free response after sample {start}"
        starts.append(start)
    return starts


def _unchanged(omega, zeta, omega_std, zeta_std, reason: str, ssi: dict | None = None) -> PoleRefinement:
    return PoleRefinement(omega, zeta, omega_std, zeta_std, np.zeros(omega.size, bool), np.arange(omega.size),
                          {"applied": False, "reason": reason, "modes": [False] * omega.size,
                           "mode_reasons": [reason] * omega.size} | ({"ssi": ssi} if ssi else {}))


def complex_poles(omega: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """``lambda = -zeta omega + i omega sqrt(1 - zeta^2)`` (k,) 1/s of ``omega`` (k,) rad/s, ``zeta`` (k,)."""
    return -zeta * omega + 1j * omega * np.sqrt(np.maximum(1 - zeta**2, 0.0))


def nuisance_poles(candidates: Sequence[tuple[float, float]], poles: np.ndarray, dt: float, span: float
                   ) -> np.ndarray:
    """The poles of rejected candidate modes ``(omega, zeta)`` that the fit
    takes as nuisance terms: under 0.99 x Nyquist, ``0 < zeta <
    MAX_NUISANCE_ZETA``, lasting 10 samples or more, and resolved from every
    other pole (``|delta omega_d| > 2 pi / span + sigma_a + sigma_b``)."""
    kept = list(poles)
    out = []
    for w, z in sorted(candidates, key=lambda c: c[0]):
        if not (np.isfinite(w) and np.isfinite(z) and 0 < w < 0.99 * np.pi / dt and 0 < z < MAX_NUISANCE_ZETA):
            continue
        if z * w * dt > 0.1:
            continue
        lam = complex_poles(np.array([w]), np.array([z]))[0]
        if resolved(np.array([lam]), np.array(kept, dtype=complex), span)[0]:
            kept.append(lam)
            out.append(lam)
    return np.array(out, dtype=complex)


@dataclass
class _Data:
    """Groups of equal length: times ``t`` (n,), raw data ``y`` (n, M), noise levels ``s`` (M,)."""

    t: list[np.ndarray]
    y: list[np.ndarray]
    s: list[np.ndarray]


def _weighted(data: _Data, rank: int, budget: int) -> tuple[list[np.ndarray], list[np.ndarray], int]:
    """The weighted groups (times, data) within ``budget`` samples x
    channels: each group's channels reduced to their ``rank`` principal
    directions (the signal's rank) where it has more, then fewer samples.
    Returns them and the samples kept."""
    ts, zs = list(data.t), [y / s for y, s in zip(data.y, data.s)]
    if sum(z.size for z in zs) > budget:
        zs = [z @ la.svd(z, full_matrices=False)[2][:rank].T if z.shape[1] > rank else z for z in zs]
    cut = max(t.size for t in ts)
    if sum(z.size for z in zs) > budget:
        cut = max(int(budget / sum(z.shape[1] for z in zs)), 8 * rank)
        ts, zs = [t[:cut] for t in ts], [z[:cut] for z in zs]
    return ts, zs, cut


def pole_bounds(free: np.ndarray, fixed: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Per free pole (at its anchor ``free``) ``sigma`` within ``[-2 |lambda|,
    -1e-9 |lambda|]`` and ``omega_d`` within half-way to the nearest other pole,
    free or ``fixed`` (and Nyquist)."""
    lower, upper = [], []
    nyquist = np.pi / dt
    everyone = np.concatenate([free, fixed]).imag
    for i, lam in enumerate(free):
        others = np.delete(everyone, i)
        below, above = others[others < lam.imag], others[others >= lam.imag]
        lo = (lam.imag + below.max()) / 2 if below.size else 0.5 * lam.imag
        hi = (lam.imag + above.min()) / 2 if above.size else min(1.5 * lam.imag, nyquist)
        mag = abs(lam)
        lower += [-2 * mag, lo]
        upper += [-1e-9 * mag, min(hi, nyquist)]
    return np.array(lower), np.array(upper)


def refine_poles(traces: Sequence[Trace], records: Sequence[np.ndarray], dt: float, omega: np.ndarray,
                 zeta: np.ndarray, omega_std: np.ndarray, zeta_std: np.ndarray, held: np.ndarray,
                 candidates: Sequence[tuple[float, float]], refine: str) -> PoleRefinement:
    """The modes (``omega`` rad/s, ``zeta``, their standard errors; ``held``
    (k,) True for modes not to refine, e.g. a close-pair fit's) with their
    poles refined by maximum likelihood on the traces' free decays
    (``records`` (m, n) per trace), ``candidates`` ``(omega, zeta)`` of the
    rejected SSI modes as nuisance terms; the SSI answer where refused
    (module docstring). ``refine``: ``auto`` or ``off``."""
    omega, zeta = np.asarray(omega, float), np.asarray(zeta, float)
    omega_std, zeta_std = np.asarray(omega_std, float), np.asarray(zeta_std, float)
    ssi = {"omega": omega.tolist(), "damping": zeta.tolist(), "omega_std": omega_std.tolist(),
           "damping_std": zeta_std.tolist()}
    if refine == "off":
        return _unchanged(omega, zeta, omega_std, zeta_std, "refine=off")
    k = omega.size
    if k == 0:
        return _unchanged(omega, zeta, omega_std, zeta_std, "no mode reported")
    starts = free_starts(traces, records)
    if isinstance(starts, str):
        return _unchanged(omega, zeta, omega_std, zeta_std, starts)
    trusted = np.isfinite(omega_std) & np.isfinite(zeta_std) & (omega_std > 0) & (zeta_std > 0)
    modelled = (zeta > 0) & (zeta < 1)  # a pole that does not decay, or no oscillation: left out
    todo = ~np.asarray(held, bool) & modelled
    if not todo.any():
        return _unchanged(omega, zeta, omega_std, zeta_std, "no mode to refine (close-pair fits, damping "
                          "outside (0, 1))", ssi)
    poles = complex_poles(omega, zeta)
    free_len = [y.shape[1] - s for y, s in zip(records, starts)]
    n = min(max(free_len), int(np.ceil(DECAYS / np.min((zeta * omega)[modelled]) / dt)))
    nuisance = nuisance_poles(candidates, poles[modelled], dt, n * dt)
    data = _Data([], [], [])
    first_cols = None
    for length in sorted({min(f, n) for f in free_len}):
        cols = [y[:, s:s + length].T for y, s, f in zip(records, starts, free_len) if min(f, n) == length]
        t = np.arange(length) * dt
        y = np.hstack(cols)
        every = np.concatenate([poles[modelled], nuisance])
        b = basis(t, every)
        first_cols = np.column_stack([b, t[:, None] * b[:, 2:]])
        if first_cols.shape[1] >= length:
            return _unchanged(omega, zeta, omega_std, zeta_std,
                              f"{length} samples are too few for {every.size} poles", ssi)
        data.t.append(t)
        data.y.append(y)
        data.s.append(noise_levels(t, y, first_cols))
    refused = np.zeros(k, bool)
    reasons = ["held (close-pair fit)" if h else "" if ok else "damping ratio outside (0, 1): not refined"
               for h, ok in zip(held, modelled)]
    out_w, out_z, out_sw, out_sz = omega.copy(), zeta.copy(), omega_std.copy(), zeta_std.copy()
    applied = np.zeros(k, bool)
    cut, added, split = n, 0, {}
    kept_nuisance = np.zeros(0, complex)
    apart: dict[int, tuple[float, float]] = {}  # SSI kept after a move over MOVE: |omega, zeta| of the move
    with one_blas_thread():
        for round_ in range(ROUNDS):
            active = todo & ~refused
            if not active.any():
                break
            p = int(active.sum())
            fixed = poles[~active & modelled]
            free = np.concatenate([poles[active], nuisance])
            for sweep in range(2):  # weights of the SSI poles, then of the first fit's residual
                lower, upper = pole_bounds(np.concatenate([poles[active], nuisance]), fixed, dt)  # SSI's anchor
                ts, zs, cut = _weighted(data, 2 * (free.size + fixed.size) + 2, BUDGET)
                fitted, cov, ok, edge = fit_poles(ts, zs, fixed, free, lower, upper, watch=p)
                if not ok:
                    return _unchanged(omega, zeta, omega_std, zeta_std, "the fit did not converge", ssi)
                if sweep == 1:
                    break
                if round_ == 0:  # modes the model misses, found in the fit's residual: nuisance terms too
                    found = missing_poles(ts, zs, np.concatenate([fitted, fixed]), dt)
                    added = found.size
                    nuisance = np.concatenate([fitted[p:], found])
                else:
                    nuisance = fitted[p:]
                free = np.concatenate([fitted[:p], nuisance])
                for g, t in enumerate(data.t):
                    data.s[g] = noise_levels(t, data.y[g], basis(t, np.concatenate([free, fixed])))
            idx = np.flatnonzero(active)
            every = omega_zeta(fitted, cov)  # the nuisance poles last, those found in the residual at the end
            w, z, se_w, se_z = (v[:p] for v in every)
            misfit = misfit_pvalues(ts, zs, np.concatenate([fitted, fixed]), p)
            good = np.zeros(p, bool)
            partner = np.full(p, -1)
            for a, i in enumerate(idx):
                moved = max(abs(w[a] - omega[i]) / omega_std[i], abs(z[a] - zeta[i]) / zeta_std[i]) \
                    if trusted[i] else 0.0  # no SSI errors (uncertainty="off"): no move to bound
                if edge[a]:
                    reasons[i] = "the refined pole ended on a bound"
                elif misfit[a] < MISFIT:
                    reasons[i] = f"the residual holds a t e^(lambda t) term at the pole (p = {misfit[a]:.2g})"
                elif not (np.isfinite(se_w[a]) and np.isfinite(se_z[a]) and se_w[a] > 0 and se_z[a] > 0):
                    reasons[i] = "no finite refined standard error"
                elif moved > MOVE and (j := _partner(every, fitted.size - added, w[a], i, omega, zeta,
                                                     partner)) >= 0:
                    reasons[i] = (f"refined; moved {moved:.3g} SSI standard errors, the SSI pole a merger with "
                                  f"the term found in the residual at {every[0][j]:.4g} rad/s (reported)")
                    good[a], partner[a] = True, j
                elif moved > MOVE:
                    reasons[i] = f"moved {moved:.3g} SSI standard errors (over {MOVE:g})"
                    apart[i] = (abs(w[a] - omega[i]), abs(z[a] - zeta[i]))
                else:
                    reasons[i] = "refined"
                    good[a] = True
            if good.all() or round_ == ROUNDS - 1:  # the last round: its good poles, the others held
                use = idx[good]
                out_w[use], out_z[use] = w[good], z[good]
                errors = trusted[use]  # without SSI's errors (uncertainty="off") none are stated
                out_sw[use] = np.where(errors, se_w[good], np.nan)
                out_sz[use] = np.where(errors, se_z[good], np.nan)
                applied[use] = True
                split = {int(idx[a]): tuple(float(v[partner[a]]) for v in every)
                         for a in np.flatnonzero(good & (partner >= 0))}
                kept_nuisance = np.delete(fitted[p:], partner[good & (partner >= 0)] - p)  # not the reported
                break
            refused[idx[~good]] = True
    for i in np.flatnonzero(todo & ~applied):
        reasons[i] += " (SSI kept)"
        if i in apart:  # the two estimates' difference: a model error neither error states
            out_sw[i], out_sz[i] = np.hypot(omega_std[i], apart[i][0]), np.hypot(zeta_std[i], apart[i][1])
            reasons[i] += ", its errors widened by the move"
    details = {"applied": bool(applied.any()), "reason": "" if applied.any() else "every mode refused",
               "modes": applied.tolist(), "mode_reasons": reasons, "samples": int(min(cut, n)),
               "nuisance": sorted(float(abs(p)) for p in nuisance), "found_in_residual": int(added),
               "ssi": ssi, "split": {str(i): list(v) for i, v in split.items()}}
    rows = []  # per reported mode: source, omega, zeta, their errors, applied; a split merger's two by omega
    for i in range(k):
        pair = [(i, out_w[i], out_z[i], out_sw[i], out_sz[i], applied[i])] + \
            ([(-1, *split[i], True)] if i in split else [])
        rows += sorted(pair, key=lambda row: row[1])
    src, w, z, sw, sz, done = (np.array(c) for c in zip(*rows))
    return PoleRefinement(w.astype(float), z.astype(float), sw.astype(float), sz.astype(float), done.astype(bool),
                          src.astype(int), details, kept_nuisance)


def _partner(every: tuple[np.ndarray, ...], first: int, moved_to: float, i: int, omega: np.ndarray,
             zeta: np.ndarray, taken: np.ndarray) -> int:
    """The index (in the fit's poles ``every`` = omega, zeta and their
    standard errors) of the term found in the residual (indices ``first``
    on) that explains the move of mode ``i``'s pole from SSI's ``omega[i]``
    to ``moved_to`` rad/s: SSI's pole one fitted over two modes. The term
    is within ``BAND`` ``zeta omega`` of SSI's pole, on its other side, no
    other reported mode nearer, with finite errors, damping in (0, 1) and
    not ``taken`` by another mode; -1 if none. Its evidence is the
    residual search's (:mod:`.ml_residual`, level ``ALPHA``)."""
    w, z, sw, sz = every
    best, gap = -1, np.inf
    for j in range(first, w.size):
        near = abs(w[j] - omega[i])
        if (j in taken or not (np.isfinite(sw[j]) and np.isfinite(sz[j]) and sw[j] > 0 and sz[j] > 0)
                or not 0 < z[j] < 1 or near > BAND * zeta[i] * omega[i] or near >= gap
                or (w[j] - omega[i]) * (moved_to - omega[i]) >= 0
                or np.argmin(np.abs(omega - w[j])) != i):
            continue
        best, gap = j, near
    return best
