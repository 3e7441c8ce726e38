"""Chapter 3: element parameters by time-domain least squares (eqs. 3.1-3.15).

At a sample time ``t_k`` the equations of motion ``M a + C v + K u = F`` are
linear in the element parameters: ``A(t_k) p = F(t_k)`` with columns
``dM_j a(t_k)``, ``dC_j v(t_k)``, ``dK_j u(t_k)``. Two estimators:

``bias-compensated`` (default)
    every sample of every trace; the noise of every channel (forces,
    accelerations, velocities, displacements) inside the regression is
    compensated, noise-weighted, with sandwich standard errors
    (:mod:`identifier.least_squares.bias_compensated`). Noise levels are the ones the
    channels declare; channels that declare none get theirs estimated from
    the data (:mod:`identifier.least_squares.noise_levels`; ``details["noise"]`` says so).
``ols``
    the dissertation's set-up: plain or noise-weighted least squares at
    ``t_0 + interval k``, k = 1..samples (:mod:`identifier.least_squares.ols`); biased
    when the accelerations are noisy (errors in variables).

``samples`` (with ``interval``) picks sample times for either estimator;
None means every sample. Displacements and velocities are the measured
channels when every DOF has one (``integration="auto"``), else integrated
from the accelerations (:mod:`identifier.least_squares.integrate`; the structure must
start at rest); the integrated ones carry the acceleration noise as a
random walk, ``sigma_v = sigma_a sqrt(dt t)``, ``sigma_u = sigma_a sqrt(dt t^3/3)``
(correlation between sample times neglected).

Any one response quantity per DOF (displacement only, velocity only, or a
mix; issue 22): when some DOF lacks an acceleration channel, the default
estimator (bias-compensated, every sample, ``integration="auto"``) filters
every term of the equations by one stable low-pass ``L = s^e (lam / (s +
lam))^r``, ``M (L a) + C (L v) + K (L u) = L f``, each slot a proper filter
of whichever quantity the DOF has (:mod:`identifier.least_squares.prefilter`,
:mod:`identifier.least_squares.quantities`: ``lam`` twice the records'
band; their discretisation error, computed on a simulation of the first
estimate, removed by :mod:`identifier.least_squares.defect`); the filtered
noise is coloured and correlated between slots, which
the bias compensation and the first-order standard errors of
:mod:`identifier.least_squares.colored` take into account. Chosen over
repeated integration (``M u + C int u + K intint u = intint f``; its
random-walk noise left the chapter 3 beam's displacement-only error at
0.024, the prefilter 0.002) and over spectra (4 s records resolve
1.6 rad/s, above most of that beam's response). Constant sensor offsets
(a displacement probe's zero, a velocity sensor's or accelerometer's DC
bias) are estimated with the parameters, one per response channel and
record, when a chi-square test on the at-rest estimate finds them
(:mod:`identifier.least_squares.offsets`: what the filter makes of a
constant, how it is taken out, when it is confounded with the motion;
``details["offsets"]``). Needs the
structure at rest at the first sample, ``lam dt`` small (the band well
below Nyquist; else :class:`IdentificationError`), and a response channel
on every DOF of the model (else the unmeasured-DOF path below; with
``domain="time"`` an error naming the DOF and the channels present). The
acceleration path (every DOF with an acceleration channel) assumes
zero-mean noise: no offsets there.

Domain (option ``domain``, issue 22). ``time``: the estimators above.
``frequency``: the equations of motion on FRFs, ``(K - omega^2 M + i omega
C) H = e_f`` at the measured lines, from any one response quantity per DOF
(velocity and acceleration FRFs divided by ``(i omega)^k``: exact, no
differentiation), H1 by :mod:`identifier.frf` per group of traces with one
force location (Welch for random tests, a record per average for impulses,
a per-line fit per stepped-sine test), the force noise's bias of H1 removed
when declared, the zero-order hold of the sampled data corrected at the
latest estimate; the bias-compensated linear estimate, then the output-error
fit that the whitened equation error converges to
(:mod:`identifier.least_squares.frequency`, :mod:`.frequency_output`,
:mod:`.frequency_data`; ``details["frequency_domain"]``). ``samples``,
``interval`` and ``integration`` do not apply there; ``estimator="ols"``
gives the plain (biased) linear estimate. ``auto`` (default): time when
every DOF has an acceleration channel, or when the prefiltered path accepts
the records (corner ``lam = 2 x band``, ``lam dt <= 0.5``: the band far below
Nyquist, as :mod:`identifier.least_squares.quantities` decides); else
frequency. That band is a median frequency: a free-free structure's
rigid-body drift pulls it to nearly zero while its flexible response
reaches Nyquist (``ch3-damped-beam``'s random test at dt = 0.02 s from
velocities, benchmarks/least_squares_frequency.py: ``auto`` takes the time
domain, whose prefiltered path then fails, normalized RMS error 74 from
three 655 s records; ``domain=frequency`` gives 0.008 from each one). ``details["domain"]`` says which and why. The
frequency domain needs excitation over a band (random, impulse, several
stepped-sine lines: a single harmonic line leaves the parameters
unidentifiable) and a linear, stationary response: FRFs of lightly damped
or undamped structures leak, which biases damping up and, for the undamped
chapter 3 beam, every parameter (benchmarks/least_squares_frequency.py).

Unmeasured DOF (a DOF of the model without any response channel, in
``auto`` or ``frequency``): the output error at the measured DOF on FRFs,
the unmeasured DOF condensed (eliminated per line for given parameters),
started from the topology alone; parameters the measured set does not
determine are reported with value NaN and no standard error
(:mod:`identifier.least_squares.unmeasured`, :mod:`.unmeasured_data`;
``details["unmeasured_dofs"]``, ``details["undetermined"]``). A refusal of
that path names the DOF without a sensor, the channels present and why.

Rank deficiency (e.g. only rigid-body motion excited, eq. 3.15 discussion)
raises :class:`IdentificationError` naming the parameters that are not
identifiable.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.special import chdtrc

from structbench.models import ModelError, Structure

from .bias_compensated import solve_compensated
from .colored import solve_colored
from .defect import corrected
from ..errors import IdentificationError
from .estimate import Estimate
from .integrate import METHODS, integrate
from .noise_levels import estimate_sigma
from . import offsets, whitened
from .regression import layout
from .ols import WEIGHTINGS, solve
from ..io.results import Identification, ParameterEstimate
from ..io.traces import Channel, Trace
from . import frequency_data
from .quantities import MAX_LAM_DT, corner, missing_message, prefiltered_run, present_channels, response_channels
from . import unmeasured_data
from .unmeasured_data import unmeasured_dofs

RCOND = 1e-7
INTEGRATIONS = ("auto",) + METHODS
ESTIMATORS = ("bias-compensated", "ols")
DOMAINS = ("auto", "time", "frequency")
DEFECT_PASSES = 4  # defect corrections at most (each from the latest estimate; stops when it moves < 0.01 s.e.)
__all__ = ["DOMAINS", "ESTIMATORS", "INTEGRATIONS", "WEIGHTINGS", "Estimate", "Motion", "identify", "solve",
           "choose_domain", "solve_compensated", "trace_motion"]


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


def _sigma(trace: Trace, channel: Channel, estimated: list[str]) -> np.ndarray:
    """The channel's noise standard deviation per sample (n_t,): declared, or
    estimated from its data (its name is then added to ``estimated``)."""
    if channel.noise_declared:
        return channel.sigma()
    estimated.append(f"{trace.path.name}:{channel.name}")
    return np.full(channel.data.shape, estimate_sigma(channel.data))


def _full(trace: Trace, quantity: str, model: Structure,
          estimated: list[str]) -> tuple[np.ndarray, np.ndarray] | None:
    """A quantity on every model DOF, (n_t, n) with its sigma, or None if any DOF lacks it."""
    channels = trace.select(quantity)
    cols = _dof_columns(trace, channels, model)
    if set(cols.tolist()) != set(range(model.n_dof)):
        return None
    data, sigma = np.zeros((trace.time.size, model.n_dof)), np.zeros((trace.time.size, model.n_dof))
    for c, j in zip(channels, cols):
        data[:, j], sigma[:, j] = c.data, _sigma(trace, c, estimated)
    return data, sigma


def _every_dof_has(trace: Trace, quantity: str, model: Structure) -> bool:
    return {c.dof for c in trace.select(quantity)} >= set(model.dofs)


def trace_motion(trace: Trace, model: Structure, samples: int | None, interval: float,
                 integration: str = "auto", estimated: list[str] | None = None) -> tuple[Motion, str]:
    """The motion of one trace at its sample times (``samples`` None: every
    sample), and how u, v were obtained; channels whose noise level had to be
    estimated are appended to ``estimated``."""
    estimated = [] if estimated is None else estimated
    if integration not in INTEGRATIONS:
        raise IdentificationError(f"unknown integration {integration!r}; known: {', '.join(INTEGRATIONS)}",
                                  field="integration")
    acc = _full(trace, "acceleration", model, estimated)
    if acc is None:
        response_channels(trace, model)  # raises when a DOF has no response channel at all
        have = {c.dof for c in trace.select("acceleration")}
        missing = [f"acceleration_{n}_{d}" for n, d in model.dofs if (n, d) not in have]
        raise IdentificationError(f"{trace.path.name}: least squares needs the acceleration of every DOF "
                                  "unless it runs bias-compensated over every sample with integration 'auto'; "
                                  f"missing channel(s) {', '.join(missing)}; present: "
                                  f"{', '.join(sorted(trace.channels))}", field="channels")
    forces = trace.require_forces()
    fcols = _dof_columns(trace, forces, model)
    force, fsigma = np.zeros_like(acc[0]), np.zeros_like(acc[0])
    for c, j in zip(forces, fcols):
        force[:, j] += c.data
        fsigma[:, j] = np.hypot(fsigma[:, j], _sigma(trace, c, estimated))
    measured = {q: _full(trace, q, model, estimated) for q in ("displacement", "velocity")}
    how = "measured"
    if integration != "auto" or any(m is None for m in measured.values()):
        how = "zoh-simpson" if integration == "auto" else integration
        v, u = integrate(acc[0], trace.dt, how, force[:, np.unique(fcols)], trace.step)
        t = (trace.time - trace.time[0])[:, None]
        measured = {"displacement": (u, acc[1] * np.sqrt(trace.dt * t**3 / 3)),
                    "velocity": (v, acc[1] * np.sqrt(trace.dt * t))}
    idx = slice(None) if samples is None else sample_indices(trace.time, samples, interval, trace.path.name)
    sigma = {"acceleration": acc[1][idx], "force": fsigma[idx],
             "displacement": measured["displacement"][1][idx], "velocity": measured["velocity"][1][idx]}
    return Motion(trace.time[idx], measured["displacement"][0][idx], measured["velocity"][0][idx],
                  acc[0][idx], force[idx], sigma), how


def choose_domain(traces: Sequence[Trace], model: Structure, domain: str = "auto") -> tuple[str, str]:
    """``(domain, why)``: ``domain`` itself unless ``"auto"`` (module docstring, "Domain")."""
    if domain not in DOMAINS:
        raise IdentificationError(f"unknown domain {domain!r}; known: {', '.join(DOMAINS)}", field="domain")
    unmeasured = unmeasured_dofs(traces, model)
    if unmeasured:
        gaps = [(t, missing_message(t, model)) for t in traces]
        trace, gap = next((t, g) for t, g in gaps if g)
        if domain == "time" or not any(present_channels(t, model) for t in traces):
            raise IdentificationError(f"{trace.path.name}: least squares in the time domain needs one of "
                                      f"displacement/velocity/acceleration on every DOF of the model; {gap}"
                                      + ("; domain=auto or frequency takes the unmeasured-DOF path"
                                         if domain == "time" else ""), field="channels")
        return "frequency", (f"{len(unmeasured)} unmeasured DOF ({', '.join(map(str, unmeasured[:4]))}"
                             f"{', ...' if len(unmeasured) > 4 else ''}): output error at the measured DOF on FRFs")
    if domain != "auto":
        return domain, "asked for"
    if all(_every_dof_has(t, "acceleration", model) for t in traces):
        return "time", "every DOF has an acceleration channel"
    response_channels(traces[0], model)  # raises naming the DOF without any response channel
    lam = corner(traces, model)
    worst = max(lam * t.dt for t in traces)
    if worst <= MAX_LAM_DT:
        return "time", f"band far below Nyquist (prefilter corner x dt = {worst:.3g} <= {MAX_LAM_DT})"
    return "frequency", (f"band near Nyquist (prefilter corner x dt = {worst:.3g} > {MAX_LAM_DT}): "
                         "equations of motion on FRFs")


def identify(traces: Sequence[Trace], model: Structure, estimator: str = "bias-compensated",
             samples: int | None = None, interval: float = 0.5, integration: str = "auto",
             weighting: str = "noise", rcond: float = RCOND, domain: str = "auto") -> Identification:
    """Least-squares identification from the traces of one repetition.

    Every trace contributes its equations at every sample (``samples`` None)
    or at ``t_0 + interval k``, k = 1..samples; ``estimator`` as in the module
    docstring; ``domain`` ``time``, ``frequency`` or ``auto`` (module docstring, "Domain").
    """
    if not isinstance(model, Structure):
        raise IdentificationError(f"least squares needs a finite-element model; {model.name} is modal",
                                  field="model")
    if estimator not in ESTIMATORS:
        raise IdentificationError(f"unknown estimator {estimator!r}; known: {', '.join(ESTIMATORS)}",
                                  field="estimator")
    if weighting not in WEIGHTINGS:
        raise IdentificationError(f"unknown weighting {weighting!r}; known: {', '.join(WEIGHTINGS)}",
                                  field="weighting")
    estimated: list[str] = []
    chosen_domain, why = choose_domain(traces, model, domain)
    if chosen_domain == "frequency" and (samples is not None or integration != "auto"):
        raise IdentificationError("samples, interval and integration apply to the time domain; the frequency "
                                  f"domain ({why}) uses every FRF line", field="domain")
    undetermined = np.zeros(int(model.kind_mask().sum()), dtype=bool)
    if chosen_domain == "frequency" and unmeasured_dofs(traces, model):
        if estimator != "bias-compensated" or weighting != "noise":
            raise IdentificationError("with unmeasured DOF least squares is the output error at the measured DOF "
                                      "(noise-weighted): estimator and weighting take their defaults",
                                      field="estimator")
        try:
            est, undetermined = unmeasured_data.solve_traces(traces, model, lambda t, c: _sigma(t, c, estimated))
        except (IdentificationError, np.linalg.LinAlgError) as err:  # numpy >= 2.4 raises on NaN in solve
            trace = next(t for t in traces if missing_message(t, model))
            why = err if isinstance(err, IdentificationError) else f"the fit failed numerically ({err})"
            raise IdentificationError(f"{trace.path.name}: {missing_message(trace, model)}; least squares with "
                                      f"unmeasured DOF (frequency domain, output error at the measured DOF) "
                                      f"refused: {why}", field=getattr(err, "field", "channels")) from None
        motion, how, extra = None, ["frequency-domain, unmeasured DOF condensed"], {}
    elif chosen_domain == "frequency":
        est = frequency_data.solve_traces(traces, model, lambda t, c: _sigma(t, c, estimated), weighting, rcond,
                                          compensate=estimator == "bias-compensated")
        motion, how, extra = None, ["frequency-domain"], {}
    elif not all(_every_dof_has(t, "acceleration", model) for t in traces) and (
            estimator == "bias-compensated" and samples is None and integration == "auto"):
        sigma_of = (lambda t, c: _sigma(t, c, estimated))
        records, prefilter = prefiltered_run(traces, model, None, sigma_of)
        est = solve_colored(model, records, weighting, rcond)
        at_rest = model.values.copy()
        at_rest[model.kind_mask()] = est.values
        chi2, dof = offsets.statistic(records, whitened.equation_matrix(layout(model), np.append(at_rest, -1.0)))
        prefilter["offsets_test"] = {"chi2": chi2, "dof": dof}
        if dof and chdtrc(dof, chi2) < offsets.SIGNIFICANCE:
            records = [offsets.projected(r) for r in records]
            est = solve_colored(model, records, weighting, rcond)
        passes = 0
        for _ in range(DEFECT_PASSES):
            fixed = corrected(traces, model, records, prefilter["lambda"], est.values, sigma_of)
            if fixed is None:
                break
            before, passes = est.values, passes + 1
            est = solve_colored(model, fixed, weighting, rcond, est)
            if np.max(np.abs(est.values - before) / np.maximum(est.std_errors, 1e-300)) < 0.01:
                break
        prefilter["defect_corrections"] = passes
        motion = Motion.stack([r.motion for r in records])
        how, extra = ["prefiltered"], {"prefilter": prefilter}
        if "offset_values" in est.details:
            names = [[c.name for c in response_channels(t, model)] for t in traces]
            values = est.details.pop("offset_values").reshape(len(traces), model.n_dof)
            extra["offsets"] = {t.path.name: dict(zip(chans, v.tolist())) for t, chans, v in zip(traces, names, values)}
            prefilter["offset_iterations"] = est.details.pop("offset_iterations")
    else:
        parts = [trace_motion(t, model, samples, interval, integration, estimated) for t in traces]
        motion = Motion.stack([m for m, _ in parts])
        est = (solve if estimator == "ols" else solve_compensated)(model, motion, weighting, rcond)
        how = sorted({h for _, h in parts})
        extra = ({"std_errors": est.details.get("std_errors", "") + "; too small here: integrated displacements "
                  "and velocities carry errors correlated in time"} if any(h != "measured" for h in how)
                 and np.any(motion.sigma["acceleration"] > 0) else {})
    mask = model.kind_mask()
    chosen = [p for p, u in zip(model.parameters, mask) if u]
    p = model.values.copy()
    p[mask] = est.values
    try:
        omega = [] if undetermined.any() else model.with_values(p).modes(min(10, model.n_dof)).omega.tolist()
    except ModelError:  # a non-physical (negative) estimate under heavy noise
        omega = []
    times = ({} if motion is None else {"sample_times": motion.times.tolist()} if samples is not None
             else {"samples": int(motion.times.size), "sample_span": [float(motion.times.min()),
                                                                     float(motion.times.max())]})
    return Identification(
        method="least-squares", structure=model.name, repetition=traces[0].repetition,
        tests=[t.test for t in traces],
        parameters=[ParameterEstimate(q.label, q.kind, q.unit, float(v), None if u else float(s))
                    for q, v, s, u in zip(chosen, est.values, est.std_errors, undetermined)],
        omega=omega,
        details=times | est.details | {
            "n_equations": est.n_equations, "condition": est.condition, "residual_rms": est.residual_rms,
            "motion": how, "domain": {"chosen": chosen_domain, "why": why}, **extra,
            "noise": ("estimated from the data (second differences) for " + ", ".join(estimated[:8])
                      + (f" and {len(estimated) - 8} more" if len(estimated) > 8 else "")
                      if estimated else "declared by the traces")})
