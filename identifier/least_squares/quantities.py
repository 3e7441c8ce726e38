"""Least squares from whatever response quantity each DOF has: the prefiltered records.

Per DOF the lowest measured level is used (displacement before velocity
before acceleration: fewer slots then need the filter's zeros at s = 0);
the forces are summed per DOF. Every record becomes a
:class:`identifier.least_squares.colored.Record`: its slots ``a``, ``v``,
``u``, ``f`` filtered as in :mod:`identifier.least_squares.prefilter`, and
its noise sources (each measured channel's white noise, declared or
estimated, and the slot filters it passes). An acceleration jumps with
every step of the held force, which the first-order hold of the filter
stages does not represent: DOF measured by acceleration alone in a mix
carry an ``O(dt)`` discretisation error (exact zero-order-hold handling of
accelerations needs the force's acceleration per unit force, as
:mod:`identifier.least_squares.integrate` estimates it when every DOF has one).

The filter's corner ``lam`` (rad/s), when not given, is :data:`BAND_FACTOR`
times the band of the run's records (:func:`prefilter.band`, the median
over records); beyond ``lam dt =`` :data:`MAX_LAM_DT` the records are refused.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from structbench.models import ModelError, Structure

from ..errors import IdentificationError
from ..io.traces import Channel, Trace
from . import offsets
from .colored import Record, Source
from .prefilter import LEVELS, SLOTS, Design, band

BAND_FACTOR = 2.0
MAX_LAM_DT = 0.5  # corner (rad/s) x dt beyond which the discretisation error is not small
QUANTITIES = ("displacement", "velocity", "acceleration")


def _dof(trace: Trace, c: Channel, model: Structure) -> int:
    try:
        return model.dof_index(c.node, c.direction)
    except ModelError:
        raise IdentificationError(f"{trace.path.name}: channel {c.name} is at ({c.node}, {c.direction!r}), "
                                  f"which is not a free DOF of model {model.name}: the model's DOF do not "
                                  "match the traces", field="model") from None


def response_channels(trace: Trace, model: Structure) -> list[Channel]:
    """One response channel per model DOF (n,), the lowest level measured there;
    raises naming the first DOF with none and the channels present, or a
    channel at no free DOF of the model (the model does not match)."""
    gap = missing_message(trace, model)
    if gap:
        raise IdentificationError(f"{trace.path.name}: least squares in the time domain needs one of "
                                  f"displacement/velocity/acceleration on every DOF of the model; {gap}",
                                  field="channels")
    best = present_channels(trace, model)
    return [best[j] for j in range(model.n_dof)]


def missing_message(trace: Trace, model: Structure) -> str:
    """"DOF ... has none ...; missing channel(s) ...; present: ..." for the
    first model DOF without a response channel; "" when every DOF has one."""
    have = {c.dof for q in QUANTITIES for c in trace.select(q)}
    missing = [d for d in model.dofs if d not in have]
    if not missing:
        return ""
    names = [c.name for c in sorted(trace.channels.values(), key=lambda c: (c.quantity, c.node, c.direction))]
    present = (", ".join(names[:12]) + (f" and {len(names) - 12} more" if len(names) > 12 else "")) or "none"
    wanted = ", ".join(f"acceleration_{n}_{d}" for n, d in missing[:6]) + (", ..." if len(missing) > 6 else "")
    return (f"DOF {missing[0]} has none" + (f" (nor {len(missing) - 1} more)" if len(missing) > 1 else "")
            + f"; missing channel(s) {wanted} (or the displacement or velocity of the same DOF); present: {present}")


def present_channels(trace: Trace, model: Structure) -> dict[int, Channel]:
    """DOF index -> the lowest-level response channel measured there, for the
    DOF that have one (unmeasured DOF absent); raises for a channel at no
    free DOF of the model."""
    best: dict[int, Channel] = {}
    for q in QUANTITIES[::-1]:
        for c in trace.select(q):
            best[_dof(trace, c, model)] = c
    return best


def record_band(trace: Trace, model: Structure) -> float:
    """The band (rad/s) of one trace's chosen response channels of the lowest
    level (a displacement-equivalent spectrum of a higher level is dominated
    by its noise at low frequencies)."""
    chans = response_channels(trace, model)
    lowest = min(LEVELS[c.quantity] for c in chans)
    data = np.column_stack([c.data for c in chans if LEVELS[c.quantity] == lowest])
    return band(data, np.full(data.shape[1], lowest), trace.dt)


def prefiltered(trace: Trace, model: Structure, lam: float, sigma_of: Callable[[Trace, Channel], np.ndarray],
                responses: dict[str, np.ndarray] | None = None) -> tuple[Record, Design]:
    """The :class:`Record` of one trace through the prefilter at ``lam`` rad/s;
    ``sigma_of(trace, channel)`` gives a channel's noise (n_t,). ``responses``
    (quantity -> (n_t, n)) replaces the channels' data by other signals of
    the same channels (a simulation: :mod:`identifier.least_squares.defect`)."""
    from . import Motion

    chans = response_channels(trace, model)
    n, m = model.n_dof, trace.time.size
    levels = np.array([LEVELS[c.quantity] for c in chans])
    design = Design.for_levels(levels, lam)
    slots = np.zeros((4, m, n))
    sources = []
    for ell in np.unique(levels):
        dofs = np.flatnonzero(levels == ell)
        data = np.column_stack([chans[j].data if responses is None else responses[chans[j].quantity][:, j]
                                for j in dofs])
        sigma = np.column_stack([sigma_of(trace, chans[j]) for j in dofs])
        filters = tuple(design.slot(2 - b, int(ell), trace.dt) for b in range(3))
        for b, f in enumerate(filters):
            slots[b][:, dofs] = f(data)
        sources.append(Source(dofs, sigma, (0, 1, 2), filters))
    forces = trace.require_forces()
    fcols = np.array([_dof(trace, c, model) for c in forces])
    force, fsigma = np.zeros((m, n)), np.zeros((m, n))
    for c, j in zip(forces, fcols):
        force[:, j] += c.data
        fsigma[:, j] = np.hypot(fsigma[:, j], sigma_of(trace, c))
    fdofs = np.unique(fcols)
    if responses is not None:
        force = responses["force"]
    ffilter = design.force(trace.dt, held=bool(np.isclose(trace.step, trace.dt)))
    slots[3][:, fdofs] = ffilter(force[:, fdofs])
    sources.append(Source(fdofs, fsigma[:, fdofs], (3,), (ffilter,)))
    flat = np.ascontiguousarray(slots.transpose(1, 0, 2)).reshape(m, 4 * n)  # raw-slot order b n + j
    motion = Motion(trace.time, slots[2], slots[1], slots[0], slots[3], {})
    return Record(motion, tuple(sources), offsets.signatures(flat, sources, design)), design


def corner(traces: Sequence[Trace], model: Structure) -> float:
    """The prefilter's corner (rad/s) for a run: :data:`BAND_FACTOR` times the
    median band of its records; the prefiltered equations need ``corner dt <=``
    :data:`MAX_LAM_DT` (the domain choice of :func:`identifier.least_squares.identify` asks the same)."""
    return BAND_FACTOR * float(np.median([record_band(t, model) for t in traces]))


def prefiltered_run(traces: Sequence[Trace], model: Structure, lam: float | None,
                    sigma_of: Callable[[Trace, Channel], np.ndarray]) -> tuple[list[Record], dict]:
    """Every trace of a run through one prefilter; ``lam`` None: from the band.
    Returns the records and what was done (for ``details``)."""
    if lam is None:
        lam = corner(traces, model)
    worst = max(lam * t.dt for t in traces)
    if worst > MAX_LAM_DT:
        raise IdentificationError(
            f"the records' response band needs a prefilter corner of {lam:.4g} rad/s, lam dt = {worst:.3g} > "
            f"{MAX_LAM_DT}: too close to the Nyquist frequency for the prefiltered equations; sample faster "
            "or measure the acceleration of every DOF", field="channels")
    parts = [prefiltered(t, model, lam, sigma_of) for t in traces]
    design = parts[0][1]
    used = sorted({c.quantity for t in traces for c in response_channels(t, model)},
                  key=QUANTITIES.index)
    info = {"lambda": design.lam, "zeros_at_dc": design.e, "order": design.r, "quantities": used,
            "slots": list(SLOTS)}
    return [r for r, _ in parts], info
