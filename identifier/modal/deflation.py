"""Spatial deflation of a stationary record: the weak modes the strong ones hide.

In a random response a weak, well-damped mode beside strong ones gets too
few stable SSI orders or no pole at all: the strong modes take the orders
and their covariance-noise poles crowd it out. Every reported mode ``r``
moves the channels only within ``span{Re psi_r, Im psi_r}`` of its complex
shape, so projecting the RMS-scaled records ``D^-1 y`` (``D`` the channels'
RMS) onto the orthogonal complement of those spans removes the reported
modes' responses in space and keeps the part of every other mode's shape
outside them. The projected records (``m - rank`` pseudo-channels, at least
``LEFT``) are identified by the same SSI, stabilisation, jackknife and
support tests (``run``: the caller's identification); a mode found there is
added when it is resolved from every reported mode ``r``:
``|omega - omega_r| > 2 pi / T + zeta omega + zeta_r omega_r`` (the
record's resolution plus both half-power half-widths) and outside the
reported mode's 95 % interval ``1.96 se_r``, and its temporal coherence
reaches the first pass's bar without that pass's exemption for modes stable
at most orders. Its frequency, damping and
their standard errors are the deflated pass's (the same jackknife and bias
terms). Its shape on the original channels is a least-squares fit: the
cross-covariances ``R_l = <y_s,k+l u_k>``, ``l = 1 .. L``, of the scaled
channels with the pseudo-channels' combination ``u`` along the mode's
projected shape are fitted as ``sum_j 2 Re(c_j mu_j^l)`` over the poles
``mu_j`` of every reported and deflated mode; ``D c`` of the added mode is
its shape (the projected shape alone lacks the part in the removed span;
the original SSI may have no pole there at all). Its shape standard errors
are NaN. Fails (adds nothing, says why in ``details["deflation"]``) with
fewer than ``LEFT`` channels left, a pass that refuses the projected
records or records that test as free decays.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from ..errors import IdentificationError
from ..io.results import Identification
from ..io.traces import Channel, Trace
from .refine import complex_poles
from .sensors import free_response
from .ssi.poles import mpc, real_shapes

LEFT = 2  # least pseudo-channels left after the projection
PER_MODE = ("orders", "support", "coherence", "refined", "band_fit")  # details with one entry per mode (and
# the lists of details["ml_refinement"])


def complement(shapes: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Orthonormal basis (m, m - rank) of the complement of the spans
    ``{Re, Im}`` of the scaled shapes ``shapes / scale`` ((m, k) complex,
    (m,) channel RMS); rank by the SVD at ``max(m, 2k) eps`` of the largest
    singular value."""
    scaled = shapes / scale[:, None]
    spans = np.column_stack([scaled.real, scaled.imag])
    U, s, _ = np.linalg.svd(spans, full_matrices=True)
    rank = int(np.sum(s > s.max(initial=0.0) * max(spans.shape) * np.finfo(float).eps)) if s.size else 0
    return U[:, rank:]


def pseudo_traces(traces: Sequence[Trace], projected: list[np.ndarray]) -> list[Trace]:
    """The projected records (m', n) as traces of displacement channels 1..m'
    (the pass needs one quantity; the scale is arbitrary), labelled as the
    originals (their excitation kind decides stationary or free)."""
    def one(t: Trace, z: np.ndarray) -> Trace:
        channels = {f"displacement_{i + 1}_w": Channel(f"displacement_{i + 1}_w", row, "displacement", "-", i + 1,
                                                       "w", np.full(3, np.nan), 0.0) for i, row in enumerate(z)}
        return Trace(t.path, t.time, t.dt, t.step, channels, {}, t.attrs, t.excitation_attrs, t.noise_attrs)
    return [one(t, z) for t, z in zip(traces, projected)]


