"""Chapter 4: iterative frequency-domain perturbation with pseudo-parameters.

Starting from postulated parameters ``p0`` (the model's values), each cycle
computes the model's response ``w0 = Z0^-1 F`` at every excitation frequency
(``Z = K - omega^2 M + i omega C``, eq. 4.5) and solves the first-order
equations ``sum_j (dZ/dp_j w0) dp_j = -Z0 dw`` (eqs. 4.7-4.18) for the
corrections, ``dw`` being the measured minus the model's response. DOF without
a sensor make ``dw`` partly unknown: those entries are pseudo-parameters, one
set per frequency (eqs. 4.19-4.26). They are eliminated exactly: projecting
each frequency's equations on the orthogonal complement of ``Z0 I_r`` gives
the same ``dp`` as the stacked least squares of eq. 4.26. The corrected
parameters are the next cycle's postulated ones.

Frequency responses from the time traces (one harmonic test per frequency,
``/excitation`` attribute ``omega``): after the soft start (attribute
``window_start``, else the spec's ``ramp + settle``, else the first sample) the
sensor and force channels are fitted by least squares with the forced
component at ``omega`` plus free-vibration components, which never decay in
an undamped structure. Their frequencies are the structure's natural
frequencies as estimated from the records themselves
(:func:`identifier.perturbation.harmonic.free_frequencies`, seeded by the postulated
model; traces of the run without ``omega``, an impulse test say, contribute
their free response after the last force sample), falling back to the
current model's where the records show no clear peak; components the record cannot separate from ``omega`` (within half a
frequency bin) are left out. The force is held over each ``step`` (trace
format), so its fundamental acts as the fitted amplitude times
``(1 - exp(-i omega h)) / (i omega h)`` (its images at ``omega + 2 pi k / h``
are neglected: 4e-5 relative at 5 rad/s with h = 0.025 s on the cantilever,
1e-6 and less at 2 rad/s and below). The excitation frequency is the
commanded one (actuator frequency noise therefore acts as in the
dissertation); the force amplitude is the measured one (force channels, else
the commanded ``/excitation``).

``natural_frequencies=True`` (not in the dissertation) adds one equation per
natural frequency found in the records, the eigenvalue sensitivity
``dlambda_r = phi_r^T (dK - lambda_r dM) phi_r dp`` relative to the measured
``lambda_r``. With a single sensor (case 2: tip displacement, 0.5-6 rad/s) the
frequency-response equations alone are nearly singular at the true
parameters (condition about 2e7: Newton's method diverges from Table 4.1's
postulated values); the measured natural frequencies make it well posed.
A long soft start suppresses the free vibration that carries them (below the
sensor noise, at least): start the harmonic tests abruptly or add an impulse
test to the run.

Stops when ``max |dp / p| < tol`` (converged), when a parameter leaves
``(0, inf)`` or the response misfit exceeds ten times its smallest value
(diverged), or after ``max_iterations``. The result is the iterate with the
smallest misfit (``details["selected_iteration"]``; once converged, the last
iterates all but agree); ``history`` holds them all.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from structbench.models import ModelError, Structure

from ..errors import IdentificationError
from .harmonic import Record, amplitudes, free_frequencies, resolvable
from ..io.results import Identification, ParameterEstimate
from ..io.traces import Channel, Trace

RCOND = 1e-10
ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}


@dataclass
class HarmonicTest:
    """One excitation frequency: the windowed ``sensors`` record (n, s) in
    sensor units, ``force`` record (n, f), times (n,), the hold ``step`` (s)."""

    name: str
    omega: float
    t: np.ndarray
    sensors: np.ndarray
    force: np.ndarray
    force_index: np.ndarray
    step: float
    dt: float


def _window_start(trace: Trace) -> float:
    attrs = trace.excitation_attrs
    if "window_start" in attrs:
        return float(attrs["window_start"])
    spec = attrs.get("spec") or []
    items = spec if isinstance(spec, list) else [spec]
    return max((float(i.get("ramp", 0.0)) + float(i.get("settle", 0.0)) for i in items if isinstance(i, dict)),
               default=0.0)


def _index(model: Structure, channels: Sequence[Channel], trace: Trace) -> np.ndarray:
    try:
        return np.array([model.dof_index(c.node, c.direction) for c in channels], dtype=int)
    except ModelError as err:
        raise IdentificationError(f"{trace.path.name}: {err}; the model's DOF do not match the traces",
                                  field="model") from None


def _sensors(trace: Trace) -> tuple[str, list[Channel]]:
    for quantity in ORDER:
        found = trace.select(quantity)
        if found:
            return quantity, found
    raise IdentificationError(f"{trace.path.name}: no displacement, velocity or acceleration channel",
                              field="channels")


def _free_record(trace: Trace, quantity: str, dofs: list) -> Record:
    """A free response (no ``omega``): its sensor samples after the last force sample."""
    here = trace.select(quantity)
    if [c.dof for c in here] != dofs:
        raise IdentificationError(f"{trace.path.name}: its {quantity} sensors differ from the harmonic tests'",
                                  field="channels")
    forces = [c.data for c in trace.forces()]
    active = np.flatnonzero(np.any(np.abs(forces) > 0, axis=0)) if forces else np.array([], dtype=int)
    start = active[-1] + 1 if active.size else 0
    return Record(trace.time[start:], np.column_stack([c.data for c in here])[start:])


def harmonic_tests(traces: Sequence[Trace], model: Structure
                   ) -> tuple[list[HarmonicTest], str, list[Channel], np.ndarray, list[Record]]:
    """Windowed records of the harmonic tests, the sensor quantity, sensor
    channels (of the first harmonic test), their DOF indices, and the free
    responses (traces without ``omega``, used for natural frequencies only)."""
    harmonic = [t for t in traces if "omega" in t.excitation_attrs]
    if not harmonic:
        raise IdentificationError(f"no harmonic test (an /excitation attribute 'omega') among "
                                  f"{', '.join(t.path.name for t in traces)}", field="omega")
    quantity, sensors = _sensors(harmonic[0])
    index = _index(model, sensors, harmonic[0])
    tests = []
    for trace in harmonic:
        here = trace.select(quantity)
        if [c.dof for c in here] != [c.dof for c in sensors]:
            raise IdentificationError(f"{trace.path.name}: its {quantity} sensors differ from those of "
                                      f"{harmonic[0].path.name}", field="channels")
        forces = trace.require_forces()
        keep = trace.time >= _window_start(trace) - 1e-9 * trace.dt
        if keep.sum() < 16:
            raise IdentificationError(f"{trace.path.name}: fewer than 16 samples after the soft start",
                                      field="window_start")
        tests.append(HarmonicTest(trace.test, trace.omega, trace.time[keep],
                                  np.column_stack([c.data for c in here])[keep],
                                  np.column_stack([c.data for c in forces])[keep],
                                  _index(model, forces, trace), trace.step, trace.dt))
    free = [_free_record(t, quantity, [c.dof for c in sensors]) for t in traces
            if "omega" not in t.excitation_attrs]
    return tests, quantity, sensors, index, free


def responses(tests: Sequence[HarmonicTest], quantity: str, free: np.ndarray, n_dof: int
              ) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Per test: ``(omega, W, F)`` with ``W`` (s,) the complex displacement
    amplitudes at the sensors and ``F`` (n,) the effective complex force over
    the DOF (zero-order hold corrected)."""
    out = []
    for test in tests:
        span = test.t[-1] - test.t[0]
        others = resolvable(free, test.omega, span, test.dt)
        w = test.omega
        W = amplitudes(test.t, test.sensors, [w, *others])[0] / (1j * w) ** ORDER[quantity]
        hold = (1 - np.exp(-1j * w * test.step)) / (1j * w * test.step)
        F = np.zeros(n_dof, dtype=complex)
        np.add.at(F, test.force_index, amplitudes(test.t, test.force, [w, 0.0])[0] * hold)
        out.append((w, W, F))
    return out


