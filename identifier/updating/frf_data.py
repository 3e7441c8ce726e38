"""Measured FRFs for model updating (:mod:`.frf_residuals`): from the
traces of one run, or from an :class:`~structbench.identifier.io.frf_files.Frf`.

:class:`FrfData` holds ``L`` lines of one force each (``force[l]``, a
``(node, direction)``; lines of several forces may be mixed) at ``m``
response DOF ``dofs``: ``omega`` (L,) rad/s, ``H`` (m, L) complex in SI
units per newton of the response's quantity (``order``: 0 receptance m/N, 1
mobility (m/s)/N, 2 accelerance (m/s^2)/N; per row), their standard errors
``std`` (m, L) (of the real part and of the imaginary part each; NaN: the
entry is not used), per-line relative errors common to all rows of a line,
``gain`` (L,) (real: a force amplitude error) and ``phase`` (L,) (a force
phase error, rad), and ``hold`` (L,) the interval over which the force was
held (s; 0: a continuous force).

Two sources (:func:`from_traces` picks per test group):

- harmonic and stepped-sine tests (an ``/excitation`` attribute ``omega``):
  :func:`harmonic_lines`, one line per test by a least-squares fit of the
  whole steady-state window with the forced component plus the free
  vibration at the natural frequencies found in the records
  (:func:`structbench.identifier.perturbation.harmonic.free_frequencies`,
  seeded by the prior's). The excitation frequency is estimated from the
  responses when the trace declares actuator frequency noise (the
  commanded one otherwise). A line within half a frequency bin
  (``pi / T`` of a record of ``T`` s) of a natural frequency found in the
  records is left out (``details.unresolved``): the record cannot separate
  the forced response from the free vibration there. Why not :func:`structbench.identifier.frf.estimate`
  here: its per-block fit at the commanded frequency is meant for damped
  structures in steady state; on the undamped chapter 4 records (abrupt
  start, free vibration that never decays, 0.5 % actuator frequency noise)
  its lines are off by a median 0.5 to 19 % without any noise and up to
  125 % with the dissertation's noise (benchmarks/updating_ch4.py), far
  beyond what an updating to 0.5 % needs;
- random and impulse tests: :func:`from_frf` on the FRF product,
  ``estimate(traces, "H1")``: lines with a finite random error ``eps``
  below :data:`MAX_EPS` (the Bendat-Piersol formula holds for small
  ``eps``), ``std = |H| eps`` for the real and for the imaginary part (the
  error is circular: ``eps`` is the relative error of ``|H|`` and the phase
  error in rad).

Standard errors of a harmonic line. Response ``x`` and force amplitudes
``c = a - i b`` of ``a cos(w t) + b sin(w t)``: ``var(a), var(b)`` from the
fit (``s^2 (X^T X)^-1``, ``s^2`` the channel's residual variance), divided by
``|F|^2``. The force: a load cell (a force channel) is fitted the same way
and its relative error enters ``gain`` and ``phase`` (``var(F) / (2 |F|^2)``
each); the commanded force (``/excitation``, no load cell) is exact as
written, but the actuator applied it with the declared amplitude error
(``/noise`` ``actuator_amplitude_ratio``: ``gain``) at the estimated
frequency, starting at the commanded phase at ``t = 0``.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from structbench.models import ModelError, Structure

from ..errors import IdentificationError
from ..io.frf_files import Frf
from ..io.traces import Channel, Trace
from ..perturbation.harmonic import (Record, _refine, coefficients, design, free_frequencies, moving_misfit,
                                     resolvable)

ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}
MAX_EPS = 0.2
SEARCH_SIGMAS = 5.0  # the actual excitation frequency is sought within this many declared standard deviations
NEAR_BINS = 4.0      # free components this close (frequency bins) to the forced one are refined per test
FREE_BAND = 0.15     # a natural frequency not found in the records is sought per test within this share of the prior's


@dataclass
class FrfData:
    """Measured FRF lines (see the module docstring)."""

    omega: np.ndarray
    H: np.ndarray
    std: np.ndarray
    order: np.ndarray
    dofs: list[tuple[int, str]]
    force: list[tuple[int, str]]
    gain: np.ndarray
    phase: np.ndarray
    hold: np.ndarray
    source: str = ""
    details: dict[str, Any] = field(default_factory=dict)
    natural: np.ndarray = field(default_factory=lambda: np.zeros(0))
    natural_std: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def lines(self) -> int:
        return int(self.omega.size)

    def join(self, other: "FrfData") -> "FrfData":
        """The lines of both (the same response DOF and quantities)."""
        if other.dofs != self.dofs or not np.array_equal(other.order, self.order):
            raise IdentificationError(f"{other.source}: its responses differ from {self.source}'s", field="frf")
        cat = np.concatenate
        return FrfData(cat([self.omega, other.omega]), np.hstack([self.H, other.H]), np.hstack([self.std, other.std]),
                       self.order, self.dofs, self.force + other.force, cat([self.gain, other.gain]),
                       cat([self.phase, other.phase]), cat([self.hold, other.hold]),
                       f"{self.source}; {other.source}", self.details | other.details,
                       self.natural if self.natural.size else other.natural,
                       self.natural_std if self.natural.size else other.natural_std)


def from_frf(frf: Frf, max_eps: float = MAX_EPS) -> FrfData:
    """The lines of an FRF product (``docs/frf-format.md``) with a finite
    random error below ``max_eps`` (and a positive frequency)."""
    order = np.array([ORDER.get(r.quantity, -1) for r in frf.responses])
    if np.any(order < 0):
        bad = [r.name for r, o in zip(frf.responses, order) if o < 0]
        raise IdentificationError(f"FRF responses {bad} are not displacement, velocity or acceleration",
                                  field="responses")
    eps = np.asarray(frf.random_error, dtype=float)
    ok = np.isfinite(eps) & (eps < max_eps) & np.isfinite(frf.frf) & (frf.omega[None, :] > 0)
    lines = np.flatnonzero(ok.any(axis=0))
    if lines.size == 0:
        raise IdentificationError(f"no FRF line with a random error below {max_eps} (coherence too low)",
                                  field="frf")
    H = frf.frf[:, lines]
    std = np.where(ok[:, lines], np.abs(H) * eps[:, lines], np.nan)
    L = lines.size
    step = float(frf.attrs.get("step", frf.dt) or frf.dt)
    return FrfData(frf.omega[lines], H, std, order, [(r.node, r.direction) for r in frf.responses],
                   [(frf.force.node, frf.force.direction)] * L, np.zeros(L), np.zeros(L), np.full(L, step),
                   f"FRF {frf.estimator} of {frf.attrs.get('group', '')} ({frf.analysis})")


def _responses(trace: Trace) -> list[Channel]:
    found = sorted((c for c in trace.channels.values() if c.quantity in ORDER), key=lambda c: (c.quantity, c.dof))
    if not found:
        raise IdentificationError(f"{trace.path.name}: no displacement, velocity or acceleration channel",
                                  field="channels")
    return found


def _window(trace: Trace) -> np.ndarray:
    attrs = trace.excitation_attrs
    start = float(attrs.get("window_start", 0.0))
    keep = trace.time >= start - 1e-9 * trace.dt
    if keep.sum() < 16:
        raise IdentificationError(f"{trace.path.name}: fewer than 16 samples after window_start", field="window_start")
    return keep


def _grid_min(fun, lo: float, hi: float, spacing: float, tol: float) -> float:
    """Least ``fun`` over ``[lo, hi]``: a grid of ``spacing``, then a bounded scalar search."""
    grid = np.linspace(lo, hi, max(5, int(np.ceil((hi - lo) / spacing)) + 1))
    cost = [fun(w) for w in grid]
    k = int(np.argmin(cost))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    return float(minimize_scalar(fun, bounds=(a, b), method="bounded", options={"xatol": tol}).x)


def _line_frequencies(t: np.ndarray, y: np.ndarray, w0: float, ratio: float, free: np.ndarray, found: np.ndarray,
                      dt: float, track: bool) -> tuple[float, np.ndarray]:
    """The forced frequency (commanded ``w0``, or tracked within
    ``w0 (1 +- SEARCH_SIGMAS ratio)``) and the free ones of one test: natural
    frequencies not ``found`` in the records sought within :data:`FREE_BAND`
    of the prior's, and those within :data:`NEAR_BINS` bins of the forced one
    refined jointly with it (variable projection; their leakage into the
    forced amplitude is what matters)."""
    span = t[-1] - t[0]
    bin_ = 2 * np.pi / span
    free = np.array(free, dtype=float)
    w = w0
    if track:
        half = max(SEARCH_SIGMAS * ratio * w0, 2 * bin_)
        tracked = moving_misfit(t, y, lambda x: [*resolvable(free, x, span, dt), 0.0])
        w = _grid_min(tracked, w0 - half, w0 + half, bin_ / 4, 1e-9 * w0)
    for i in np.flatnonzero(~found & (np.abs(free - w) < FREE_BAND * free + NEAR_BINS * bin_)):
        others = [w, *resolvable(np.delete(free, i), w, span, dt), 0.0]
        misfit = moving_misfit(t, y, lambda x: others)

        def cost(x: float) -> float:
            return np.inf if abs(x - w) < 0.5 * bin_ else misfit(x)

        free[i] = _grid_min(cost, free[i] * (1 - FREE_BAND), free[i] * (1 + FREE_BAND), bin_ / 4, 1e-9 * free[i])
    near = np.flatnonzero((np.abs(free - w) < NEAR_BINS * bin_) & (np.abs(free - w) > 0.5 * bin_))
    moving = ([w] if track else []) + [float(free[i]) for i in near]
    if near.size:
        fixed = ([] if track else [w]) + [float(v) for v in np.delete(free, near)] + [0.0]
        fixed = [v for v in fixed if v == 0.0 or v == w or abs(v - w) > 0.5 * bin_]
        refined = _refine([Record(t, y)], np.array(moving), np.array(fixed), iterations=6)
        if np.all(np.isfinite(refined)) and np.all(np.abs(refined / np.array(moving) - 1) < 0.01):
            if track:
                w, refined = float(refined[0]), refined[1:]
            free[near] = refined
    return w, free


def _amplitude(t: np.ndarray, y: np.ndarray, omegas: list[float], info: dict[float, float] | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Complex amplitude of the first frequency per column of ``y`` (n, c) and
    the standard errors of its real and imaginary parts (c,) each; ``info``
    (frequency -> Fisher information) collects, for the other non-zero
    frequencies, the Cramer-Rao information on a sinusoid's frequency
    ``sum_c A_c^2 n T^2 / (12 s_c^2)`` (rad/s)^-2."""
    X = design(t, omegas)
    coef = coefficients(X, y)
    dof = max(t.size - X.shape[1], 1)
    s2 = np.sum((y - X @ coef) ** 2, axis=0) / dof
    scale = np.linalg.norm(X, axis=0)
    inv = np.linalg.inv((X / scale).T @ (X / scale)) / np.outer(scale, scale)
    if info is not None:
        span = t.size * (t[1] - t[0])
        for k, w in enumerate(omegas[1:], start=1):
            if w > 0:
                a2 = coef[2 * k] ** 2 + coef[2 * k + 1] ** 2
                info[w] = info.get(w, 0.0) + float(np.sum(a2 * t.size * span**2 / (12 * np.maximum(s2, 1e-300))))
    return coef[0] - 1j * coef[1], np.sqrt(s2 * inv[0, 0]), np.sqrt(s2 * inv[1, 1])