def resolved(omega: float, zeta: float, reported: Identification, length: float) -> str:
    """Why the deflated mode (omega rad/s, zeta) is not resolved from a
    reported mode of a record of ``length`` s, or ``""`` when it is."""
    for w, z, se in zip(reported.omega, reported.damping, reported.omega_std):
        gap = abs(omega - w)
        if gap <= 2 * np.pi / length + zeta * omega + z * w:
            return f"within the resolution 2 pi / T plus half-widths of the reported mode at {w:.6g} rad/s"
        if gap <= 1.96 * se:
            return f"within the 95 % interval of the reported mode at {w:.6g} rad/s"
    return ""


def admitted(other: Identification, result: Identification, coherent: float, label: str) -> list[int]:
    """Indices of ``other``'s modes (a further pass over the record of
    ``result``) to add: temporal coherence at least ``coherent`` whatever
    their stable orders, and resolved from every reported mode
    (:func:`resolved`); the others and the pass's own rejections join
    ``result.details["rejected"]``, their reasons prefixed ``label``."""
    rejected = [dict(r, reason=f"{label}: {r['reason']}") for r in other.details["rejected"]]
    new = []
    for j, (w, z) in enumerate(zip(other.omega, other.damping)):
        if (c := other.details["coherence"][j]) < coherent:
            why = f"temporal coherence {c:.2f} (an added mode needs {coherent:g} whatever its stable orders)"
        else:
            why = resolved(w, z, result, result.details["record_s"])
        if why:
            rejected.append({"omega": w, "zeta": z, "reason": f"{label}: {why}"})
        else:
            new.append(j)
    result.details["rejected"] = sorted(result.details["rejected"] + rejected, key=lambda r: r["omega"])
    return new


def full_shape(records: list[np.ndarray], scale: np.ndarray, weights: np.ndarray, basis: np.ndarray,
               poles: np.ndarray, which: int, lags: int) -> np.ndarray:
    """Complex shape (m,) on the original channels of pole ``poles[which]``
    (``mu = exp(s dt)``, all (J,) poles of the reported and deflated modes):
    least squares of the cross-covariances of the scaled channels with
    ``u = weights^T basis^T y_s`` at lags 1..``lags`` on ``sum_j 2 Re(c_j mu_j^l)``;
    ``scale c_which``, max |.| = 1."""
    m = records[0].shape[0]
    R = np.zeros((lags, m))
    count = 0
    for y in records:
        ys = y / scale[:, None]
        u = weights @ (basis.T @ ys)
        n = ys.shape[1]
        size = 1 << int(np.ceil(np.log2(2 * n)))
        cross = np.fft.irfft(np.fft.rfft(ys, size) * np.conj(np.fft.rfft(u, size)), size)
        R += cross[:, 1:lags + 1].T
        count += n
    powers = poles[None, :] ** np.arange(1, lags + 1)[:, None]  # (L, J)
    coef = np.linalg.lstsq(np.column_stack([powers.real, powers.imag]), R / count, rcond=None)[0]
    J = poles.size
    shape = scale * (coef[which] - 1j * coef[J + which]) / 2
    return shape / np.abs(shape).max(initial=0.0) if np.abs(shape).max(initial=0.0) > 0 else shape


