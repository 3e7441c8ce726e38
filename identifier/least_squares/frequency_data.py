"""Receptance lines for :mod:`identifier.least_squares.frequency` from traces.

Per group of traces with the same force channel and the same response
channels (:func:`identifier.least_squares.quantities.response_channels`: one
per DOF, the lowest level measured there), the FRFs by
:func:`identifier.frf.estimate` (``H1``; Welch for random tests, one record
per average for impulses, a per-line fit per stepped-sine test; Welch
segments at most :data:`MAX_SEGMENT` samples; with unmeasured DOF
1 / :data:`PARTIAL_AVERAGES` of the shortest record, up to that cap: the
unmeasured DOF amplify the leakage bias of short segments,
docs/least-squares-method.md). Then:

* **force noise**: ``H1 = S_fx / S_ff`` is biased low by the force's noise
  spectrum ``N_ff``; when the force channel declares its noise (white,
  ``N_ff = 2 sigma^2 dt``, the one-sided density the FRF's spectra are
  scaled to) ``H = S_fx / (S_ff - N_ff)`` (random and impulse tests);
* **variance** of ``H1`` per line and channel from the residual spectrum:
  ``V = S_xx (1 - gamma^2) / ((n_d - 1) S_ff)`` (``n_d`` the effective
  averages; the ``- 1`` for the fitted ``H``);
* **quantity**: a velocity or acceleration FRF is divided by
  ``(i omega)^k`` (k = 1, 2), its variance by ``omega^(2 k)``: exact, no
  differentiation;
* **sampling**: with the force held over each sample (``step == dt``) the
  measured FRF is the zero-order-hold equivalent ``Hd = C (z I - A_d)^-1
  B_d + D`` (``z = e^(i omega dt)``), not ``(i omega)^k Z^-1``: near the
  Nyquist frequency they differ by far more than the noise (for
  displacements mostly ``sinc(omega dt / 2) e^(-i omega dt / 2)``, plus
  aliases). The defect ``Hd(theta) - (i omega)^k Z(theta)^-1 e_f`` of the
  latest estimate is subtracted from the measurement (first pass:
  ``H / (sinc e^(-i omega dt/2))`` at the lines with ``omega dt <=``
  :data:`FIRST_OMEGA_DT` only: for accelerations, which jump with every
  step of the held force, that approximation fails well below the Nyquist
  frequency), up to :data:`ZOH_PASSES` times, until
  no parameter moves by 0.01 standard errors; ``Hd`` through the complex
  Schur form of ``A_d`` (rigid-body Jordan blocks are fine).

Lines used: ``0 < omega < pi / dt``, at least 2 averages, the force's
spectrum above ``1e-8`` of its largest, and the median coherence over the
channels at least :data:`MIN_COHERENCE` (where the responses are mostly
noise the compensated Gram matrix only gathers variance).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from structbench.models import Structure
from structbench.models.statespace import StateSpace

from .. import frf as frf_module
from ..frf import _analysis as _analysis_of
from ..errors import IdentificationError
from ..io.traces import Channel, Trace
from .estimate import Estimate
from .frequency import CLUSTER, REWEIGHTINGS, Lines, matrices, solve_lines
from .frequency_output import refine
from .quantities import _dof, present_channels, response_channels

LEVELS = {"displacement": 0, "velocity": 1, "acceleration": 2}
MIN_COHERENCE = 0.5
ZOH_PASSES = 8
MAX_SEGMENT = 8192  # Welch segment cap (samples): lines and time grow with it, leakage bias falls
PARTIAL_AVERAGES = 4  # with unmeasured DOF: Welch segments of 1/4 of a record (at most MAX_SEGMENT samples)
FIRST_OMEGA_DT = 0.3  # the first estimate (before any defect is known) from lines with omega dt up to this


@dataclass
class Measured:
    """One FRF group at its kept lines: ``omega`` (L,) rad/s, ``H`` (L, s)
    as measured at the ``dofs`` (s,) that have a response channel (each at
    its level), ``var`` (L, s) receptance variance, ``levels`` (s,),
    ``force`` (DOF index), ``dt``, ``held`` (force held over each sample:
    the ZOH defect applies), ``cluster`` (L,)."""

    omega: np.ndarray
    H: np.ndarray
    var: np.ndarray
    levels: np.ndarray
    force: int
    dt: float
    held: bool
    cluster: np.ndarray
    analysis: str
    lines_total: int
    force_noise: bool
    dofs: np.ndarray


def _channels(trace: Trace, model: Structure, partial: bool) -> tuple[list[Channel], np.ndarray]:
    """The response channels (lowest level per DOF) and their DOF indices:
    every DOF's (``partial`` False: raises naming a DOF without one), or
    those of the measured DOF only."""
    if not partial:
        return response_channels(trace, model), np.arange(model.n_dof)
    best = present_channels(trace, model)
    dofs = np.array(sorted(best), dtype=int)
    return [best[j] for j in dofs], dofs


def _groups(traces: Sequence[Trace], model: Structure, partial: bool = False) -> dict[tuple, list[Trace]]:
    groups: dict[tuple, list[Trace]] = {}
    for t in traces:
        forces = t.require_forces()
        dofs = {c.dof for c in forces}
        if len(dofs) != 1:
            raise IdentificationError(f"{t.path.name}: the frequency domain needs one force location per test "
                                      f"(FRFs per force); forces at {sorted(dofs)}", field="channels")
        chans = _channels(t, model, partial)[0]
        key = (forces[0].name, tuple(c.name for c in chans), round(t.dt, 12), round(t.step, 12))
        groups.setdefault(key, []).append(t)
    return groups


def _noise_density(group: Sequence[Trace], name: str, sigma_of: Callable[[Trace, Channel], np.ndarray]) -> float:
    """One-sided density ``2 sigma^2 dt`` of a channel's white noise, averaged over the group's traces."""
    chan = (lambda t: t.channels.get(name) or t.excitation[name])
    return 2.0 * float(np.mean([np.mean(sigma_of(t, chan(t)) ** 2) for t in group])) * group[0].dt


def measured(traces: Sequence[Trace], model: Structure,
             sigma_of: Callable[[Trace, Channel], np.ndarray], partial: bool = False) -> list[Measured]:
    """The FRF groups of ``traces`` (module docstring); ``partial``: at the
    DOF that have a response channel (else every DOF must have one)."""
    out = []
    for (force_name, names, _, _), group in _groups(traces, model, partial).items():
        first = group[0]
        chans, dofs = _channels(first, model, partial)
        n_min = min(t.time.size for t in group)
        segment = None  # the FRF's default (about 1/16 of the samples), at most MAX_SEGMENT samples
        if _analysis_of(first) == "welch" and 2 ** int(np.log2(max(8, min(n_min, sum(t.time.size for t in group) / 16)))) > MAX_SEGMENT:
            segment = MAX_SEGMENT * first.dt
        if partial and _analysis_of(first) == "welch":  # unmeasured DOF amplify leakage bias: longer segments
            segment = min(MAX_SEGMENT, 2 ** int(np.log2(max(8, n_min / PARTIAL_AVERAGES)))) * first.dt
        frf = frf_module.estimate(group, "H1", force=force_name, responses=list(names), segment=segment)
        omega = 2 * np.pi * frf.frequency
        s_ff, s_xx, s_fx = frf.auto_force, frf.auto_response, frf.cross
        fchan = first.channels.get(force_name) or first.excitation[force_name]
        density = frf.spectra_scaling == "density"
        n_ff = np.zeros_like(s_ff)
        if density and fchan.noise_declared and fchan.noise_ratio > 0:
            n_ff[:] = _noise_density(group, force_name, sigma_of)
        s_true = s_ff - n_ff
        n_d = frf.n_effective
        with np.errstate(divide="ignore", invalid="ignore"):
            H = s_fx / s_true
            # the residual spectrum: every error not coherent with the force (noise, leakage)
            resid = np.clip(s_xx - np.abs(s_fx) ** 2 / s_ff, 0.0, None)
            var = resid / (np.maximum(n_d - 1.0, 1e-300) * s_ff) * (s_ff / s_true) ** 2
        levels = np.array([LEVELS[c.quantity] for c in chans])
        coherent = np.median(np.nan_to_num(frf.coherence), axis=0)
        keep = ((omega > 0) & (omega < np.pi / first.dt * (1 - 1e-9)) & (n_d >= 2)
                & (s_true > 1e-8 * np.max(s_true)) & (coherent >= MIN_COHERENCE)
                & np.all(np.isfinite(H), axis=0) & np.all(np.isfinite(var), axis=0))
        index = np.arange(omega.size)
        cluster = index if frf.analysis == "harmonic" else index // CLUSTER
        w = omega[keep]
        var_rec = var[:, keep].T / w[:, None] ** (2 * levels[None, :])
        out.append(Measured(w, H[:, keep].T, var_rec, levels, _dof(first, fchan, model), first.dt,
                            bool(np.isclose(first.step, first.dt)), cluster[keep], frf.analysis, omega.size,
                            bool(np.any(n_ff > 0)), dofs))
    return out


def sampled(model: Structure, p: np.ndarray, part: Measured) -> np.ndarray:
    """The model's (parameters ``p``) sampled-data FRF, zero-order hold,
    at ``part``'s lines and levels, (L, n)."""
    M, C, K = matrices(model, p)
    try:
        minv = np.linalg.inv(M)
    except la.LinAlgError:
        raise IdentificationError("the frequency-domain estimate's mass matrix is singular: no sampled-data "
                                  "FRF to correct the lines with (too few or too noisy lines)", field="channels") from None
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ K, -minv @ C]])
    ss = StateSpace(A, np.vstack([np.zeros((n, n)), minv]), np.hstack([np.eye(n), np.zeros((n, n))]),
                    np.hstack([np.zeros((n, n)), np.eye(n)]), A[n:], minv)
    Ad, Bd = ss.discretize(part.dt)
    T, Q = la.schur(Ad, output="complex")
    rhs = Q.conj().T @ Bd[:, part.force]
    z = np.exp(1j * part.omega * part.dt)
    m = T.shape[0]
    y = np.zeros((m, z.size), dtype=complex)  # state-major: each step an elementwise sum, no BLAS call
    for k in range(m - 1, -1, -1):  # (z I - T) y = rhs, T upper triangular
        y[k] = (rhs[k] + np.sum(T[k, k + 1:, None] * y[k + 1:], axis=0)) / (z - T[k, k])
    out = np.stack([ss.Cd, ss.Cv, ss.Ca])[part.levels, part.dofs]  # (s, 2 n)
    direct = np.where(part.levels == 2, ss.Da[part.dofs, part.force], 0.0)
    return np.einsum("kl,ks->ls", y, np.einsum("jk,sj->ks", Q, out)) + direct[None, :]