def _natural(windows: list, forced: list[float], guesses: np.ndarray, ratios: list[float], tracking: list[bool]
             ) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies (k,) of the free vibration in the records, the
    prior's where not found, and which were found: pooled over the records
    (:func:`~structbench.identifier.perturbation.harmonic.free_frequencies`, each
    record's forced component at ``forced``), then each one not found there
    sought in the test forced nearest to it (within :data:`FREE_BAND`)."""
    if guesses.size == 0:
        return guesses, np.zeros(0, bool)
    records = [Record(t.time[k], y, w) for (t, k, y, _), w in zip(windows, forced)]
    natural = free_frequencies(records, guesses, windows[0][0].dt)
    free = np.where(np.isfinite(natural), natural, guesses)
    found = np.isfinite(natural)
    for i in np.flatnonzero(~found):
        l = int(np.argmin([abs(w - guesses[i]) for w in forced]))
        t, keep, y, _ = windows[l]
        if abs(forced[l] - guesses[i]) > FREE_BAND * guesses[i]:
            continue
        only = np.ones(free.size, bool)
        only[i] = False
        _, here = _line_frequencies(t.time[keep], y, forced[l], ratios[l], free, only, t.dt, tracking[l])
        free[i], found[i] = here[i], True
    return free, found


def harmonic_lines(traces: Sequence[Trace], prior: Structure, track: bool | None = None) -> FrfData:
    """One line per harmonic trace (see the module docstring); ``track``:
    estimate the excitation frequency from the responses (default: when the
    trace declares actuator frequency noise)."""
    tests = [t for t in traces if "omega" in t.excitation_attrs]
    if not tests:
        raise IdentificationError("no harmonic test among the traces", field="omega")
    first = _responses(tests[0])
    names = [c.name for c in first]
    dofs = [c.dof for c in first]
    order = np.array([ORDER[c.quantity] for c in first])
    windows = []
    for t in tests:
        here = _responses(t)
        if [c.name for c in here] != names:
            raise IdentificationError(f"{t.path.name}: its response channels differ from {tests[0].path.name}'s",
                                      field="channels")
        forces = t.require_forces()
        if len(forces) > 1:
            raise IdentificationError(f"{t.path.name}: {len(forces)} forces; FRF lines need one force per test",
                                      field="force")
        keep = _window(t)
        windows.append((t, keep, np.column_stack([c.data for c in here])[keep], forces[0]))
    try:
        guesses = prior.modes().omega
    except (ModelError, ValueError, np.linalg.LinAlgError):
        guesses = np.array([])
    ratios = [float(t.noise_attrs.get("actuator_frequency_ratio", 0.0) or 0.0) for t, *_ in windows]
    tracking = [bool(track if track is not None else r > 0) for r in ratios]
    forced = [t.omega for t, *_ in windows]
    free, found = _natural(windows, forced, guesses, ratios, tracking)
    if any(tracking):  # the forced frequencies tracked; then the free ones again with the actual forced ones
        forced = [_line_frequencies(t.time[k], y, t.omega, r, free, found, t.dt, True)[0] if tr else t.omega
                  for (t, k, y, _), r, tr in zip(windows, ratios, tracking)]
        free, found = _natural(windows, forced, guesses, ratios, [False] * len(windows))
    L, m = len(windows), len(names)
    omega, H, std = np.empty(L), np.empty((m, L), complex), np.empty((m, L))
    gain, phase, hold, force = np.zeros(L), np.zeros(L), np.empty(L), []
    fisher = np.zeros(free.size)
    tracked, unresolved = [], []
    for l, (t, keep, y, f) in enumerate(windows):
        time = t.time[keep]
        w0 = t.omega
        w, here = _line_frequencies(time, y, forced[l], 0.0, free, found, t.dt, tracking[l])  # re-tracked (+- 2 bins)
        others = resolvable(here, w, time[-1] - time[0], t.dt)
        tracked.append(w)
        info: dict[float, float] = {}
        c, s_re, s_im = _amplitude(time, y, [w, *others, 0.0], info)
        for i in np.flatnonzero(found):
            fisher[i] += info.get(float(here[i]), 0.0)
        loadcell = f.name in t.channels
        if loadcell:  # a measured force at the actual frequency, with its own error
            F, f_re, f_im = _amplitude(time, f.data[keep][:, None], [w, *others, 0.0])
            rel2 = (f_re[0] ** 2 + f_im[0] ** 2) / (2 * abs(F[0]) ** 2)
            gain[l] = phase[l] = np.sqrt(rel2)
        else:  # the commanded force as written (exact), applied with the declared amplitude error
            F, _, _ = _amplitude(time, f.data[keep][:, None], [w0, 0.0])
            gain[l] = float(t.noise_attrs.get("actuator_amplitude_ratio", 0.0) or 0.0)
        F0 = F[0]
        if abs(F0) == 0:
            raise IdentificationError(f"{t.path.name}: the force {f.name} has no component at {w0} rad/s",
                                      field="force")
        omega[l], H[:, l] = w, c / F0
        std[:, l] = np.sqrt(0.5 * (s_re**2 + s_im**2)) / abs(F0)  # circular: the phase of F0 mixes re and im
        if np.any(found & (np.abs(here - w) < 0.5 * 2 * np.pi / (time[-1] - time[0]))):
            std[:, l] = np.nan  # the free vibration at a natural frequency this close is not separable
            unresolved.append(float(w))
        hold[l] = t.step
        force.append(f.dof)
    return FrfData(omega, H, std, order, dofs, force, gain, phase, hold,
                   f"{len(tests)} harmonic test(s) {tests[0].test} ..",
                   {"estimate": "harmonic: forced plus free-vibration fit per test",
                    "commanded_omega": [t.omega for t, *_ in windows], "omega": tracked,
                    "unresolved": unresolved,
                    "natural_frequencies": [float(v) if ok else None for v, ok in zip(free, found)]},
                   np.where(found, free, np.nan),
                   np.where(found & (fisher > 0), 1 / np.sqrt(np.maximum(fisher, 1e-300)), np.nan))


def has_force(traces: Sequence[Trace]) -> bool:
    """Whether any trace of the run has a force (a load cell or a commanded
    ``/excitation`` force) and a response: FRFs can be formed."""
    return any(t.forces() and any(c.quantity in ORDER for c in t.channels.values()) for t in traces)


def from_traces(traces: Sequence[Trace], prior: Structure) -> FrfData:
    """FRF lines of the run: harmonic tests by :func:`harmonic_lines`, the
    others (random, impulse) grouped by test name through the FRF product
    (:func:`structbench.identifier.frf.estimate`, ``H1``) and :func:`from_frf`.
    Traces without a force (free decays, output-only) are left out."""
    from ..frf import estimate  # the FRF product

    usable = [t for t in traces if t.forces() and "initial" not in str(t.excitation_attrs.get("kind", ""))]
    if not usable:
        raise IdentificationError("no trace of the run has a force to refer FRFs to", field="traces")
    harmonic = [t for t in usable if "omega" in t.excitation_attrs]
    out = harmonic_lines(harmonic, prior) if harmonic else None
    groups: dict[str, list[Trace]] = {}
    for t in usable:
        if "omega" not in t.excitation_attrs:
            groups.setdefault(t.test, []).append(t)
    for name, group in groups.items():
        part = from_frf(estimate(group, "H1", responses=[c.name for c in _responses(group[0])]))
        out = part if out is None else out.join(part)
    return out
