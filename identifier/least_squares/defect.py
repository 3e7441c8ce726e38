"""Defect correction: the prefiltered equations' discretisation error, computed on a simulation and removed.

The filtered equations ``M (L a) + C (L v) + K (L u) = L f``
(:mod:`identifier.least_squares.prefilter`) hold exactly in continuous
time; their sampled stages leave a residual ``d = Y theta`` of order
``(omega dt)^2`` that depends on the structure and the force, not on the
noise. For the estimate ``theta_1`` the exact zero-order-hold response of the
model to the measured forces, ``x_sim`` (the same quantities at the same
DOF, from rest), filtered like the data, gives that residual,

    d_k = Mt(theta_1)^T x_sim,k,

and the equations ``Y theta - d = 0`` (``d`` added to the force slot of
the records as filtered) are solved again; repeated from the new estimate
(:data:`identifier.least_squares.DEFECT_PASSES`) while it moves. One pass
suffices when the residual is ``O((omega dt)^2)`` (displacements,
velocities); accelerations in a mix leave an ``O(dt)`` one (their jumps
with the held force) and a first estimate far enough off to need a few.
Skipped when ``lam dt <`` :data:`MIN_LAM_DT` (the residual of displacements
and velocities is then negligible, and a simulation of a noisy estimate's
high modes, at ``omega dt`` far above ``lam dt``, would add more than it
removes), when the estimate is not a physical model (a negative mass or
stiffness), its simulation is not finite, or its residual exceeds
:data:`MAX_DEFECT` of the force (the estimate, not the discretisation, is off).

Assumes, as the prefilter does, the structure at rest at the first sample
(``d`` is projected like the records' slots when their offsets are
estimated, :mod:`identifier.least_squares.offsets`).
Cost: one simulation per record and pass (:func:`simulate`; dense ``2 n x 2 n``
eigenproblem, so for models of moderate size).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from structbench.models import ModelError, Structure

from ..io.traces import Channel, Trace
from .colored import Record
from .quantities import prefiltered, response_channels
from .regression import layout, raw
from . import whitened

MIN_LAM_DT = 0.01  # below, the residual is O(1e-6) of the force and not corrected
MAX_DEFECT = 0.5  # a residual above this share of the force slot (RMS) is not a discretisation error


def corrected(traces: Sequence[Trace], model: Structure, records: list[Record], lam: float,
              p_unknown: np.ndarray, sigma_of: Callable[[Trace, Channel], np.ndarray]) -> list[Record] | None:
    """The records with the discretisation residual at ``p_unknown`` (the
    unknown parameters' latest estimate) in their force slots (``records``
    as the prefilter made them), or None when the correction is skipped
    (module docstring)."""
    from . import Motion

    if max(lam * t.dt for t in traces) < MIN_LAM_DT:
        return None
    p = model.values.copy()
    p[model.kind_mask()] = p_unknown
    try:
        estimate = model.with_values(p)
        matrices = [x.toarray() for x in (estimate.mass(), estimate.damping(), estimate.stiffness())]
    except (ModelError, np.linalg.LinAlgError, ValueError):
        return None
    lay = layout(model)
    mt = whitened.equation_matrix(lay, np.append(p, -1.0))
    out = []
    for trace, rec in zip(traces, records):
        force = np.zeros((trace.time.size, model.n_dof))
        for c in trace.require_forces():
            force[:, model.dof_index(c.node, c.direction)] += c.data
        sim = simulate(*matrices, force, trace.dt)
        if sim is None:
            sim = estimate.state_space().simulate(force, trace.dt)
        if not all(np.all(np.isfinite(sim[q])) for q in ("displacement", "velocity", "acceleration")):
            return None
        response_channels(trace, model)
        sim_rec, _ = prefiltered(trace, model, lam, sigma_of, responses=sim | {"force": force})
        d = (mt.T @ raw(sim_rec.motion, slice(None))).T  # (n_t, n): the residual of exact data
        if rec.projected:  # where the equations are
            d -= rec.steps.U @ (rec.steps.U.T @ d)
        m = rec.motion
        if np.sqrt(np.mean(d**2)) > MAX_DEFECT * np.sqrt(np.mean(m.force**2)):
            return None  # not a discretisation error: the estimate is too far off to correct from
        out.append(replace(rec, motion=Motion(m.times, m.displacement, m.velocity, m.acceleration, m.force + d,
                                              m.sigma)))
    return out


def simulate(M: np.ndarray, C: np.ndarray, K: np.ndarray, force: np.ndarray,
             dt: float) -> dict[str, np.ndarray] | None:
    """Exact zero-order-hold response from rest, vectorised over time by modes:
    the state ``x = [u; v]`` with ``x' = A x + B f`` in eigen-coordinates
    ``x = V z`` is ``z_(k+1) = exp(mu dt) z_k + (exp(mu dt) - 1) / mu (V^-1 B f_k)``
    per eigenvalue ``mu`` (one ``lfilter`` each). ``force`` (m, n) held over
    each step; returns displacement, velocity, acceleration (m, n) at the
    samples (acceleration with ``force[k]``), or None when ``A`` is
    defective or badly conditioned (rigid-body modes: use the state-space loop)."""
    from scipy.signal import lfilter

    n = M.shape[0]
    try:
        Minv = np.linalg.inv(M)
    except np.linalg.LinAlgError:
        return None
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    mu, V = np.linalg.eig(A)
    if np.linalg.cond(V) > 1e8 or np.min(np.abs(mu)) < 1e-9 * np.max(np.abs(mu)):
        return None
    g = np.linalg.solve(V, np.vstack([np.zeros((n, force.shape[0])), Minv @ force.T]))  # (2 n, m)
    decay = np.exp(mu * dt)
    z = np.empty_like(g)
    for i in range(2 * n):  # one recursion per eigenvalue
        z[i] = lfilter([0.0, (decay[i] - 1.0) / mu[i]], [1.0, -decay[i]], g[i])
    x = np.real(V @ z)  # (2 n, m)
    u, v = x[:n].T, x[n:].T
    return {"displacement": u, "velocity": v, "acceleration": (force - v @ C.T - u @ K.T) @ Minv.T}
