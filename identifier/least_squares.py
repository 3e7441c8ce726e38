"""Chapter 3: element parameters by time-domain least squares (eqs. 3.1-3.15).

At a sample time ``t_k`` the equations of motion ``M a + C v + K u = F`` are
linear in the element parameters: ``A(t_k) p = F(t_k)`` with columns
``dM_j a(t_k)``, ``dC_j v(t_k)``, ``dK_j u(t_k)`` (Rayleigh damping
``alpha M + beta K`` folds into the mass and stiffness columns). Parameters of
known kinds move to the right-hand side; the equations of all sample times
(and of all traces of a repetition) are stacked, ``B p = c``, and solved by
least squares with column scaling:

* up to :data:`DENSE_COLUMNS` unknowns by an SVD of ``B`` (rank, solution and
  covariance from one factorisation);
* beyond, by the sparse normal equations (``splu``), the rank from the
  smallest eigenvalues by shift-invert Lanczos.

Displacements and velocities are the measured channels when every DOF has
one (``integration="auto"``), else integrated from the accelerations
(:mod:`identifier.integrate`; the structure must start at rest).

``weighting="noise"`` (default) makes it generalised least squares with the
sensor noise the channels declare: the equation error at ``t_k`` is
``M da + C dv + K du - dF``, covariance ``M Sa M + C Sv C + K Su K + Sf``
evaluated with the previous estimate (two re-weightings after plain least
squares); dense whitening up to :data:`DENSE_DOF` DOF, diagonal beyond.
Integrated displacements and velocities carry the acceleration noise as a
random walk, ``sigma_v = sigma_a sqrt(dt t)``, ``sigma_u = sigma_a sqrt(dt t^3/3)``
(correlation between sample times neglected). Without declared noise it is
plain least squares, as in the dissertation.

Rank deficiency (e.g. only rigid-body motion excited, eq. 3.15 discussion)
raises :class:`IdentificationError` naming the parameters that are not
identifiable; standard errors come from ``s^2 (B^T B)^-1``.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from structbench.models import ModelError, Structure

from .errors import IdentificationError
from .integrate import METHODS, integrate
from .results import Identification, ParameterEstimate
from .traces import Trace

DENSE_COLUMNS = 1000
DENSE_DOF = 600
RCOND = 1e-7
INTEGRATIONS = ("auto",) + METHODS
WEIGHTINGS = ("noise", "none")


@dataclass
class Motion:
    """Samples at the equation times over the model's DOF, each (m, n):
    displacement (m or rad), velocity, acceleration, force (N or N m); ``sigma``
    maps a quantity to the standard deviation of its noise, (m, n)."""

    times: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    force: np.ndarray
    sigma: dict[str, np.ndarray] = field(default_factory=dict)

    @staticmethod
    def stack(parts: Sequence["Motion"]) -> "Motion":
        cat = (lambda name: np.vstack([getattr(p, name) for p in parts]))
        quantities = set().union(*(p.sigma for p in parts))
        sigma = {q: np.vstack([p.sigma.get(q, np.zeros_like(p.force)) for p in parts]) for q in quantities}
        return Motion(np.concatenate([p.times for p in parts]), cat("displacement"), cat("velocity"),
                      cat("acceleration"), cat("force"), sigma)


@dataclass
class Estimate:
    """Least-squares solution over the unknown parameters: ``values``,
    ``std_errors`` (same units), ``condition`` (of the column-scaled ``B``),
    ``residual_rms`` (N), ``n_equations``."""

    values: np.ndarray
    std_errors: np.ndarray
    condition: float
    residual_rms: float
    n_equations: int


def sample_indices(time: np.ndarray, samples: int, interval: float, where: str = "trace") -> np.ndarray:
    """Indices of ``t_k = t_0 + interval k``, k = 1..samples, on the sampling grid."""
    if samples < 1 or interval <= 0:
        raise IdentificationError("need at least one sample time and a positive interval", field="samples")
    dt = time[1] - time[0]
    wanted = time[0] + interval * np.arange(1, samples + 1)
    idx = np.round((wanted - time[0]) / dt).astype(int)
    if idx[-1] >= time.size:
        raise IdentificationError(f"{where}: sample time {wanted[-1]:g} s is beyond the record "
                                  f"(ends at {time[-1]:g} s)", field="samples")
    off = np.abs(time[idx] - wanted) > 1e-6 * dt
    if off.any():
        raise IdentificationError(f"{where}: sample time {wanted[off][0]:g} s is not on the sampling grid "
                                  f"(dt = {dt:g} s)", field="interval")
    return idx


def _dof_columns(trace: Trace, channels: list, model: Structure) -> np.ndarray:
    cols = []
    for c in channels:
        try:
            cols.append(model.dof_index(c.node, c.direction))
        except ModelError:
            raise IdentificationError(f"{trace.path.name}: channel {c.name} is at ({c.node}, {c.direction!r}), "
                                      f"which is not a free DOF of model {model.name}: the model's DOF do not "
                                      "match the traces", field="model") from None
    return np.array(cols, dtype=int)


def _full(trace: Trace, quantity: str, model: Structure) -> tuple[np.ndarray, np.ndarray] | None:
    """A quantity on every model DOF, (n_t, n) with its sigma, or None if any DOF lacks it."""
    channels = trace.select(quantity)
    cols = _dof_columns(trace, channels, model)
    if set(cols.tolist()) != set(range(model.n_dof)):
        return None
    data, sigma = np.zeros((trace.time.size, model.n_dof)), np.zeros((trace.time.size, model.n_dof))
    for c, j in zip(channels, cols):
        data[:, j], sigma[:, j] = c.data, c.sigma()
    return data, sigma


def trace_motion(trace: Trace, model: Structure, samples: int, interval: float,
                 integration: str = "auto") -> tuple[Motion, str]:
    """The motion of one trace at its sample times, and how u, v were obtained."""
    if integration not in INTEGRATIONS:
        raise IdentificationError(f"unknown integration {integration!r}; known: {', '.join(INTEGRATIONS)}",
                                  field="integration")
    acc = _full(trace, "acceleration", model)
    if acc is None:
        have = {c.dof for c in trace.select("acceleration")}
        missing = [f"acceleration_{n}_{d}" for n, d in model.dofs if (n, d) not in have]
        raise IdentificationError(f"{trace.path.name}: least squares needs the acceleration of every DOF; "
                                  f"missing channel(s) {', '.join(missing)}", field="channels")
    forces = trace.require_forces()
    fcols = _dof_columns(trace, forces, model)
    force, fsigma = np.zeros_like(acc[0]), np.zeros_like(acc[0])
    for c, j in zip(forces, fcols):
        force[:, j] += c.data
        fsigma[:, j] = np.hypot(fsigma[:, j], c.sigma())
    measured = {q: _full(trace, q, model) for q in ("displacement", "velocity")}
    how = "measured"
    if integration != "auto" or any(m is None for m in measured.values()):
        how = "zoh-simpson" if integration == "auto" else integration
        v, u = integrate(acc[0], trace.dt, how, force[:, np.unique(fcols)], trace.step)
        t = (trace.time - trace.time[0])[:, None]
        measured = {"displacement": (u, acc[1] * np.sqrt(trace.dt * t**3 / 3)),
                    "velocity": (v, acc[1] * np.sqrt(trace.dt * t))}
    idx = sample_indices(trace.time, samples, interval, trace.path.name)
    sigma = {"acceleration": acc[1][idx], "force": fsigma[idx],
             "displacement": measured["displacement"][1][idx], "velocity": measured["velocity"][1][idx]}
    return Motion(trace.time[idx], measured["displacement"][0][idx], measured["velocity"][0][idx],
                  acc[0][idx], force[idx], sigma), how


def equations(model: Structure, motion: Motion) -> tuple[sp.csr_matrix, np.ndarray]:
    """``B`` (m n, n_par) over all parameters and ``F`` (m n,) stacked by sample time."""
    par, rows, cols, vals = model.triplets
    alpha, beta = model.rayleigh
    kind_of = np.array([{"mass": 0, "damping": 1, "stiffness": 2}[p.kind] for p in model.parameters])
    signals = np.stack([motion.acceleration + alpha * motion.velocity, motion.velocity,
                        motion.displacement + beta * motion.velocity])  # (3, m, n)
    m, n = motion.acceleration.shape
    data = vals[:, None] * signals[kind_of[par], :, cols]  # (nnz, m)
    row = rows[:, None] + n * np.arange(m)[None, :]
    col = np.broadcast_to(par[:, None], data.shape)
    B = sp.csr_matrix((data.ravel(), (row.ravel(), col.ravel())), shape=(m * n, len(model.parameters)))
    return B, motion.force.ravel()


def _noise_factors(model: Structure, p: np.ndarray, motion: Motion) -> list[np.ndarray]:
    """Per sample time, the inverse Cholesky factor (or inverse std, diagonal) of the equation error."""
    mats = {"acceleration": model.mass(p), "velocity": model.damping(p), "displacement": model.stiffness(p)}
    dense = model.n_dof <= DENSE_DOF
    out = []
    for k in range(motion.times.size):
        cov = sp.diags(motion.sigma["force"][k] ** 2)
        for q, mat in mats.items():
            cov = cov + mat @ sp.diags(motion.sigma[q][k] ** 2) @ mat.T
        if dense:
            c = cov.toarray()
            c[np.diag_indices_from(c)] += 1e-12 * np.trace(c) / c.shape[0]
            out.append(la.solve_triangular(la.cholesky(c, lower=True), np.eye(c.shape[0]), lower=True))
        else:
            d = cov.diagonal()
            out.append(1.0 / np.sqrt(d + 1e-12 * d.mean()))
    return out


def _whiten(B: sp.csr_matrix, c: np.ndarray, factors: list[np.ndarray]) -> tuple[sp.csr_matrix, np.ndarray]:
    blocks = [sp.csr_matrix(w) if w.ndim == 2 else sp.diags(w) for w in factors]
    W = sp.block_diag(blocks, format="csr")
    return W @ B, W @ c


def _not_identifiable(null: np.ndarray, labels: list[str]) -> list[str]:
    weight = np.sqrt(np.sum(null**2, axis=0))
    return [lab for lab, w in zip(labels, weight) if w > 1e-2]


def _raise_deficient(names: list[str], rank: int, total: int) -> None:
    listed = ", ".join(names[:30]) + (f" and {len(names) - 30} more" if len(names) > 30 else "")
    raise IdentificationError(f"rank deficient ({rank} of {total}): parameter(s) {listed} are not "
                              "identifiable from these measurements (is elastic motion excited?)",
                              field="parameters")


def _check_excited(model: Structure, motion: Motion, B: sp.csr_matrix, labels: list[str]) -> None:
    """Columns ``dX_j x`` that vanish against ``|dX_j| |x|`` (e.g. ``dK_j u`` under
    rigid-body motion) carry no information: raise naming their parameters."""
    signal = {"mass": motion.acceleration, "damping": motion.velocity, "stiffness": motion.displacement}
    par, _, _, vals = model.triplets
    pattern = np.sqrt(np.bincount(par, vals**2, minlength=len(model.parameters)))  # |dX_j|_F
    capacity = np.array([f * np.linalg.norm(signal[p.kind]) for f, p, u in
                         zip(pattern, model.parameters, model.kind_mask()) if u])
    norms = np.sqrt(np.asarray(B.multiply(B).sum(axis=0)).ravel())
    dead = norms <= 1e-9 * capacity
    if dead.any():
        _raise_deficient([lab for lab, d in zip(labels, dead) if d], int(np.sum(~dead)), len(labels))


def _solve_dense(B: np.ndarray, c: np.ndarray, labels: list[str], rcond: float) -> Estimate:
    scale = np.linalg.norm(B, axis=0)
    U, s, Vt = la.svd(B / scale, full_matrices=False)
    bad = s < rcond * s[0]
    if bad.any():
        _raise_deficient(_not_identifiable(Vt[bad], labels), int(np.sum(~bad)), len(labels))
    x = Vt.T @ ((U.T @ c) / s) / scale
    resid = c - B @ x
    dof = B.shape[0] - B.shape[1]
    s2 = resid @ resid / dof if dof > 0 else np.nan
    std = np.sqrt(np.sum((Vt / s[:, None]) ** 2, axis=0) * s2) / scale
    return Estimate(x, std, float(s[0] / s[-1]), float(np.sqrt(np.mean(resid**2))), B.shape[0])


def _solve_sparse(B: sp.csr_matrix, c: np.ndarray, labels: list[str], rcond: float) -> Estimate:
    scale = np.sqrt(np.asarray(B.multiply(B).sum(axis=0)).ravel())
    Bs = (B @ sp.diags(1.0 / scale)).tocsr()
    N = (Bs.T @ Bs).tocsc()
    lam_max = sla.eigsh(N, k=1, which="LA", return_eigenvectors=False)[0]
    lam, vec = sla.eigsh(N, k=min(4, N.shape[0] - 1), sigma=-1e-6 * lam_max, which="LM")
    bad = lam < rcond**2 * lam_max
    if bad.any():
        _raise_deficient(_not_identifiable(vec[:, bad].T, labels), N.shape[0] - int(bad.sum()), len(labels))
    lu = sla.splu(N)
    x = lu.solve(Bs.T @ c) / scale
    resid = c - B @ x
    dof = B.shape[0] - B.shape[1]
    s2 = resid @ resid / dof if dof > 0 else np.nan
    n, block = N.shape[0], 64
    diag = np.concatenate([np.diagonal(lu.solve(np.eye(n, min(block, n - j), -j))[j:j + block]).copy()
                           for j in range(0, n, block)])  # copies: a diagonal view keeps its block alive
    std = np.sqrt(diag * s2) / scale
    return Estimate(x, std, float(np.sqrt(lam_max / lam.min())), float(np.sqrt(np.mean(resid**2))), B.shape[0])


def solve(model: Structure, motion: Motion, weighting: str = "noise", rcond: float = RCOND) -> Estimate:
    """Unknown parameters (``model.kind_mask()``) from the stacked equations of ``motion``."""
    if weighting not in WEIGHTINGS:
        raise IdentificationError(f"unknown weighting {weighting!r}; known: {', '.join(WEIGHTINGS)}",
                                  field="weighting")
    mask = model.kind_mask()
    labels = [p.label for p, u in zip(model.parameters, mask) if u]
    B_all, F = equations(model, motion)
    B = B_all.tocsc()[:, np.flatnonzero(mask)].tocsr()
    c = F - B_all.tocsc()[:, np.flatnonzero(~mask)] @ model.values[~mask]
    if B.shape[0] < B.shape[1]:
        raise IdentificationError(f"fewer equations ({B.shape[0]}) than unknowns ({B.shape[1]}): use more "
                                  "sample times or more sensors", field="samples")
    _check_excited(model, motion, B, labels)
    dense = B.shape[1] <= DENSE_COLUMNS

    def run(Bw: sp.csr_matrix, cw: np.ndarray) -> Estimate:
        return _solve_dense(Bw.toarray(), cw, labels, rcond) if dense else _solve_sparse(Bw, cw, labels, rcond)

    est = run(B, c)
    noisy = weighting == "noise" and any(np.any(s > 0) for s in motion.sigma.values())
    for _ in range(2 if noisy else 0):
        p = model.values.copy()
        p[mask] = est.values
        est = run(*_whiten(B, c, _noise_factors(model, p, motion)))
    return est


def identify(traces: Sequence[Trace], model: Structure, samples: int = 8, interval: float = 0.5,
             integration: str = "auto", weighting: str = "noise", rcond: float = RCOND) -> Identification:
    """Least-squares identification from the traces of one repetition.

    Every trace contributes its equations at ``t_0 + interval k``, k = 1..samples.
    """
    if not isinstance(model, Structure):
        raise IdentificationError(f"least squares needs a finite-element model; {model.name} is modal",
                                  field="model")
    parts = [trace_motion(t, model, samples, interval, integration) for t in traces]
    motion = Motion.stack([m for m, _ in parts])
    est = solve(model, motion, weighting, rcond)
    mask = model.kind_mask()
    chosen = [p for p, u in zip(model.parameters, mask) if u]
    p = model.values.copy()
    p[mask] = est.values
    try:
        omega = model.with_values(p).modes(min(10, model.n_dof)).omega.tolist()
    except ModelError:  # a non-physical (negative) estimate under heavy noise
        omega = []
    return Identification(
        method="least-squares", structure=model.name, repetition=traces[0].repetition,
        tests=[t.test for t in traces],
        parameters=[ParameterEstimate(q.label, q.kind, q.unit, float(v), float(s))
                    for q, v, s in zip(chosen, est.values, est.std_errors)],
        omega=omega,
        details={"sample_times": motion.times.tolist(), "n_equations": est.n_equations,
                 "condition": est.condition, "residual_rms": est.residual_rms,
                 "motion": sorted({how for _, how in parts}), "weighting": weighting if any(
                     np.any(s > 0) for s in motion.sigma.values()) else "none"})