def _kind_factors(model: Structure, omega: float) -> dict[str, complex]:
    alpha, beta = model.rayleigh
    return {"mass": -omega**2 + 1j * omega * alpha, "damping": 1j * omega, "stiffness": 1 + 1j * omega * beta}


def equations(model: Structure, data: Sequence[tuple[float, np.ndarray, np.ndarray]], index: np.ndarray,
              natural: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, float]:
    """Real least-squares system over the unknown parameters (pseudo-parameters
    eliminated), and the relative response misfit of the current model."""
    mask = model.kind_mask()
    chosen = [(d, p.kind) for d, p, u in zip(model.derivatives, model.parameters, mask) if u]
    M, C, K = (x.toarray() for x in (model.mass(), model.damping(), model.stiffness()))
    unknown = np.setdiff1d(np.arange(model.n_dof), index)
    rows, rhs, misfit, scale = [], [], 0.0, 0.0
    for omega, W, F in data:
        Z = K - omega**2 * M + 1j * omega * C
        w0 = la.solve(Z, F)
        factor = _kind_factors(model, omega)
        B = np.column_stack([factor[kind] * (d @ w0) for d, kind in chosen])
        d = -Z[:, index] @ (W - w0[index])
        if unknown.size:
            Q = la.qr(Z[:, unknown])[0]
            B, d = Q[:, unknown.size:].conj().T @ B, Q[:, unknown.size:].conj().T @ d
        norm = np.linalg.norm(F)
        rows += [B.real / norm, B.imag / norm]
        rhs += [d.real / norm, d.imag / norm]
        misfit += np.sum(np.abs(W - w0[index]) ** 2)
        scale += np.sum(np.abs(W) ** 2)
    if natural is not None and np.isfinite(natural).any():
        modes = la.eigh(K, M)
        for r in np.flatnonzero(np.isfinite(natural)):
            lam, phi = modes[0][r], modes[1][:, r]
            measured = natural[r] ** 2
            factor = {"mass": -lam, "damping": 0.0, "stiffness": 1.0}
            rows.append(np.array([[factor[kind] * (phi @ (d @ phi)) for d, kind in chosen]]) / measured)
            rhs.append(np.array([(measured - lam) / measured]))
    return np.vstack(rows), np.concatenate(rhs), float(np.sqrt(misfit / scale))


