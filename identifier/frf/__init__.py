"""Frequency response functions with coherence and confidence bands, from
the traces of random, impulse and stepped-sine (harmonic) tests.

Public call: :func:`estimate`. Reads only :class:`~structbench.identifier.io.traces.Trace`
objects; imports :mod:`structbench.identifier` and :mod:`structbench.models` only.

Model and conventions. One force ``f`` (N, or N m) and ``c`` responses
``x`` (m, m/s, m/s^2, rad, ...), sampled every ``dt`` s. With the time
dependence ``exp(+i omega t)`` and ``X = rfft(x)`` (numpy's sign), the FRF is
``H(omega) = X / F`` in response units per force unit (``m/N``, ``(m/s)/N``,
``(m/s^2)/N``); a displacement lagging the force has a negative phase, and
``H = (K - omega^2 M + i omega C)^-1`` for ``M x'' + C x' + K x = f``.
The estimate is that of the sampled data: when the force was held over each
sample (virtual tests, ``docs/trace-format.md``), it is the zero-order-hold
equivalent of the structure, ``C (e^(i omega dt) I - A_d)^-1 B_d + D``,
which for displacements is close to ``H(omega) sinc(omega dt / 2)
e^(-i omega dt / 2)`` well below the Nyquist frequency.

Averages ``k`` give spectra ``F_k``, ``X_k`` (:mod:`.spectra`):

- random tests (``analysis="welch"``): Welch segments of ``segment`` s
  (default: a power of two of samples, about 1/16 of all samples, at most
  one record), ``overlap`` (0.5), ``window`` (``hann``), segment means
  removed; the segments of every trace (repetition) are pooled;
- impulse tests (``"impulse"``): each trace is one average over its whole
  record, boxcar window, no detrending;
- stepped-sine and harmonic tests (``"harmonic"``): one line per test at its
  ``omega``, from the steady-state window (``window_start`` to the end),
  cut into up to ``blocks`` blocks of whole periods, each fitted by least
  squares (a per-line fit, not an FFT).

From ``S_ff = <|F|^2>``, ``S_xx = <|X|^2>``, ``S_fx = <conj(F) X>``:
``H1 = S_fx / S_ff``, ``H2 = S_xx / conj(S_fx)``, ``Hv`` (total least
squares), coherence ``gamma^2 = |S_fx|^2 / (S_ff S_xx)``, random error
``eps = sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d))`` (Bendat & Piersol) with
``n_d`` the effective number of independent averages (overlapping Welch
segments count less, :func:`.spectra.overlap_correlation`), bands
``|H| (1 +- z eps)`` and ``arg H +- z eps`` (:mod:`.estimators`).

Bias and failure modes:

- noise on the force biases H1 low and leaves H2 unbiased; noise on the
  response biases H2 high and leaves H1 unbiased; Hv lies between them;
- coherence is low (and the bands wide) at antiresonances, where the
  response drowns in its noise, and near lightly damped resonances when the
  segments are short (resolution bias and leakage: the response within a
  segment owes part of itself to force before it);
- an impulse response that has not decayed by the end of the record leaks
  (the estimate smears the peaks): a warning names the channel; so does a
  line with fewer than 2 averages (coherence is then 1 by construction and
  the bands are NaN);
- lines where the force has no power (outside a random force's band, DC
  after detrending) give NaN or meaningless values: read the coherence.

Errors (:class:`~structbench.identifier.errors.IdentificationError`, naming
the file and channel): no force channel or more than one without ``force=``,
an unknown response, traces with different ``dt``, channels or (impulse)
lengths, a record shorter than one segment, a harmonic trace without
``omega``, an initial-condition test without any force.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.signal import get_window

from ..errors import IdentificationError
from ..io.frf_files import ChannelInfo, Frf
from ..io.traces import Channel, Trace
from . import estimators
from .estimators import ESTIMATORS
from .spectra import Products, harmonic, welch

__all__ = ["ANALYSES", "ESTIMATORS", "Frf", "estimate"]
ANALYSES = ("auto", "welch", "impulse", "harmonic")
LEAKAGE_RATIO = 0.01  # an impulse response's last tenth above this share of its peak leaks


def _analysis(trace: Trace) -> str:
    kind = str(trace.excitation_attrs.get("kind", ""))
    if "random" in kind:
        return "welch"
    if "harmonic" in kind and "omega" in trace.excitation_attrs:
        return "harmonic"
    if "impulse" in kind:
        return "impulse"
    if kind == "initial":
        raise IdentificationError(f"{trace.path.name}: an initial-condition test has no force to refer "
                                  "an FRF to", field="excitation")
    return "welch"


def _force(trace: Trace, name: str | None) -> Channel:
    if name is not None:
        found = trace.channels.get(name) or trace.excitation.get(name)
        if found is None or found.quantity != "force":
            raise IdentificationError(f"{trace.path.name}: no force channel {name!r} "
                                      f"(forces: {', '.join(c.name for c in trace.forces()) or 'none'})",
                                      field="force")
        return found
    forces = trace.require_forces()
    if len(forces) > 1:
        raise IdentificationError(f"{trace.path.name}: {len(forces)} force channels "
                                  f"({', '.join(c.name for c in forces)}); name one with force=", field="force")
    return forces[0]


def _responses(trace: Trace, names: Sequence[str] | None) -> list[Channel]:
    if names is None:
        found = [c for c in trace.channels.values() if c.quantity != "force"]
        if not found:
            raise IdentificationError(f"{trace.path.name}: no response channel", field="channels")
        return found
    missing = [n for n in names if n not in trace.channels]
    if missing:
        raise IdentificationError(f"{trace.path.name}: no channel {missing[0]!r} "
                                  f"(channels: {', '.join(trace.channels)})", field="responses")
    return [trace.channels[n] for n in names]


def _info(c: Channel) -> ChannelInfo:
    return ChannelInfo(c.name, c.quantity, c.unit, c.node, c.direction)


def _check_alike(traces: Sequence[Trace], force: Channel, responses: list[Channel], force_name: str | None) -> None:
    first = traces[0]
    names = [r.name for r in responses]
    for t in traces[1:]:
        if not np.isclose(t.dt, first.dt, rtol=1e-9, atol=0.0):
            raise IdentificationError(f"{t.path.name}: dt {t.dt} s differs from {first.path.name}'s {first.dt} s",
                                      field="dt")
        if _force(t, force_name or force.name).name != force.name:
            raise IdentificationError(f"{t.path.name}: force channel differs from {first.path.name}'s "
                                      f"{force.name}", field="force")
        _responses(t, names)


def _leakage(trace: Trace, responses: list[Channel]) -> list[str]:
    data = np.stack([r.data for r in responses])
    tail = data[:, -max(1, data.shape[1] // 10):]
    peak = np.max(np.abs(data), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(np.mean(tail**2, axis=1)) / peak
    return [f"{trace.path.name}: {responses[i].name} has not decayed (RMS of the last tenth {ratio[i]:.1%} "
            "of its peak): leakage" for i in np.flatnonzero(ratio > LEAKAGE_RATIO)]


def _segment(traces: Sequence[Trace], segment: float | None, overlap: float) -> int:
    n = min(t.time.size for t in traces)
    if segment is None:
        total = sum(t.time.size for t in traces)
        return int(2 ** np.floor(np.log2(max(8, min(n, total / 16)))))
    length = int(round(segment / traces[0].dt))
    if length < 8 or length > n:
        raise IdentificationError(f"segment of {segment} s is {length} samples; must be 8 .. {n} "
                                  f"(the shortest record, {traces[0].path.name})", field="segment")
    return length


def _products(traces: Sequence[Trace], analysis: str, force_name: str, names: list[str], segment: float | None,
              overlap: float, window: str, blocks: int) -> tuple[Products, int, str]:
    """The summed products of all traces, the segment length (samples) and the window used."""
    def signals(t: Trace) -> tuple[np.ndarray, np.ndarray]:
        f = t.channels.get(force_name) or t.excitation[force_name]
        return f.data, np.stack([t.channels[n].data for n in names])

    if analysis == "harmonic":
        lines: dict[float, Products] = {}
        for t in traces:
            keep = t.time >= float(t.excitation_attrs.get("window_start", t.time[0]))
            if keep.sum() < 4:
                raise IdentificationError(f"{t.path.name}: fewer than 4 samples after window_start",
                                          field="window_start")
            f, x = signals(t)
            p = harmonic(f[keep], x[:, keep], t.time[keep], t.omega, blocks)
            lines[t.omega] = lines[t.omega].add(p) if t.omega in lines else p
        order = sorted(lines)
        ps = [lines[w] for w in order]
        cat = Products(np.concatenate([p.frequency for p in ps]), np.concatenate([p.force for p in ps]),
                       np.hstack([p.response for p in ps]), np.hstack([p.cross for p in ps]),
                       np.concatenate([p.count for p in ps]), np.concatenate([p.effective for p in ps]),
                       np.concatenate([p.scale for p in ps]))
        return cat, 0, "boxcar"
    if analysis == "impulse":
        n = {t.time.size for t in traces}
        if len(n) > 1:
            raise IdentificationError(f"impulse records of different lengths ({sorted(n)} samples; "
                                      f"{traces[0].path.name} ...)", field="time")
        length, hop, detrend, window = traces[0].time.size, traces[0].time.size, False, window or "boxcar"
    else:
        length = _segment(traces, segment, overlap)
        hop, detrend, window = max(1, int(round(length * (1.0 - overlap)))), True, window or "hann"
    try:
        w = np.asarray(get_window(window, length, fftbins=True), dtype=float)
    except ValueError as err:
        raise IdentificationError(f"unknown window {window!r}: {err}", field="window") from None
    total = None
    for t in traces:
        f, x = signals(t)
        p = welch(f, x, t.dt, w, hop, detrend)
        total = p if total is None else total.add(p)
    return total, length, window


def estimate(traces: Sequence[Trace], estimator: str = "H1", *, force: str | None = None,
             responses: Sequence[str] | None = None, analysis: str = "auto", segment: float | None = None,
             overlap: float = 0.5, window: str | None = None, blocks: int = 8,
             confidence: float = 0.95) -> Frf:
    """FRFs of ``responses`` (default: every non-force sensor channel) per
    ``force`` (default: the one measured force, else the commanded one) from
    traces of one test group (its repetitions, or a stepped sine's tests).

    ``estimator``: ``H1``, ``H2`` or ``Hv``; ``analysis``: ``auto`` (from the
    excitation kind), ``welch``, ``impulse`` or ``harmonic``; ``segment``
    (s) and ``overlap`` (fraction) of Welch segments; ``window``: a
    :func:`scipy.signal.get_window` name (default ``hann``, impulse
    ``boxcar``); ``blocks``: averages per harmonic record; ``confidence``:
    two-sided level of the bands. Returns an :class:`Frf` (shapes there).
    """
    if not traces:
        raise IdentificationError("no traces to estimate FRFs from", field="traces")
    if estimator not in ESTIMATORS:
        raise IdentificationError(f"unknown estimator {estimator!r}; known: {', '.join(ESTIMATORS)}",
                                  field="estimator")
    if analysis not in ANALYSES:
        raise IdentificationError(f"unknown analysis {analysis!r}; known: {', '.join(ANALYSES)}", field="analysis")
    if not 0.0 <= overlap < 1.0 or not 0.0 < confidence < 1.0 or blocks < 1:
        raise IdentificationError(f"need 0 <= overlap < 1, 0 < confidence < 1, blocks >= 1; got {overlap}, "
                                  f"{confidence}, {blocks}", field="overlap")
    first = traces[0]
    kind = _analysis(first) if analysis == "auto" else analysis
    f_channel = _force(first, force)
    r_channels = _responses(first, responses)
    _check_alike(traces, f_channel, r_channels, force)
    names = [r.name for r in r_channels]
    products, length, window_used = _products(traces, kind, f_channel.name, names, segment, overlap, window, blocks)
    s_ff, s_xx, s_fx = products.means()
    h = estimators.frf(estimator, s_ff, s_xx, s_fx)
    gamma2 = estimators.coherence(s_ff, s_xx, s_fx)
    eps = estimators.random_error(gamma2, products.effective)
    magnitude_band, phase_band = estimators.bands(h, eps, confidence)
    warnings = [w for t in traces for w in _leakage(t, r_channels)] if kind == "impulse" else []
    few = np.flatnonzero(products.effective < 2)
    if few.size:
        warnings.append(f"{few.size} line(s) with fewer than 2 averages: coherence 1 by construction, bands NaN")
    attrs = {"campaign": str(first.attrs.get("campaign", "")), "structure": first.structure,
             "group": str(first.attrs.get("group", first.test)), "tests": sorted({t.test for t in traces}),
             "traces": [t.path.name for t in traces], "step": first.step}
    return Frf(frequency=products.frequency, frf=h, coherence=gamma2, random_error=eps,
               magnitude_band=magnitude_band, phase_band=phase_band, n_averages=products.count.astype(np.int64),
               n_effective=products.effective, auto_force=s_ff, auto_response=s_xx, cross=s_fx,
               force=_info(f_channel), responses=[_info(r) for r in r_channels], estimator=estimator,
               analysis=kind, window=window_used, segment=length, overlap=overlap if kind == "welch" else 0.0,
               confidence=confidence, dt=first.dt,
               spectra_scaling="amplitude^2" if kind == "harmonic" else "density", attrs=attrs, warnings=warnings)
