"""Least squares with unmeasured DOF from traces: FRFs at the measured DOF,
the estimate of :mod:`identifier.least_squares.unmeasured`, the sampling
defect iterated away.

The FRF groups and lines are those of
:mod:`identifier.least_squares.frequency_data` at the DOF that have a
response channel (each at its lowest measured level; the others get no
weight). With the force held over each sample the measured FRF is the
zero-order-hold equivalent: the first estimate uses the ``sinc``
approximation (for accelerations only at lines with ``omega dt <=``
:data:`~.frequency_data.FIRST_OMEGA_DT`, when enough remain), then the
defect of the latest estimate is subtracted and the fit repeated from it,
up to :data:`~.frequency_data.ZOH_PASSES` times, until no determined
parameter moves by 0.01 standard errors. The final estimate is refused
when its lines cannot support it (:func:`~.unmeasured_support.check_support`:
no more clusters of lines than determined parameters).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from structbench.models import Structure

from ..errors import IdentificationError
from ..io.traces import Channel, Trace
from .estimate import Estimate
from .frequency import CLUSTER
from .frequency_data import FIRST_OMEGA_DT, MIN_COHERENCE, ZOH_PASSES, measured, receptance
from .unmeasured import solve
from .unmeasured_support import check_support


def unmeasured_dofs(traces: Sequence[Trace], model: Structure) -> list[tuple]:
    """The model's DOF without a response channel in some trace."""
    from .quantities import present_channels

    have = [set(present_channels(t, model)) for t in traces]
    return [d for j, d in enumerate(model.dofs) if not all(j in h for h in have)]


def _remedy(parts: Sequence) -> str:
    """What would do when the sampling correction fails: other sensors for displacements alone."""
    if all(np.all(p.levels == 0) for p in parts):
        return "displacements alone carry few coherent lines: measure velocities or accelerations, or more DOF"
    return "measure more DOF or a longer record"


def solve_traces(traces: Sequence[Trace], model: Structure,
                 sigma_of: Callable[[Trace, Channel], np.ndarray]) -> tuple[Estimate, np.ndarray]:
    """The estimate over the unknown parameters (NaN where undetermined) and
    the undetermined mask (n_u,), from ``traces`` with unmeasured DOF."""
    parts = measured(traces, model, sigma_of, partial=True)
    kept = sum(p.omega.size for p in parts)
    if kept == 0:
        raise IdentificationError(f"no FRF line with coherence >= {MIN_COHERENCE} and at least 2 averages at "
                                  "the measured DOF: nothing to fit in the frequency domain", field="channels")
    mask = model.kind_mask()
    first = receptance(model, parts, None)
    dt = np.repeat([p.dt for p in parts], [p.omega.size for p in parts])
    low = np.array([p.held and bool(np.any(p.levels == 2)) for p in parts for _ in p.omega]) & (
        first.omega * dt > FIRST_OMEGA_DT)
    if low.any() and 2 * np.isfinite(first.var[~low]).sum() >= 4 * mask.sum():
        first = first.take(~low)
    p, std, bad, info = solve(model, first, refuse=False)
    held = any(part.held for part in parts)
    passes = 0
    if held or low.any():
        for passes in range(1, ZOH_PASSES + 1):
            try:
                with np.errstate(all="ignore"):
                    corrected = receptance(model, parts, p if held else None)
                if not np.all(np.isfinite(corrected.h)):
                    raise ValueError("non-finite")
            except (ValueError, np.linalg.LinAlgError, IdentificationError):
                raise IdentificationError(
                    "the sampling (zero-order-hold) correction failed at the estimate from the lines with omega dt "
                    f"<= {FIRST_OMEGA_DT} (cost per degree of freedom {info['output_error_cost']:.3g}, 1 when the "
                    f"model fits): that estimate is not a stable structure; {_remedy(parts)}", field="channels") from None
            new, std, bad, info_new = solve(model, corrected, p, refuse=False)
            info |= info_new
            ok = ~bad
            moved = np.max(np.abs(new[mask][ok] - p[mask][ok]) / np.maximum(std[ok], 1e-300), initial=0.0)
            p = new
            if moved < 0.01 or not held:
                break
    unmeasured = sorted({tuple(model.dofs[j]) for j in range(model.n_dof) if not any(j in part.dofs for part in parts)})
    check_support(info, int(np.sum(~bad)), unmeasured)
    values = p[mask].copy()
    values[bad] = np.nan
    n_obs = int(sum(np.isfinite(part.var).sum() for part in parts))
    details = info | {
        "estimator": "output error at the measured DOF (Gauss-Newton), unmeasured DOF condensed; start from "
                     "the kind factors and the linear pseudo-parameter iteration",
        "std_errors": f"larger of a sandwich over clusters of {CLUSTER} consecutive lines and the model-based",
        "unmeasured_dofs": [list(d) for d in unmeasured],
        "frequency_domain": {"frf": "H1" + (" (declared force noise removed)" if any(p.force_noise for p in parts)
                                            else ""),
                             "analyses": sorted({p.analysis for p in parts}), "lines": kept,
                             "lines_total": sum(p.lines_total for p in parts), "groups": len(parts),
                             "min_coherence": MIN_COHERENCE, "zoh_corrections": passes if held else 0,
                             "variance": "residual spectrum (coherence and averages)"}}
    return Estimate(values, std, float("nan"), float(np.sqrt(info["output_error_cost"])), 2 * n_obs, details), bad
