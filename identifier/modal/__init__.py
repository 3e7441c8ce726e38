"""Operational and free-decay modal identification by covariance-driven
stochastic subspace identification (SSI-cov) with automatic order selection.

Steps (each its own module):
0. harmonics (stationary records only, :mod:`identifier.modal.harmonics`):
   spectral lines whose band-filtered response has the kurtosis of a
   sinusoid (1.5, a random response's is 3) are subtracted from the
   records; after step 3, SSI modes of near-zero damping at their orders
   whose band kurtosis is low are dropped too (and the other tests of
   :func:`identifier.modal.harmonics.confirm`); when these find any, the
   record is identified again with them subtracted as well, since each took
   model orders from the modes. All are in ``details["harmonics"]``, never among the modes;
1. lagged output covariances ``R_l = <y_{k+l} y_ref,k^T>``, l >= 1, summed per
   sample group by FFT (:mod:`identifier.modal.ssi.covariance`); white sensor noise
   only enters ``R_0``, which is not used. Lags 1 .. p + q - 1 with ``p`` block
   rows and ``q`` block columns chosen from the data
   (:mod:`identifier.modal.ssi.design`: the record length, free decay or not, the
   lowest frequency the response carries, the channel count; in a random
   response no lag past those whose covariances stand out of their
   estimation noise);
2. block Hankel matrix of the covariances, on at most 20 principal row
   channels; its leading singular vectors by subspace iteration with products
   by FFT (:mod:`identifier.modal.ssi.hankel`), and the poles ``s = ln(mu(A)) / dt``
   of every model order 2, 4, ..., ``max_order`` (:mod:`identifier.modal.ssi.poles`):
   ``omega = |s|`` rad/s, ``zeta = -Re s / |s|``, complex shapes ``C psi`` on
   every channel (``C`` from the first block row of all channels,
   ``[R_1 .. R_q] V S^-1``);
3. stabilisation across orders and clustering of the stable poles into modes,
   estimated as medians over all their stable poles (:mod:`identifier.modal.stabilisation`);
   a mode whose observability vectors do not follow the geometric sequence
   ``mu^i`` of their eigenvalue over the block rows (temporal coherence,
   :func:`identifier.modal.ssi.poles.coherence`, below ``COHERENCE``) is a pole
   of the covariance estimates' own noise and dropped: such poles become
   stable at orders far past the structure's (a response that dies out
   early in a long record, few modes on many sensors) and seldom at
   ``STEADY`` (80 %) of the orders or more: a mode stable there is exempt,
   unless it lies at or above every candidate of coherence ``COHERENCE`` or
   more (there a record holds only background, where the covariance noise's
   poles gather stable at most orders). A mode's coherence is the
   median over ``COHERENCE_ORDERS`` of its orders, spread over those it is
   stable at, of its most coherent pole at each: one pole is no measure
   (within one heavily damped mode of a random response it ranges from 0.3
   to 1 between orders, and a noise pole can join the mode's cluster at the
   same order: the pole nearest the median frequency, which alone used to
   decide, lost one such mode of ``benchmarks/modal_fuzz.py`` at 0.35 and
   kept another at 0.50 only by the ``STEADY`` exemption);
4. standard errors of every frequency and damping ratio by the delete-one-group
   jackknife over the sample groups (:mod:`identifier.modal.uncertainty`;
   a mode one replicate misses gets them from the others), plus the
   scatter over the model orders and, in a stationary record of ``T`` s,
   the short-record bias (``1 / T`` rad/s on omega, ``1 / (omega T)`` on
   zeta: :mod:`identifier.modal.support`). The replicates' subspaces are
   computed in the background while steps 2-3 run; ``uncertainty="off"``
   skips this step; a stationary record's errors widen where its band disagrees (:mod:`.band_fit`);
5. support (:func:`identifier.modal.support.judge`): a mode is reported only
   when the record carries it (its periods and, in a stationary record, its
   decay times in the record; stable at half the model orders, or precise; found again by all jackknife
   replicates but one; finite standard errors; not a duplicate the record does not resolve; in a free
   response, above the sensor noise by a matched-filter test, :mod:`identifier.modal.decay_snr`; in a free
   decay, needed beside its neighbours, :mod:`identifier.modal.decay_pairs`; then the modes SSI missed,
   found in a free decay's residual, :mod:`identifier.modal.decay_search`; in a stationary record, not a mode
   kept by the coherence exemption that step 4's widened errors leave unresolved from a more coherent one,
   :func:`identifier.modal.band_fit.checked`). The others, and the candidates
   of step 3 below ``COHERENCE``, are listed in ``details["rejected"]`` with their reason;
   ``details["warnings"]`` says when a stationary record is under two periods of its lowest frequency;
6. a short-lag pass (stationary records, with the jackknife's replicate test on, block rows not given,
   ``short_lags="on"``, :mod:`.short_lags`): steps 0-5 again with a quarter of the block rows; a mode found
   there that is resolved from every reported one, no nearer than 5 % to any and with a peak of its own in
   the spectrum is added (``details["short_lags"]``): long lags, set by a light low mode, leave a broad or
   high mode's covariance to estimation noise;
7. spatial deflation (stationary records, with the jackknife's replicate test on, :mod:`.deflation`): the
   RMS-scaled records projected off the spans of the reported modes' complex shapes are identified again
   by steps 0-5; a mode found there that is resolved from every reported one is added
   (``details["deflation"]``), what that pass rejected is listed in ``details["rejected"]``.

Each channel's mean is removed from a stationary record (neither a free
decay nor labelled a free response: stationary covariances are about the
mean; a sensor's static offset, a few times the response's RMS, otherwise
adds the constant ``c^2`` to every ``R_l``, keeps every lag "above its
noise" and fills the Hankel matrix with a pole at zero frequency); a free
response keeps its mean (an offset there is a pole at ``z = 1`` that SSI
fits as such, and the mean of a decay, or of an undamped free response
over a record of no whole number of periods, is no offset).

Assumptions: a linear time-invariant structure, the response either a free
decay or stationary (unmeasured broadband excitation), white sensor noise;
no force channel is needed or used. Several traces of one run (several
impulse tests, say) add their covariances, which is how two tests separate
a pair of close modes that one test moves as a single shape. Output-only
data cannot scale the shapes (they come normalised to max |.| = 1; with
sensors of several quantities each entry is in its own sensor's) and cannot
see a mode that no sensor moves in (nor, with more than 20 channels, one the
20 principal directions miss: a mode far weaker than 20 others); with fewer
samples than ``20 (p + q)`` or a mode with under about one period in the
record it fails or misses that mode. In a stationary record the lags span
a quarter period of the lowest frequency carrying 2 % of the power (within
``n / 20``): a mode well below it, weak in the response, may be missed.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from structbench.models import Model

from ..errors import IdentificationError
from .uncertainty import Replicates, carried, jackknife
from .close_pairs import split_free_decays
from ..io.results import Identification
from .runtime import one_blas_thread, tune_from_environment
from .ssi.covariance import covariances, project, reference_channels, row_projection
from .ssi.design import ROW_CHANNELS, block_sizes, lowest_frequency, short_record_warnings, signal_span
from .ssi.hankel import BlockHankel, leading_svd
from .ssi.poles import Poles, Subspace, coherence, mpc, pole_columns, poles_at, real_shapes, subspace
from .stabilisation import Criteria, Mode, median, select_modes
from .support import judge, rejected as support_rejected, with_bias
from . import harmonics as periodic
from . import band_edges, band_fit, decay_pairs, deflation, decay_search, decay_snr, input_output
from . import short_lags as lag_pass
from .refine import refine_poles
from .free_shapes import free_decay_shapes
from ..io.traces import Trace
from . import sensors
from .sensors import channels_quantity, free_response, sensor_records

QUANTITIES = sensors.QUANTITIES  # the values of the quantity option
UNCERTAINTY = ("jackknife", "off")
SHORT_LAGS = ("off", "on")  # the values of the short_lags option (step 6)
COHERENCE = 0.6  # least temporal coherence of a reported SSI mode (:func:`identifier.modal.ssi.poles.coherence`)
COHERENCE_ORDERS = 5  # ... the median over this many of its orders (spread) of its most coherent pole there
STEADY = 0.8  # ... unless it is stable at this share of the orders or more


def _exempt(candidates: list[Mode], coherence: list[float], orders: int) -> list[bool]:
    """Which candidates the coherence test exempts: stable at ``STEADY`` of the
    ``orders`` or more and below the highest candidate of coherence
    ``COHERENCE`` or more (none when no candidate is coherent)."""
    top = max((md.omega for md, c in zip(candidates, coherence) if c >= COHERENCE), default=-np.inf)
    return [md.omega < top and len({n for n, _ in md.members}) >= STEADY * orders for md in candidates]


def identify(traces: Sequence[Trace], model: Model | None = None, quantity: str = "auto",
             block_rows: int | None = None, max_order: int = 80, references: int = 20, segments: int = 8,
             min_fraction: float = 0.3, drop_unrepeated: bool = True, refine: str = "auto",
             uncertainty: str = "jackknife", input: str = "auto", short_lags: str = "on") -> Identification:
    """Natural frequencies (rad/s), damping ratios, shapes and their standard
    errors from the outputs of one run's traces (``model`` is not needed;
    it only names the structure). ``drop_unrepeated``: report only modes that
    all jackknife replicates but at most one find again (spurious noise modes
    do not); off, a mode without finite errors is still not reported. ``refine``: ``auto`` fits free responses whole to split close
    pairs (:mod:`identifier.modal.close_pairs`) and, on free decays, refines the reported
    modes' poles by maximum likelihood (:mod:`identifier.modal.refine`); ``off`` does neither. ``uncertainty``:
    ``off`` skips the jackknife (about half the time): no standard errors
    (NaN) and no check that replicates find each mode again. Changes nothing
    outside its own work unless the process opted in to tuning
    (:mod:`identifier.modal.runtime`). ``input``: ``auto``, ``on`` or ``off``, the measured force scales
    the shapes to unit modal mass (:mod:`identifier.modal.input_output`, ``details["input_output"]``). Records in which
    harmonics turn up only through the SSI modes (:func:`identifier.modal.harmonics.confirm`) are
    identified again with them subtracted, so that they take no model order from the modes. A stationary
    record is identified once more off the reported modes' shapes (:mod:`.deflation`, step 7); before that,
    with ``short_lags`` ``on`` (``off`` skips it), once more with a quarter of the block rows
    (:mod:`.short_lags`, step 6)."""
    options = {"model": model, "quantity": quantity, "block_rows": block_rows, "max_order": max_order,
               "references": references, "segments": segments, "min_fraction": min_fraction,
               "drop_unrepeated": drop_unrepeated, "refine": refine, "uncertainty": uncertainty, "input": input,
               "screen": periodic.Screens()}

    def run(these: Sequence[Trace], **changes: object) -> Identification:
        result, pending = _identify(these, (), **(options | changes))
        return result if result is not None else _identify(these, tuple(pending), **(options | changes))[0]
    if short_lags not in SHORT_LAGS:
        raise IdentificationError(f"unknown short_lags {short_lags!r}; known: {', '.join(SHORT_LAGS)}",
                                  field="short_lags")
    found = run(traces)
    if not (uncertainty == "jackknife" and drop_unrepeated):  # the further passes only with the replicate test on
        return found
    records, _, dt, _ = sensor_records(traces, quantity)
    if free_response(traces, records)[1]:  # the further passes are for stationary records, mean removed
        return found
    records = [y - y.mean(axis=1, keepdims=True) for y in records]
    if short_lags == "on":
        found = lag_pass.extend(traces, records, dt, found, block_rows is not None, run, COHERENCE)
    return deflation.extend(traces, records, dt, found, run, COHERENCE)


def _identify(traces: Sequence[Trace], known: tuple[periodic.Line, ...], model: Model | None, quantity: str,
              block_rows: int | None, max_order: int, references: int, segments: int, min_fraction: float,
              drop_unrepeated: bool, refine: str, uncertainty: str, input: str, beside: tuple[float, ...] = (),
              screen: Callable[..., periodic.Screened] = periodic.screen
              ) -> tuple[Identification | None, list[periodic.Line]]:
    """:func:`identify` with the harmonics ``known`` subtracted before SSI. Without ``known``,
    when :func:`identifier.modal.harmonics.confirm` finds harmonics that were not subtracted: no
    result and those harmonics, for a second pass. ``beside``: the reported frequencies (rad/s) of the pass
    this one extends; candidates within ``short_lags.NEAR`` of one are dropped untested (never added).
    ``screen``: :func:`.harmonics.screen` or the call's :class:`.harmonics.Screens`."""
    input_output.check(input, traces)
    if uncertainty not in UNCERTAINTY:
        raise IdentificationError(f"unknown uncertainty {uncertainty!r}; known: {', '.join(UNCERTAINTY)}",
                                  field="uncertainty")
    records, channels, dt, left_out = sensor_records(traces, quantity)
    tune_from_environment()
    m = records[0].shape[0]
    r = min(references, m)
    if (block_rows is not None and block_rows < 2) or max_order < 2 or segments < 2 or references < 1:
        raise IdentificationError("block_rows, max_order and segments must be at least 2, references at least 1",
                                  field="options")
    shortest = min(y.shape[1] for y in records)
    mo = min(m, max(ROW_CHANNELS, r))
    refs = reference_channels(m, r)
    decay, free = free_response(traces, records)
    if not free:  # a stationary record's mean (a sensor offset, a static deflection) is no mode: removed
        records = [y - y.mean(axis=1, keepdims=True) for y in records]
    screened = periodic.Screened(records, [], []) if free else screen(records, dt, known)  # a free response
    # of an undamped structure is a sum of sinusoids: only stationary records are searched for harmonics
    records = screened.records
    f_low = 0.0 if decay else lowest_frequency(records, dt, refs)
    p, q = block_sizes(shortest, m, r, mo, max_order, dt, decay, f_low, block_rows)
    if shortest < 20 * (p + q):
        raise IdentificationError(f"{traces[0].path.name}: {shortest} samples are too few for {p} block rows "
                                  f"(need at least 20 x (rows + columns) = {20 * (p + q)}); give fewer "
                                  f"block rows or a longer record", field="block_rows")
    cov = covariances(records, dt, p + q - 1, r, segments)
    if not decay and block_rows is None:  # random response: only the lags that carry signal
        span = signal_span(cov, max(8, int(np.ceil(1.0 / (2.0 * f_low * dt)))))
        if span < p + q - 1:
            p, q = block_sizes(shortest, m, r, mo, max_order, dt, decay, f_low, span=span)
            cov = cov.truncated(p + q - 1)
    order_cap = min(max_order, q * r, p * mo - mo)
    if order_cap < 2:
        raise IdentificationError(f"{traces[0].path.name}: {shortest} samples of {m} channel(s) allow no model "
                                  f"order (block rows {p}, columns {q}); give a longer record", field="block_rows")
    full = cov.mean()
    W = row_projection(full, mo)
    with one_blas_thread():  # many small factorisations: threads only cost here
        H = BlockHankel(project(full, W), p, q)
        U, s, V = leading_svd(H, order_cap, power=1)
        replicates = Replicates(cov, W, H, U) if uncertainty == "jackknife" else None
        rows = subspace(U, mo)
        space = Subspace(full[:q].transpose(1, 0, 2).reshape(m, -1) @ (V / s), rows.gram, rows.shift)
        poles = [poles_at(space, n, dt, cov.scale) for n in range(2, min(order_cap, space.orders) + 1, 2)]
        by_order = {pl.order: pl for pl in poles}
        fit = {}  # (order, index) of a mode's representative pole: the mode's coherence
        incoherent: list[dict] = []  # the candidates the coherence test rejects, for details.rejected

        def coherent(candidates: list[Mode]) -> list[bool]:
            values = _coherence(U, mo, by_order, candidates)
            fit.update(((md.order, md.index), c) for md, c in zip(candidates, values))
            ok = [c >= COHERENCE or exempt for c, exempt in zip(values, _exempt(candidates, values, len(poles)))]
            incoherent.extend({"omega": md.omega, "zeta": md.zeta,
                               "reason": f"temporal coherence {c:.2f} (needs {COHERENCE:g})"}
                              for md, c, good in zip(candidates, values, ok) if not good)
            return ok

        modes, flags = select_modes(poles, Criteria.for_record(not free, min_fraction), coherent)
        modes = [md for md in modes if not np.any(np.abs(np.array(beside) - md.omega) <= lag_pass.NEAR * md.omega)]
        periodic_modes, found = periodic.confirm(
            screened, dt, np.array([md.omega for md in modes]),
            np.array([median(np.abs([by_order[n].zeta[j] for n, j in md.used])) for md in modes]),
            np.array([md.zeta for md in modes]), _scatter(modes, by_order)[0]) if not free \
            else (np.zeros(len(modes), bool), [])
        if not known and (pending := periodic.unsubtracted(found, screened)):
            return None, pending  # they took model orders: again with them subtracted
        modes = [md for md, h in zip(modes, periodic_modes) if not h]
        fits = [fit[md.order, md.index] for md in modes]
        shapes = np.column_stack([by_order[md.order].shapes[:, md.index] for md in modes]) if modes \
            else np.zeros((m, 0), complex)
        omega_se, zeta_se, missed, shape_se = jackknife(replicates, by_order,
                                                        list(zip(_spread(modes), [md.omega for md in modes]))) \
            if replicates else (np.full(len(modes), np.nan), np.full(len(modes), np.nan), np.zeros(len(modes)),
                                np.full((m, len(modes)), np.nan))
    omega = np.array([md.omega for md in modes])
    zeta = np.array([md.zeta for md in modes])
    length = (max if free else sum)(y.shape[1] for y in records) * dt  # s: see support.record_bias
    edges = band_edges.band(records, dt)  # of the band a filter left in the record
    omega_se, zeta_se = with_bias(omega, omega_se, zeta_se, length, free, _scatter(modes, by_order))
    verdict = judge(omega, zeta, omega_se, zeta_se, missed if drop_unrepeated else np.zeros(len(modes)),
                    np.array([md.support for md in modes]),
                    np.array([len({n for n, _ in md.members}) for md in modes]) / max(len(poles) - 1, 1),
                    shapes, length, free, segments,
                    errors=replicates is not None, shape_std=shape_se, spectrum=(records, dt),
                    coherence=np.array(fits, float), edges=edges)
    if free and decay:  # each mode above the sensor noise of a record that does decay (a trace labelled
        # impulse whose response goes on, e.g. under an unmeasured force, fits no free response: not screened)
        verdict = decay_snr.screen(records, dt, omega, zeta, verdict, incoherent)
    dropped = support_rejected(omega, zeta, verdict)
    rejected = incoherent + dropped
    kept = verdict.keep
    modes, shapes, omega_se, zeta_se = [md for md, k in zip(modes, kept) if k], shapes[:, kept], \
        omega_se[kept], zeta_se[kept]
    fits, shape_se = [c for c, k in zip(fits, kept) if k], shape_se[:, kept]
    split = split_free_decays(traces, records, dt, omega[kept], zeta[kept], shapes, omega_se, zeta_se, refine)
    finite = np.isfinite(split.omega_std) & np.isfinite(split.zeta_std) | (replicates is None)
    rejected += [{"omega": float(w), "zeta": float(z), "reason": "no finite standard error (close-pair fit)"}
                 for w, z in zip(split.omega[~finite], split.zeta[~finite])]
    omega, zeta, omega_se, zeta_se = split.omega[finite], split.zeta[finite], split.omega_std[finite], \
        split.zeta_std[finite]
    shapes, refined, source = split.shapes[:, finite], split.refined[finite], split.source[finite]
    shape_se = carried(shape_se, source, refined)  # a shape from the close-pair fit: NaN
    ml = refine_poles(traces, records, dt, omega, zeta, omega_se, zeta_se, refined,
                      [(r["omega"], r["zeta"]) for r in dropped], refine)  # free decays: the poles by ML
    ml, gone = decay_snr.retest(records, dt, ml, rejected) if decay else (ml, [])  # refined poles vs noise
    ml, pairs = decay_pairs.screen(traces, records, dt, ml, dropped, refine) if decay else (ml, [])
    ml, more = decay_search.search(traces, records, dt, ml, rejected + gone + pairs, refine, edges) if decay \
        else (ml, [])
    rejected += gone + pairs + more  # the pair test: one pole for a broad mode's two; then missed modes
    ml, banded, widened = band_fit.checked(records, dt, ml, [fits[i] if i >= 0 else None for i in np.append(
        source, -1)[ml.source]], length, not (free or ml.details["applied"]), COHERENCE)  # fits: per candidate
    rejected += widened  # stationary: vs bands; an exempt widened mode no longer resolved from a coherent one
    omega, zeta, omega_se, zeta_se = ml.omega, ml.zeta, ml.omega_std, ml.zeta_std
    shapes = np.column_stack([shapes, np.zeros(len(shapes))])[:, ml.source]  # -1: a split merger's second
    shape_se = np.column_stack([shape_se, np.full(len(shape_se), np.nan)])[:, ml.source]  # mode, shape by LS
    refined, source = np.append(refined, False)[ml.source], np.append(source, -1)[ml.source]
    shapes, shape_se = free_decay_shapes(traces, records, dt, omega, zeta, ml.applied, shapes,
                                         shape_se if replicates else None)  # refined modes: LS shapes
    periodic.on_modes(found, omega, zeta)
    modes = [modes[i] if i >= 0 else None for i in source]  # -1: found by the free-decay fit
    fits = [fits[i] if i >= 0 else None for i in source]
    return input_output.attach(traces, channels, input, Identification(
        method="modal", structure=model.name if model is not None else traces[0].structure,
        repetition=traces[0].repetition, tests=[t.test for t in traces],
        omega=omega.tolist(), eigenvalues=(omega**2).tolist(), mode_shapes=real_shapes(shapes).T.tolist(),
        mode_shapes_std=shape_se.T.tolist(),
        sensors=[c.name for c in channels],
        damping=zeta.tolist(), omega_std=omega_se.tolist(), damping_std=zeta_se.tolist(),
        mpc=mpc(shapes).tolist(),
        mode_shapes_complex=[[[float(v.real), float(v.imag)] for v in col] for col in shapes.T],
        details={"algorithm": "ssi-cov", "quantity": channels_quantity(channels), "block_rows": p, "block_columns": q,
                 "references": r, "segments": segments, "max_order": order_cap, "uncertainty": uncertainty,
                 "orders": [md.order if md else None for md in modes],
                 "support": [md.support if md else None for md in modes],
                 "coherence": fits,
                 "refined": refined.tolist(), "ml_refinement": ml.details, "band_fit": banded,
                 "record_s": length,
                 "rejected": sorted(rejected, key=lambda r: r["omega"]),
                 "harmonics": [ln.entry() for ln in found],
                 "warnings": left_out + short_record_warnings(free, f_low, length) + band_edges.edge_warnings(edges),
                 "stabilisation": _diagram(poles, flags)})), []