def extend(traces: Sequence[Trace], records: list[np.ndarray], dt: float, result: Identification,
           run: Callable[..., Identification], coherent: float) -> Identification:
    """``result`` of the stationary ``traces`` (their mean-removed sensor
    records (m, n_i) sampled at ``dt`` s) with the modes found in its spatially
    deflated records added (see the module docstring); ``details["deflation"]``
    says what the pass did, ``details["rejected"]`` gains what it saw and
    rejected. ``run(traces, **options)``: the identification to repeat on the
    pseudo-traces. ``coherent``: the least temporal coherence of an added
    mode, with no exemption for modes stable at most orders (one such pole,
    coherence 0.53, was tuning seed 1,003,514's only invented mode). Results
    without modes or scaled by a measured input are returned as they are."""
    if not result.omega or not result.details["input_output"]["input"].startswith("off"):
        return result
    scale = np.sqrt(sum(np.sum(y**2, axis=1) for y in records) / sum(y.shape[1] for y in records))
    scale = np.where(scale > 0, scale, 1.0)
    shapes = np.array(result.mode_shapes_complex) @ np.array([1.0, 1j])  # (k, m)
    basis = complement(shapes.T, scale)
    info: dict = {"channels_left": basis.shape[1], "added": [False] * len(result.omega)}
    result.details["deflation"] = info
    if basis.shape[1] < LEFT:
        info["skipped"] = f"{basis.shape[1]} channel(s) left after removing the reported modes (needs {LEFT})"
        return result
    projected = [basis.T @ (y / scale[:, None]) for y in records]
    if free_response(traces, projected)[0]:
        info["skipped"] = "the projected records test as free decays"
        return result
    try:
        deflated = run(pseudo_traces(traces, projected), quantity="displacement", input="off")
    except IdentificationError as err:
        info["skipped"] = f"the deflated pass refused the projected records: {err}"
        return result
    new = admitted(deflated, result, coherent, "deflated pass")
    if not new:
        return result
    omega = np.array(result.omega + deflated.omega)
    zeta = np.array(result.damping + deflated.damping)
    poles = np.exp(complex_poles(omega, zeta) * dt)
    pseudo = np.array(deflated.mode_shapes_complex) @ np.array([1.0, 1j])  # (k', m')
    k = len(result.omega)
    added = []
    for j in new:
        lags = int(np.clip(np.ceil(2.0 / (zeta[k + j] * omega[k + j] * dt)), 4 * poles.size,
                           min(y.shape[1] for y in records) // 4))
        added.append(full_shape(records, scale, real_shapes(pseudo[j][:, None])[:, 0], basis, poles, k + j, lags))
    return merged(result, deflated, new, np.array(added).T, "deflation")


def merged(result: Identification, deflated: Identification, new: list[int], shapes: np.ndarray, key: str,
           shapes_std: list | None = None) -> Identification:
    """``result`` with another pass's modes ``new`` (of ``deflated``) and their shapes (m, len(new))
    on the original channels added (shape standard errors ``shapes_std``, one list per added mode,
    else NaN), every per-mode list sorted by frequency; ``details[key]["added"]`` marks them."""
    order = np.argsort(result.omega + [deflated.omega[j] for j in new], kind="stable")

    def joined(mine: list, theirs: list) -> list:
        return [(list(mine) + list(theirs))[i] for i in order]

    def both(mine: list, theirs: list) -> list:
        return joined(mine, [theirs[j] for j in new])

    fields = {name: both(getattr(result, name), getattr(deflated, name))
              for name in ("omega", "damping", "omega_std", "damping_std", "eigenvalues")}
    fields["mode_shapes_complex"] = joined(result.mode_shapes_complex,
                                           [[[float(v.real), float(v.imag)] for v in col] for col in shapes.T])
    fields["mode_shapes"] = joined(result.mode_shapes, real_shapes(shapes).T.tolist())
    nan = [[float("nan")] * shapes.shape[0]] * len(new)
    fields["mode_shapes_std"] = joined(result.mode_shapes_std, shapes_std if shapes_std is not None else nan)
    fields["mpc"] = joined(result.mpc, mpc(shapes).tolist())
    details = result.details | {key: both(result.details[key], deflated.details[key]) for key in PER_MODE}
    ml, theirs = details["ml_refinement"], deflated.details["ml_refinement"]
    details["ml_refinement"] = ml | {key: both(value, theirs[key]) for key, value in ml.items()
                                     if isinstance(value, list) and len(value) == len(result.omega)}
    details[key] = details[key] | {"added": joined(details[key]["added"], [True] * len(new))}
    for other in {"deflation", "short_lags"} - {key}:  # a pass that ran before: its flags follow the modes
        if other in details and "added" in details[other]:
            details[other] = details[other] | {"added": joined(details[other]["added"], [False] * len(new))}
    return replace(result, **fields, details=details)
