"""Defect correction: the prefiltered equations' discretisation error, computed on a simulation and removed.

The filtered equations ``M (L a) + C (L v) + K (L u) = L f``
(:mod:`identifier.least_squares.prefilter`) hold exactly in continuous
time; their sampled stages leave a residual ``d = Y theta`` of order
``(omega dt)^2`` that depends on the structure and the force, not on the
noise. For the estimate ``theta_1`` the exact zero-order-hold response of the
model to the measured forces, ``x_sim`` (the same quantities at the same
DOF, from rest), filtered like the data, gives that residual,

    d_k = Mt(theta_1)^T x_sim,k,

and the equations ``Y theta - d = 0`` (``d`` added to the force slot) are
solved again. One pass suffices: ``d`` changes with ``theta`` only at
second order. Skipped when ``lam dt <`` :data:`MIN_LAM_DT` (the residual is
below 1e-6 there) and when the first estimate is not a physical model (a
negative mass or stiffness) or its simulation is not finite.

Assumes, as the prefilter does, the structure at rest at the first sample.
Cost: one simulation per record (:meth:`structbench.models.Structure.state_space`).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from structbench.models import ModelError, Structure

from ..io.traces import Channel, Trace
from .colored import Record
from .quantities import prefiltered, response_channels
from .regression import layout, raw
from . import whitened

MIN_LAM_DT = 0.02


def corrected(traces: Sequence[Trace], model: Structure, records: list[Record], lam: float,
              p_unknown: np.ndarray, sigma_of: Callable[[Trace, Channel], np.ndarray]) -> list[Record] | None:
    """The records with the discretisation residual at ``p_unknown`` (the
    unknown parameters' first estimate) added to their force slots, or None
    when the correction is skipped (module docstring)."""
    from . import Motion

    if max(lam * t.dt for t in traces) < MIN_LAM_DT:
        return None
    p = model.values.copy()
    p[model.kind_mask()] = p_unknown
    try:
        estimate = model.with_values(p)
        system = estimate.state_space()
    except (ModelError, np.linalg.LinAlgError, ValueError):
        return None
    lay = layout(model)
    mt = whitened.equation_matrix(lay, np.append(p, -1.0))
    out = []
    for trace, rec in zip(traces, records):
        force = np.zeros((trace.time.size, model.n_dof))
        for c in trace.require_forces():
            force[:, model.dof_index(c.node, c.direction)] += c.data
        sim = system.simulate(force, trace.dt)
        if not all(np.all(np.isfinite(sim[q])) for q in ("displacement", "velocity", "acceleration")):
            return None
        response_channels(trace, model)
        sim_rec, _ = prefiltered(trace, model, lam, sigma_of, responses=sim | {"force": force})
        d = (mt.T @ raw(sim_rec.motion, slice(None))).T  # (n_t, n): the residual of exact data
        m = rec.motion
        out.append(Record(Motion(m.times, m.displacement, m.velocity, m.acceleration, m.force + d, m.sigma),
                          rec.sources))
    return out