def _solve(B: np.ndarray, c: np.ndarray, labels: list[str]) -> np.ndarray:
    scale = np.linalg.norm(B, axis=0)
    scale[scale == 0] = 1.0
    U, s, Vt = la.svd(B / scale, full_matrices=False)
    bad = s < RCOND * s[0]
    if bad.any():
        weight = np.sqrt(np.sum(Vt[bad] ** 2, axis=0))
        names = [lab for lab, w in zip(labels, weight) if w > 1e-2]
        raise IdentificationError(f"rank deficient ({int(np.sum(~bad))} of {len(labels)}): parameter(s) "
                                  f"{', '.join(names)} are not identifiable from these frequency responses",
                                  field="parameters")
    return Vt.T @ ((U.T @ c) / s) / scale


def _count_check(model: Structure, n_tests: int, n_sensors: int, n_natural: int) -> None:
    mask = model.kind_mask()
    complex_data = "damping" in model.unknown or any(model.rayleigh)
    available = n_tests * n_sensors * (2 if complex_data else 1) + n_natural
    if available < int(mask.sum()):
        raise IdentificationError(f"fewer equations ({available}) than unknowns ({int(mask.sum())}): "
                                  f"{n_tests} frequencies x {n_sensors} sensors"
                                  + (f" + {n_natural} natural frequencies" if n_natural else ""),
                                  field="frequencies")


def _iterate(system: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, float]], p: np.ndarray,
             mask: np.ndarray, labels: list[str], max_iterations: int, tol: float
             ) -> tuple[str, str, list[np.ndarray], list[float]]:
    """Apply corrections ``B dp = c`` to the unknown entries (``mask``) of ``p``
    until converged, diverged or out of iterations; returns the status, a
    message, the unknowns per iteration (row 0: the start) and the misfits."""
    history, misfits = [p[mask].copy()], []
    status, message = "max-iterations", f"no convergence in {max_iterations} iterations"
    for _ in range(max_iterations):
        B, c, misfit = system(p)
        misfits.append(misfit)
        if misfit > 10 * min(misfits):
            status, message = "diverged", "the response misfit grew tenfold"
            break
        dp = _solve(B, c, labels)
        trial = p.copy()
        trial[mask] += dp
        if not np.all(np.isfinite(trial)) or np.any(trial[mask] <= 0):
            status, message = "diverged", "a correction made a parameter non-positive"
            break
        p = trial
        history.append(p[mask].copy())
        if np.max(np.abs(dp / p[mask])) < tol:
            status, message = "converged", ""
            break
    if len(misfits) < len(history):
        misfits.append(system(p)[2])
    return status, message, history, misfits


def identify(traces: Sequence[Trace], model: Structure, max_iterations: int = 20, tol: float = 1e-8,
             natural_frequencies: bool = False) -> Identification:
    """Perturbation identification from the harmonic tests of one repetition;
    ``model`` carries the postulated parameters."""
    if not isinstance(model, Structure):
        raise IdentificationError(f"the perturbation method needs a finite-element model; {model.name} is "
                                  "modal", field="model")
    if len({t.dt for t in traces}) > 1:
        raise IdentificationError("the traces of one run must share their sampling interval dt; got "
                                  f"{sorted({t.dt for t in traces})}", field="dt")
    tests, quantity, sensors, index, free = harmonic_tests(traces, model)
    records = [Record(t.t, t.sensors, t.omega) for t in tests] + free
    natural = free_frequencies(records, model.modes().omega, traces[0].dt)
    _count_check(model, len(tests), len(sensors), int(np.isfinite(natural).sum()) if natural_frequencies else 0)
    mask = model.kind_mask()

    def system(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        current = model.with_values(values)
        free = np.where(np.isfinite(natural), natural, current.modes().omega)
        return equations(current, responses(tests, quantity, free, model.n_dof), index,
                         natural if natural_frequencies else None)

    status, message, history, misfits = _iterate(system, model.values.copy(), mask,
                                                 [p.label for p, u in zip(model.parameters, mask) if u],
                                                 max_iterations, tol)
    best = int(np.argmin(misfits))
    initial = model.values[mask]
    chosen = [q for q, u in zip(model.parameters, mask) if u]
    return Identification(
        method="perturbation", structure=model.name, repetition=traces[0].repetition,
        tests=[t.name for t in tests], status=status, message=message,
        parameters=[ParameterEstimate(q.label, q.kind, q.unit, float(v), None, float(v0))
                    for q, v, v0 in zip(chosen, history[best], initial)],
        iterations=len(history) - 1, history=[h.tolist() for h in history], misfit_history=misfits,
        sensors=[c.name for c in sensors],
        details={"omegas": [t.omega for t in tests], "selected_iteration": best,
                 "natural_frequency_equations": natural_frequencies,
                 "natural_frequencies": [float(w) if np.isfinite(w) else None for w in natural]})
