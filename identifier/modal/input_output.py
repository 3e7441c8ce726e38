"""Input-output modal identification: the measured force scales the shapes.

The output-only SSI (:mod:`identifier.modal`) finds the poles; when the
force is measured this step fits the H1 FRFs of the SSI's sensors per that
force (:func:`identifier.frf.estimate`, coherence and random errors) with
those poles as the start of a pole-residue fit (:mod:`.residues`: the
exact zero-order-hold terms, residues linear, poles refined by variable
projection, each line weighted by ``1 / (|H| eps)``, ``eps`` its random
error from the coherence). The Welch estimate is the FRF smoothed by the
segments' spectral window; the fitted model is smoothed alike, to second
order (:func:`.residues.window_moment`: without it a Hann segment of 8
lines per half-power bandwidth widens a resonance, zeta +0.4 %, twice its
standard error on a 120 s random test of a 1-DOF oscillator). The refined
poles get standard errors (``omega_std``, ``damping_std``) from the
Gauss-Newton covariance with the residues free, scaled by the misfit
(Welch lines of 50 % overlapping Hann segments treated as independent;
1-DOF oscillators under white force, 120 s, 2-5 % noise: RMS z-scores
0.8-1.05). With the driving-point residue (a response at the
force's node and direction)

    psi_r,j^2 = 2 i omega_d,r R_r,jj,   psi_r,i = 2 i omega_d,r R_r,ij / psi_r,j,
    m_r = 1 / max_i |psi_r,i|^2   (kg, the modal mass of the shape scaled to max abs 1),

the unit-modal-mass shapes ``psi`` (``psi^T M psi = 1``) at the sensors,
in displacement per sqrt(kg) whatever each sensor measures.

``input`` option: ``off`` never; ``on`` always (an error when no trace of
the run has a force, measured or else commanded); ``auto`` when every trace
of the run has a measured force channel (``/channels/force_*``) at one DOF
and the test is not ambient or a free response (excitation kind
``initial``, or a random force drawn anew per repetition). Results go to
``details["input_output"]`` (docs/results-format.md): the run's SSI
``omega``, ``damping`` and shapes are left as they are; ``poles`` (as
``on``) reports the FRF fit's poles and their standard errors as the run's
``omega`` and ``damping`` where it refined them (``headline`` per mode; the
SSI's values in ``details["ssi"]``): with a measured force they are the
more precise (docs/modal-method.md).

Segments: the Welch segment is chosen so the narrowest SSI mode's
half-power bandwidth ``2 zeta omega`` spans ``LINES_PER_BANDWIDTH`` lines
(leakage bias of a Hann segment is then under about 1 %), within one eighth
of the shortest record; a shorter one says so in ``warnings``.

When it fails or says no: without a driving point no scale
(``shape_scaling`` says why; the residues are still given); a mode the
force does not excite (a node of the force's DOF) has a tiny, phase-less
driving-point residue and no scale; a mode whose resonant peak
``|R| / (zeta omega)`` is under ``SHARE_MIN`` of the measured FRF at its
frequency on every sensor (a noise pole of the SSI, kept when the jackknife
is off) gets no scale either, and a pole the refinement pushes onto a bound
keeps the SSI's; modes the SSI did not find that lie in
the fitted band bias their neighbours' residues (the band is cut to
``BAND`` times the SSI's lowest and highest modes); force noise biases H1,
and so the residues, low by ``1 / (1 + N_ff / S_ff)`` (the masses high);
impulse tests whose response has not decayed leak. Several force DOFs in
one run (a MIMO test) are not combined: the first trace's force is used
and the traces with another are left out (``warnings``).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.signal import get_window

from ..errors import IdentificationError
from ..frf import estimate
from ..io.results import Identification
from ..io.traces import Channel, Trace
from . import residues as rf

INPUTS = ("auto", "off", "on", "poles")
LINES_PER_BANDWIDTH = 8  # FRF lines over the narrowest mode's half-power bandwidth
BAND = (0.5, 1.5)  # fitted band: these multiples of the lowest and highest SSI frequency
MIN_SEGMENT = 256  # samples
SHARE_MIN = 0.1  # least resonant peak over the measured FRF of a mode given a scale


def check(option: str, traces: Sequence[Trace] = ()) -> None:
    """An :class:`IdentificationError` for an unknown ``input`` option, or
    for ``on`` when no trace has a force (before any work is done)."""
    if option not in INPUTS:
        raise IdentificationError(f"unknown input {option!r}; known: {', '.join(INPUTS)}", field="input")
    if option in ("on", "poles") and traces and not any(t.forces() for t in traces):
        raise IdentificationError(f"{traces[0].path.name}: input={option} needs a force channel or an "
                                  "/excitation force; found none", field="input")


def _ambient(trace: Trace) -> bool:
    kind = str(trace.excitation_attrs.get("kind", ""))
    spec = trace.excitation_attrs.get("spec", [])
    drawn = any(isinstance(s, dict) and s.get("realisation") == "per-repetition" for s in spec) \
        if isinstance(spec, list) else False
    return kind == "initial" or drawn


def decide(traces: Sequence[Trace], option: str) -> tuple[bool, str]:
    """Whether to use the force, and why (or why not)."""
    check(option)
    if option == "off":
        return False, "input=off"
    measured = [t.select("force") for t in traces]
    if option == "auto":
        if not all(measured):
            return False, "no measured force channel in every trace (output-only)"
        if any(_ambient(t) for t in traces):
            return False, "ambient or free-response test (output-only)"
        return True, "measured force"
    check(option, traces)
    return True, "measured force" if all(measured) else "commanded force (/excitation): no load cell"


def _segment(traces: Sequence[Trace], omega: np.ndarray, zeta: np.ndarray, dt: float) -> tuple[float, str]:
    """Welch segment (s) resolving the narrowest mode, and a warning or ``""``."""
    shortest = min(t.time.size for t in traces)
    narrow = float(np.min(2.0 * np.maximum(np.abs(zeta), 1e-4) * omega))  # rad/s
    want = int(2 ** np.ceil(np.log2(max(MIN_SEGMENT, LINES_PER_BANDWIDTH * 2 * np.pi / (narrow * dt)))))
    most = int(2 ** np.floor(np.log2(max(8, shortest // 8))))
    if want <= most:
        return want * dt, ""
    return most * dt, (f"Welch segments of {most * dt:.4g} s resolve the narrowest mode's bandwidth "
                       f"{narrow:.3g} rad/s by {most * dt * narrow / (2 * np.pi):.1f} lines (want "
                       f"{LINES_PER_BANDWIDTH}): residues biased low by leakage; record longer")


def analyse(traces: Sequence[Trace], channels: list[Channel], omega: np.ndarray, zeta: np.ndarray,
            why: str) -> dict[str, Any]:
    """``details["input_output"]`` of one run: FRFs of ``channels`` per the
    force, the pole-residue fit from the SSI's ``omega`` (rad/s) and
    ``zeta``, and the unit-modal-mass scaling."""
    force = (traces[0].select("force") or traces[0].forces())[0]
    warnings = []
    same = [t for t in traces if any(c.dof == force.dof for c in (t.select("force") or t.forces()))]
    if len(same) < len(traces):
        warnings.append(f"{len(traces) - len(same)} trace(s) without a force at {force.name}: left out")
    out: dict[str, Any] = {"input": why, "force": force.name, "algorithm": "pole-residue fit of H1 FRFs",
                           "shape_scaling": "none", "warnings": warnings}
    if omega.size == 0:
        out["shape_scaling"] = "none: no modes to scale"
        return out
    dt = same[0].dt
    analysis = "welch" if "random" in str(same[0].excitation_attrs.get("kind", "random")) or \
        not same[0].excitation_attrs.get("kind") else "auto"
    segment, note = _segment(same, omega, zeta, dt) if analysis == "welch" else (None, "")
    warnings += [note] if note else []
    frf = estimate(same, "H1", force=force.name, responses=[c.name for c in channels], analysis=analysis,
                   segment=segment)
    warnings += frf.warnings
    w = 2 * np.pi * frf.frequency
    band = (w >= BAND[0] * omega.min()) & (w <= min(BAND[1] * omega.max(), 0.9 * np.pi / dt)) & (w > 0)
    H = frf.frf[:, band]
    eps = np.where(np.isfinite(frf.random_error[:, band]), np.maximum(frf.random_error[:, band], rf.EPS_FLOOR),
                   rf.EPS_FLOOR)
    sigma = np.abs(H) * eps
    sigma = np.where(np.isfinite(H) & (sigma > 0), sigma, np.inf)
    if int(np.isfinite(sigma).sum(axis=1).min()) < 2 * omega.size + 3:
        out["shape_scaling"] = "none: too few FRF lines in the modes' band"
        return out
    orders = np.array([rf.ORDERS[c.quantity] for c in channels])
    mu2 = rf.window_moment(get_window(frf.window, frf.segment, fftbins=True), dt) if frf.analysis == "welch" \
        else 0.0  # the Welch estimate's smoothing of the resonances, fitted with them
    result, moved = rf.refine(w[band], H, sigma, dt, rf.poles_of(omega, zeta), orders, mu2=mu2)
    if not moved.all():
        warnings.append(f"{int((~moved).sum())} pole(s) not refined by the FRF fit (solver failed or a "
                        "bound reached: a mode the FRFs do not carry): their SSI poles are used")
    lam = result.poles
    out.update({"omega": np.abs(lam).tolist(), "damping": (-lam.real / np.abs(lam)).tolist(),
                "omega_std": result.omega_std.tolist(), "damping_std": result.zeta_std.tolist(),
                "poles_refined": moved.tolist(), "segment_s": frf.segment * dt, "analysis": frf.analysis,
                "band": [float(w[band].min()), float(w[band].max())], "lines": int(band.sum()),
                "misfit": result.misfit.tolist(),
                "residues": [[[float(v.real), float(v.imag)] for v in col] for col in result.residues.T]})
    drive = [i for i, c in enumerate(channels) if c.dof == force.dof]
    if not drive:
        out["shape_scaling"] = (f"none: no response at the force's DOF ({force.node}, {force.direction}); "
                                "unit-modal-mass scaling needs the driving point")
        out["modal_mass"] = [None] * omega.size
        return out
    scaled = rf.scale(result.residues, lam, drive[0])
    share = _shares(w[band], H, result.residues, lam, orders)
    out["share"] = share.tolist()
    for r in np.flatnonzero(share < SHARE_MIN):
        scaled.psi[:, r], scaled.modal_mass[r] = np.nan, np.nan
        scaled.reasons[r] = (f"its peak is {share[r]:.2g} of the measured FRF there (needs {SHARE_MIN:g}): "
                             "the FRFs do not carry this mode")
    out.update({"shape_scaling": "unit modal mass", "driving_point": channels[drive[0]].name,
                "modal_mass": [None if not np.isfinite(m) else float(m) for m in scaled.modal_mass],
                "mode_shapes_scaled": [[None if not np.isfinite(v) else float(v) for v in col]
                                       for col in rf.real_shapes(scaled.psi).T],
                "mode_shapes_scaled_complex": [[[float(v.real), float(v.imag)] for v in col]
                                               for col in scaled.psi.T],
                "unscaled": [r or None for r in scaled.reasons]})
    return out


def _shares(w: np.ndarray, H: np.ndarray, residues: np.ndarray, poles: np.ndarray, orders: np.ndarray) -> np.ndarray:
    """Per mode (k,) its resonant peak ``|lambda|^o |R| / (zeta omega)`` over
    the measured ``|H|`` at its frequency (nearest line), the largest over
    the channels: near 1 for a mode the FRFs carry, small for a noise pole."""
    omega = np.abs(poles)
    at = np.abs(w[:, None] - omega[None, :]).argmin(axis=0)  # (k,)
    peak = np.abs(residues) * omega[None, :] ** orders[:, None] / np.maximum(-poles.real, 1e-12)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = peak / np.abs(H[:, at])
    return np.nan_to_num(np.nanmax(np.where(np.isfinite(ratio), ratio, np.nan), axis=0), nan=0.0) \
        if np.isfinite(ratio).any() else np.zeros(omega.size)


def attach(traces: Sequence[Trace], channels: list[Channel], option: str, result: Identification) -> Identification:
    """``result`` with ``details["input_output"]`` when :func:`decide` says so
    (``{"input": "off: <why>"}`` otherwise; with ``auto`` also when the FRFs
    cannot be estimated or fitted, ``on`` raises then)."""
    use, why = decide(traces, option)
    if not use:
        result.details["input_output"] = {"input": f"off: {why}", "shape_scaling": "none"}
        return result
    try:
        found = analyse(traces, channels, np.asarray(result.omega, float), np.asarray(result.damping, float), why)
    except (IdentificationError, np.linalg.LinAlgError) as err:
        if option != "auto":
            raise
        found = {"input": f"off: the FRFs could not be fitted ({err})", "shape_scaling": "none"}
    result.details["input_output"] = found
    return headline(result) if option == "poles" else result


def headline(result: Identification) -> Identification:
    """``result`` whose ``omega``, ``damping``, ``eigenvalues`` and their standard errors are the FRF
    fit's for every pole it refined with finite errors; the SSI's values go to ``details["ssi"]``."""
    found = result.details["input_output"]
    keys = ("omega", "damping", "omega_std", "damping_std")
    result.details["ssi"] = {k: list(getattr(result, k)) for k in keys}
    if "omega" not in found:
        return result
    take = np.asarray(found["poles_refined"], bool) & np.isfinite(found["omega_std"]) \
        & np.isfinite(found["damping_std"])
    for k in keys:
        setattr(result, k, np.where(take, found[k], getattr(result, k)).tolist())
    result.eigenvalues = (np.asarray(result.omega)**2).tolist()
    found["headline"] = take.tolist()
    return result
