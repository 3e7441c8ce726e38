"""Operational and free-decay modal identification by covariance-driven
stochastic subspace identification (SSI-cov) with automatic order selection.

Steps (each its own module):
1. lagged output covariances ``R_l = <y_{k+l} y_ref,k^T>``, l >= 1, summed per
   sample group (:mod:`identifier.ssi_covariance`); white sensor noise only
   enters ``R_0``, which is not used;
2. block Hankel matrix of ``p`` block rows, its leading singular vectors, and
   the poles ``s = ln(mu(A)) / dt`` of every model order 2, 4, ..., ``max_order``
   (:mod:`identifier.ssi_poles`): ``omega = |s|`` rad/s, ``zeta = -Re s / |s|``,
   complex shapes ``C psi``;
3. stabilisation across orders and clustering of the stable poles into modes
   (:mod:`identifier.stabilisation`);
4. standard errors of every frequency and damping ratio by the delete-one-group
   jackknife over the sample groups (:mod:`identifier.modal_uncertainty`); a
   mode that more than one replicate does not find again is a noise mode and
   dropped (a mode missed by one replicate is kept without stated errors).

Assumptions: a linear time-invariant structure, the response either a free
decay or stationary (unmeasured broadband excitation), white sensor noise;
no force channel is needed or used. Several traces of one run (several
impulse tests, say) add their covariances, which is how two tests separate
a pair of close modes that one test moves as a single shape. Output-only
data cannot scale the shapes (they come normalised to max |.| = 1) and cannot
see a mode that no sensor moves in; with fewer samples than ``20 (p + q)`` or a
mode with under about one period in the record it fails or misses that mode.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from threadpoolctl import threadpool_limits

from structbench.models import Model

from .errors import IdentificationError
from .modal_uncertainty import jackknife
from .mode_split import split_free_decays
from .results import Identification
from .ssi_covariance import covariances, hankel
from .ssi_poles import Poles, leading_svd, mpc, poles_at, real_shapes, subspace
from .stabilisation import Criteria, select_modes
from .traces import Channel, Trace

QUANTITIES = ("auto", "displacement", "velocity", "acceleration")


def sensor_records(traces: Sequence[Trace], quantity: str) -> tuple[list[np.ndarray], list[Channel], float]:
    """Per trace the outputs (m, n) of one quantity (``auto``: displacement,
    else velocity, else acceleration), the channels (of the first trace) and dt s."""
    if quantity not in QUANTITIES:
        raise IdentificationError(f"unknown quantity {quantity!r}; known: {', '.join(QUANTITIES)}",
                                  field="quantity")
    first = traces[0]
    chosen = next((q for q in QUANTITIES[1:] if first.select(q)), None) if quantity == "auto" else quantity
    channels = first.select(chosen) if chosen else []
    if len(channels) < 2:
        raise IdentificationError(f"{first.path.name}: modal identification needs at least 2 "
                                  f"{chosen or 'motion'} sensors, found {len(channels)}", field="channels")
    records = []
    for trace in traces:
        here = [trace.channel(chosen, c.node, c.direction) for c in channels]
        bad = [c.name for c in here if not np.all(np.isfinite(c.data))]
        if bad:
            raise IdentificationError(f"{trace.path.name}: channel {bad[0]} holds NaN or infinite samples",
                                      field=bad[0])
        if not np.isclose(trace.dt, first.dt, rtol=1e-9):
            raise IdentificationError(f"{trace.path.name}: dt {trace.dt} s differs from {first.dt} s",
                                      field="dt")
        records.append(np.vstack([c.data for c in here]))
    return records, channels, first.dt


def auto_block_rows(m: int) -> int:
    """Default block rows ``p``: 200, fewer for many channels (p m <= 4000), at least 12."""
    return int(min(200, max(12, 4000 // m)))


def auto_block_columns(rows: int, references: int, max_order: int) -> int:
    """Default block columns: a quarter of the rows (lags 1 .. 1.25 p), at least
    enough for 1.5 x ``max_order`` columns."""
    return int(max(rows // 4, -(-3 * max_order // (2 * references)), 2))


def identify(traces: Sequence[Trace], model: Model | None = None, quantity: str = "auto",
             block_rows: int | None = None, max_order: int = 80, references: int = 20, segments: int = 8,
             min_fraction: float = 0.3, drop_unrepeated: bool = True, refine: str = "auto") -> Identification:
    """Natural frequencies (rad/s), damping ratios, shapes and their standard
    errors from the outputs of one run's traces (``model`` is not needed;
    it only names the structure). ``drop_unrepeated``: report only modes that
    all jackknife replicates but at most one find again (spurious noise modes
    do not). ``refine``: ``auto`` fits free responses whole to split close
    pairs (:mod:`identifier.mode_split`), ``off`` does not."""
    records, channels, dt = sensor_records(traces, quantity)
    m = records[0].shape[0]
    p = block_rows or auto_block_rows(m)
    r = min(references, m)
    if p < 2 or max_order < 2 or segments < 2 or references < 1:
        raise IdentificationError("block_rows, max_order and segments must be at least 2, references at least 1",
                                  field="options")
    q = auto_block_columns(p, r, max_order)
    order_cap = min(max_order, q * r)
    shortest = min(y.shape[1] for y in records)
    if shortest < 20 * (p + q):
        raise IdentificationError(f"{traces[0].path.name}: {shortest} samples are too few for {p} block rows "
                                  f"(need at least 20 x (rows + columns) = {20 * (p + q)}); give fewer "
                                  f"block rows or a longer record", field="block_rows")
    cov = covariances(records, dt, p + q - 1, r, segments)
    with threadpool_limits(1, "blas"):  # many small factorisations: threads only cost here
        U = leading_svd(hankel(cov.mean(), p, q), order_cap)
        space = subspace(U, m)
        poles = [poles_at(space, n, dt, cov.scale) for n in range(2, order_cap + 1, 2)]
        modes, flags = select_modes(poles, Criteria(min_fraction=min_fraction))
        by_order = {pl.order: pl for pl in poles}
        shapes = np.column_stack([by_order[md.order].shapes[:, md.index] for md in modes]) if modes \
            else np.zeros((m, 0), complex)
        omega_se, zeta_se, missed = jackknife(cov, (p, q), U, [(_spread(md), md.omega, shapes[:, k])
                                                               for k, md in enumerate(modes)])
    kept = (missed <= 1) | (not drop_unrepeated)
    modes, shapes, omega_se, zeta_se = [md for md, k in zip(modes, kept) if k], shapes[:, kept], \
        omega_se[kept], zeta_se[kept]
    omega = np.array([md.omega for md in modes])
    zeta = np.array([md.zeta for md in modes])
    split = split_free_decays(traces, records, dt, omega, zeta, shapes, omega_se, zeta_se, refine)
    omega, zeta, omega_se, zeta_se, shapes = split.omega, split.zeta, split.omega_std, split.zeta_std, split.shapes
    modes = [modes[i] for i in split.source]
    rows = real_shapes(shapes)
    return Identification(
        method="modal", structure=model.name if model is not None else traces[0].structure,
        repetition=traces[0].repetition, tests=[t.test for t in traces],
        omega=omega.tolist(), eigenvalues=(omega**2).tolist(), mode_shapes=rows.T.tolist(),
        sensors=[c.name for c in channels],
        damping=zeta.tolist(), omega_std=omega_se.tolist(), damping_std=zeta_se.tolist(),
        mpc=mpc(shapes).tolist(),
        mode_shapes_complex=[[[float(v.real), float(v.imag)] for v in col] for col in shapes.T],
        details={"algorithm": "ssi-cov", "quantity": channels[0].quantity, "block_rows": p, "block_columns": q,
                 "references": r, "segments": segments, "max_order": order_cap,
                 "orders": [md.order for md in modes], "support": [md.support for md in modes],
                 "refined": split.refined.tolist(),
                 "stabilisation": _diagram(poles, flags)})


def _spread(mode, count: int = 5) -> tuple[int, ...]:
    """Up to ``count`` model orders spread over those of a mode's stable poles
    (the jackknife replicates repeat the median over these)."""
    orders = sorted({n for n, _ in mode.members})
    return tuple(orders[i] for i in np.unique(np.linspace(0, len(orders) - 1, count).round().astype(int)))


def _diagram(poles: list[Poles], flags: list[np.ndarray]) -> dict[str, list]:
    """Every pole of every order, flat: order, omega rad/s, zeta, stable (for the diagram)."""
    return {"order": [q.order for q in poles for _ in q.omega],
            "omega": [float(w) for q in poles for w in q.omega],
            "zeta": [float(z) for q in poles for z in q.zeta],
            "stable": [bool(f) for fl in flags for f in fl]}