def continuous(model: Structure, p: np.ndarray, part: Measured) -> np.ndarray:
    """``(i omega)^k Z^-1 e_f`` of the model at ``part``'s lines and levels, (L, n)."""
    M, C, K = matrices(model, p)
    w = part.omega
    Z = K[None] - (w**2)[:, None, None] * M[None] + 1j * w[:, None, None] * C[None]
    e = np.zeros((w.size, M.shape[0], 1), dtype=complex)
    e[:, part.force] = 1.0
    return np.linalg.solve(Z, e)[..., 0][:, part.dofs] * (1j * w[:, None]) ** part.levels[None, :]


def receptance(model: Structure, parts: Sequence[Measured], p: np.ndarray | None,
               model_h: np.ndarray | None = None) -> Lines:
    """The :class:`Lines` of ``parts``, the sampling defect removed at the
    parameters ``p`` (None: the ``sinc`` approximation); a DOF without a
    response channel gets ``h = 0`` and ``var = inf`` (no weight).
    ``model_h`` (B, n), if given: the model's ``Z(p)^-1 e_f`` at the parts'
    lines in order (an output-error evaluation's ``hh``), used instead of
    solving for the continuous FRF again."""
    out, offset = [], 0
    for part in parts:
        w = part.omega
        H = part.H
        if part.held:
            if p is None:
                H = H / (np.sinc(w * part.dt / (2 * np.pi)) * np.exp(-0.5j * w * part.dt))[:, None]
            else:
                cont = continuous(model, p, part) if model_h is None else \
                    model_h[offset:offset + w.size, part.dofs] * (1j * w[:, None]) ** part.levels[None, :]
                H = H - (sampled(model, p, part) - cont)
        offset += w.size
        h = np.zeros((w.size, model.n_dof), dtype=complex)
        var = np.full((w.size, model.n_dof), np.inf)
        h[:, part.dofs] = H / (1j * w[:, None]) ** part.levels[None, :]
        var[:, part.dofs] = part.var
        out.append(Lines(w, h, var, np.full(w.size, part.force), part.cluster))
    return Lines.join(out)