def _scatter(modes: list[Mode], by_order: dict[int, Poles]) -> tuple[np.ndarray, np.ndarray]:
    """Standard deviations (k,) of omega rad/s and zeta over each mode's own poles (one per order)."""
    values = [np.array([(by_order[n].omega[j], by_order[n].zeta[j]) for n, j in md.own])
              for md in modes]
    spread = np.array([v.std(axis=0) for v in values]).reshape(-1, 2)
    return spread[:, 0], spread[:, 1]


def _coherence(U: np.ndarray, rows: int, by_order: dict[int, Poles], modes: list[Mode],
               count: int = COHERENCE_ORDERS) -> list[float]:
    """Each mode's temporal coherence: at ``count`` of its orders spread over
    those of the stable poles it is estimated from (``used``, (order,
    index) pairs), the coherence of its most coherent pole there; their median. One
    :func:`coherence` call for the poles of every mode."""
    if not modes:
        return []
    picks = []  # per mode, per picked order: its poles there
    for md in modes:
        orders = sorted({n for n, _ in md.used})
        chosen = [orders[i] for i in np.unique(np.linspace(0, len(orders) - 1, count).round().astype(int))]
        picks.append([[(k, j) for k, j in md.used if k == n] for n in chosen])
    pairs = sorted({pair for mode_picks in picks for there in mode_picks for pair in there})
    value = dict(zip(pairs, coherence(U, rows, *pole_columns(by_order, pairs, U.shape[1]))))
    return [median([max(value[pair] for pair in there) for there in mode_picks]) for mode_picks in picks]