def solve_traces(traces: Sequence[Trace], model: Structure, sigma_of: Callable[[Trace, Channel], np.ndarray],
                 weighting: str = "noise", rcond: float = 1e-7, compensate: bool = True):
    """The frequency-domain estimate (:class:`~identifier.least_squares.estimate.Estimate`)
    from ``traces``, the sampling defect iterated away; its ``details`` say
    what was used."""
    parts = measured(traces, model, sigma_of)
    kept = sum(p.omega.size for p in parts)
    if kept == 0:
        raise IdentificationError("no FRF line with coherence >= "
                                  f"{MIN_COHERENCE} and at least 2 averages: nothing to fit in the frequency domain",
                                  field="channels")
    mask = model.kind_mask()
    first = receptance(model, parts, None)
    low = np.array([p.held and bool(np.any(p.levels == 2)) for p in parts for _ in p.omega]) & (first.omega * np.repeat(
        [p.dt for p in parts], [p.omega.size for p in parts]) > FIRST_OMEGA_DT)
    if 2 * model.n_dof * np.sum(~low) >= 4 * mask.sum():  # enough lines below the limit for a start
        first = first.take(~low)
    refined = compensate and weighting == "noise"
    # the start of the output-error fit: plain whitened least squares (stable; its bias is removed by the fit)
    est = solve_lines(model, first, weighting, compensate and not refined, rcond=rcond,
                      reweightings=0 if refined else REWEIGHTINGS)
    passes, std, p = 0, est.std_errors, model.values.copy()
    p[mask] = est.values
    held = any(part.held for part in parts)
    memo: dict = {}  # the output-error fit's last evaluation, reused by the next pass (its Jacobian and hh)
    for _ in range(ZOH_PASSES if held or refined else 0):
        ev = memo.get("evaluation")
        known = ev.hh if ev is not None and held and ev.hh.shape[0] == kept and np.array_equal(ev.p, p) else None
        lines = receptance(model, parts, p if held else None, model_h=known)
        passes += held
        if refined:
            new, std, info = refine(model, lines, p, iterations=2 if passes < ZOH_PASSES else 30, memo=memo)
            est.details |= info
        else:
            new = p.copy()
            new[mask] = solve_lines(model, lines, weighting, compensate, rcond=rcond, start=p, reweightings=0,
                                    errors=False).values
        moved = np.max(np.abs(new[mask] - p[mask]) / np.maximum(std, 1e-300))
        p = new
        if moved < 0.01 or not held:
            break
    if refined:
        est = Estimate(p[mask], std, est.condition, float(np.sqrt(2 * est.details["output_error_cost"])),
                       est.n_equations, est.details | {
                           "estimator": "output error (Gauss-Newton) from the bias-compensated linear estimate",
                           "std_errors": f"sandwich over clusters of {CLUSTER} consecutive lines"})
    elif passes:
        est = solve_lines(model, receptance(model, parts, p), weighting, compensate, rcond=rcond, start=p,
                          reweightings=0)
    est.details |= {"frequency_domain": {
        "frf": "H1" + (" (declared force noise removed)" if any(p.force_noise for p in parts) else ""),
        "analyses": sorted({p.analysis for p in parts}), "lines": kept,
        "lines_total": sum(p.lines_total for p in parts), "groups": len(parts),
        "min_coherence": MIN_COHERENCE, "zoh_corrections": passes,
        "variance": "residual spectrum (coherence and averages)"}}
    return est