def _spread(modes: list[Mode], count: int = 8) -> list[tuple[tuple[int, int], ...]]:
    """Per mode its stable poles at the orders the jackknife replicates
    repeat: ``count`` orders spread over all the modes' orders, shared so
    that each replicate's pole tracking runs at few orders; a mode with
    stable poles at fewer than three of them (or all its orders, if fewer)
    gets ``count`` orders spread over its own."""
    def spread(orders: list[int]) -> set[int]:
        return {orders[i] for i in np.unique(np.linspace(0, len(orders) - 1, count).round().astype(int))}

    grid = spread(sorted({n for md in modes for n, _ in md.used})) if modes else set()
    picks = []
    for md in modes:
        own = sorted({n for n, _ in md.used})
        keep = grid.intersection(own)
        if len(keep) < min(3, len(own)):
            keep = spread(own)
        picks.append(tuple(pair for pair in md.used if pair[0] in keep))
    return picks


def _diagram(poles: list[Poles], flags: list[np.ndarray]) -> dict[str, list]:
    """Every pole of every order, flat: order, omega rad/s, zeta, stable (for the diagram)."""
    return {"order": [q.order for q in poles for _ in q.omega],
            "omega": [float(w) for q in poles for w in q.omega],
            "zeta": [float(z) for q in poles for z in q.zeta],
            "stable": [bool(f) for fl in flags for f in fl]}
