"""Spectral lines of stationary records and their band kurtosis: the
detection half of :mod:`identifier.modal.harmonics` (whose docstring has
the tests, equations and thresholds).

Shapes: a record ``y`` is (m channels, n samples) sampled every ``dt`` s;
frequencies are rad/s; amplitudes are complex, per channel, in the
channels' units (``a cos(omega t) + b sin(omega t)`` is ``a - i b``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.ndimage import maximum_filter1d, median_filter

from .harmonics_spatial import side_medians, sided, spatial_bar, whitened
from .support import MIN_DECAYS

LINE = 20.0  # least periodogram line over the median of its neighbours ...
WINDOW = 64  # ... the lines 3 to WINDOW either side
SURE = 3.0  # band kurtosis this many of a random response's standard errors 3 / sqrt(K) under 3: a harmonic
LIKELY = 1.25  # ... this many: a harmonic unless a narrow damped SSI mode explains the line
DOUBTFUL = 2.6  # a line of band kurtosis below this is a candidate
SKIRT = 2.0  # a line within this many half-power bandwidths zeta omega (+1.5 lines) of a narrow damped mode is its peak
STILL = MIN_DECAYS  # decay times zeta omega T over the records under which an SSI mode is still (not a supported mode)
CONC = 15.0  # a line in a pole's band this many times a mode's peak there (_pole_line): the pole is the line's ...
H_MIN = 4.0  # ... and, for a pole of half-power half-width zeta omega T / (2 pi) of at least this many lines, ...
RISE = 2.0  # ... when its band does not rise this many times over the lines 2-4 half-widths away
MAX_LINES = 40  # lines tested per record (the strongest)
BLOCKS = (16, 1024)  # band of the kurtosis, in spectral lines: a power of 2 within these (band_lines)


@dataclass(eq=False)
class Line:
    """A spectral line: ``omega`` rad/s, complex amplitude per channel (m,) in the channels' units,
    band kurtosis, line-to-median ratio, band in spectral lines (``blocks``)."""

    omega: float
    amplitude: np.ndarray
    kurtosis: float
    ratio: float
    blocks: int
    test: str = "kurtosis"
    zeta: float | None = None
    on_mode: float | None = None
    evidence: float = float("nan")  # the line over its record-wise bar (spatial_excess); >= 1: a line

    @property
    def z(self) -> float:
        """The kurtosis's drop below 3 in a random response's standard errors ``3 / sqrt(K)``."""
        return float((3 - self.kurtosis) * np.sqrt(self.blocks) / 3) if np.isfinite(self.kurtosis) else 0.0

    def entry(self) -> dict:
        """The results' ``details.harmonics`` entry (docs/results-format.md)."""
        a = np.abs(self.amplitude)
        return {"omega": self.omega, "frequency_hz": self.omega / (2 * np.pi), "amplitude": a.tolist(),
                "amplitude_max": float(a.max()) if a.size else 0.0, "kurtosis": self.kurtosis,
                "line_ratio": self.ratio if np.isfinite(self.ratio) else None, "band_lines": self.blocks,
                "zeta": self.zeta, "test": self.test, "on_mode": self.on_mode}


def _spectrum(y: np.ndarray, rms: np.ndarray | None = None) -> np.ndarray:
    """Hann-windowed transforms (m, n // 2 + 1) of the channels of ``y`` (m, n) scaled by ``rms`` (m, 1)
    (default: their own RMS)."""
    rms = np.sqrt(np.mean(y**2, axis=1, keepdims=True)) if rms is None else rms
    return np.fft.rfft(y / np.where(rms > 0, rms, 1.0) * np.hanning(y.shape[1]), axis=1)


def _power(y: np.ndarray, omega: float, t: np.ndarray, window: np.ndarray) -> float:
    return float(np.sum(np.abs(y @ (window * np.exp(-1j * omega * t)))**2))


def fit(y: np.ndarray, omega: float, t: np.ndarray) -> np.ndarray:
    """Least-squares amplitudes ``a - i b`` (m,) of ``a cos(omega t) + b sin(omega t)`` in ``y`` (m, n)."""
    c, s = np.cos(omega * t), np.sin(omega * t)
    gram = np.array([[c @ c, c @ s], [c @ s, s @ s]])
    ab = np.linalg.solve(gram, np.vstack([y @ c, y @ s]))
    return ab[0] - 1j * ab[1]


def subtract(y: np.ndarray, lines: list[Line], dt: float) -> np.ndarray:
    """``y`` (m, n) less the fitted sinusoids of ``lines``."""
    t = np.arange(y.shape[1]) * dt
    out = y.copy()
    for ln in lines:
        out -= np.outer(ln.amplitude.real, np.cos(ln.omega * t)) - np.outer(ln.amplitude.imag, np.sin(ln.omega * t))
    return out


def kurtosis(y: np.ndarray, omega: float, dt: float, blocks: int, amplitude: np.ndarray,
             noise: np.ndarray) -> tuple[float, int]:
    """Kurtosis of ``y`` (m, n) filtered to ``blocks`` lines around ``omega`` rad/s (module
    docstring), and the blocks used: 8 samples and 2 periods per block, 8 blocks at least (else NaN)."""
    n = y.shape[1]
    least = max(8, int(np.ceil(4 * np.pi / (omega * dt))))
    k = min(blocks, n // least)
    if k < 8:
        return float("nan"), k
    size = n // k
    t = np.arange(k * size) * dt
    carrier = (np.hanning(size + 2)[1:-1] * np.exp(-1j * omega * t).reshape(k, size))  # (k, size)
    z = np.einsum("mkj,kj->mk", y[:, :k * size].reshape(y.shape[0], k, size), carrier)
    w = np.conj(amplitude) / np.maximum(noise, 1e-300)
    zc = w @ z
    p = np.abs(zc)**2
    return float(1.5 * np.mean(p**2) / max(np.mean(p)**2, 1e-300)), k


def _hann_gain(x: np.ndarray) -> np.ndarray:
    """Power response of a Hann-weighted block at ``x`` of its own frequency lines from its centre."""
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.sinc(x) / (1 - x**2)
    return np.where(np.isclose(np.abs(x), 1.0), 0.5, g)**2


def band_lines(P: np.ndarray, bg: np.ndarray, j: int, n: int, omega: float, dt: float) -> int:
    """Blocks ``K`` (band in record lines) that best tell the line at ``j``
    from a random response: the largest ``rho^2 sqrt(K)`` (drop ``1.5 rho^2``
    over the standard error ``3 / sqrt(K)``), ``rho = L / (L + G_K)``, ``L``
    the line's power (``P`` over ``bg`` within 2 lines), ``G_K = sum_k |W((k -
    j) / K)|^2 B_k`` the random power through the Hann blocks (``B``: ``P``, the
    line's lines replaced by ``bg``), over K = 16, ..., 1024 that the record
    holds (:func:`kurtosis`) and no stronger value passes (``max_k |W|^2 B_k
    <= P_j``); 0 when even K = 16 is passed."""
    least = max(8, int(np.ceil(4 * np.pi / (omega * dt))))
    B = P.copy()
    B[max(j - 3, 0):j + 4] = bg[max(j - 3, 0):j + 4]
    line = float(np.sum(P[max(j - 2, 0):j + 3] - bg[max(j - 2, 0):j + 3]))
    best, score = 0, -1.0
    for K in 2 ** np.arange(int(np.log2(BLOCKS[0])), int(np.log2(BLOCKS[1])) + 1):
        if n // K < least:
            break
        lo, hi = max(j - 6 * K, 0), min(j + 6 * K + 1, P.size)
        gain = _hann_gain((np.arange(lo, hi) - j) / K)
        if np.max(gain * B[lo:hi]) > P[j]:  # a stronger peak passes the band: its kurtosis, not the line's
            break
        value = (line / (line + float(gain @ B[lo:hi])))**2 * np.sqrt(K)
        if value > score:
            best, score = int(K), value
    return best


def measure(y: np.ndarray, dt: float, X: np.ndarray, P: np.ndarray, bg: np.ndarray, j: int,
            evidence: float = float("nan"), peak: np.ndarray | None = None) -> Line | None:
    """The line at periodogram index ``j`` of ``y`` (m, n), frequency
    refined, amplitude fitted, band kurtosis measured (module docstring);
    when a stronger value passes every band (:func:`band_lines`): ``None``,
    or, for a line of ``evidence >= 1`` (:func:`spatial_excess`), the line
    without a kurtosis (NaN, ``blocks`` 0). ``peak`` (lines,): refine the
    frequency on it alone (log-parabola), for a line that the summed
    periodogram ``P`` does not show."""
    m, n = y.shape
    t = np.arange(n) * dt
    a, b, c = np.log(np.maximum((P if peak is None else peak)[j - 1:j + 2], 1e-300))
    delta = 0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c < 0 else 0.0
    bin_w = 2 * np.pi / (n * dt)
    omega = (j + float(np.clip(delta, -0.5, 0.5))) * bin_w
    h = 0.05 * bin_w
    window = np.hanning(n)
    p0, p1, p2 = (_power(y, omega + d, t, window) for d in (-h, 0.0, h))
    if peak is None and p0 - 2 * p1 + p2 < 0:
        omega += float(np.clip(0.5 * h * (p0 - p2) / (p0 - 2 * p1 + p2), -h, h))
    blocks = band_lines(P, bg, j, n, omega, dt)
    if not blocks and not evidence >= 1:
        return None
    amplitude = fit(y, omega, t)
    if not blocks:
        return Line(float(omega), amplitude, float("nan"), float(P[j] / max(bg[j], 1e-300)), 0, evidence=evidence)
    lo, hi = max(j - WINDOW, 0), min(j + WINDOW + 1, P.size)
    near = np.r_[lo:max(j - 3, lo), min(j + 4, hi):hi]
    rms2 = np.mean(y**2, axis=1)
    noise = np.median(np.abs(X[:, near])**2, axis=1) * rms2 + 1e-300
    kappa, used = kurtosis(y, omega, dt, blocks, amplitude, noise)
    return Line(float(omega), amplitude, kappa, float(P[j] / max(bg[j], 1e-300)), used, evidence=evidence)


def background(P: np.ndarray) -> np.ndarray:
    """The running median of ``P`` over the lines 3 to ``WINDOW`` either side."""
    ring = np.ones(2 * WINDOW + 1, dtype=bool)
    ring[WINDOW - 2:WINDOW + 3] = False
    return median_filter(P, footprint=ring, mode="nearest")


class Spectra(NamedTuple):
    """What :func:`detect` reads of a record: its transforms ``X`` (m, lines) (:func:`_spectrum`),
    their summed periodogram ``P``, its :func:`background` ``bg`` and :func:`spatial_excess` ``over``
    (lines,)."""

    X: np.ndarray
    P: np.ndarray
    bg: np.ndarray
    over: np.ndarray


def spectra(y: np.ndarray) -> Spectra:
    """:class:`Spectra` of a record ``y`` (m, n); computed once and handed on, since the
    :func:`spatial_excess` of an 8 h record costs about 1.5 CPU seconds."""
    X = _spectrum(y)
    P = np.sum(np.abs(X)**2, axis=0)
    return Spectra(X, P, background(P), spatial_excess(X))


def detect(y: np.ndarray, dt: float, max_lines: int = MAX_LINES, known: Spectra | None = None) -> list[Line]:
    """The lines of a stationary record ``y`` (m, n) sampled every ``dt`` s (module docstring),
    strongest first, then those that stand out only in every sensor's lines
    (local maxima of :func:`spatial_excess` over 7 lines, at 1 or more, more than 3 lines from a line
    of the first kind), each with its ``evidence``; none when the record is under ``4 WINDOW``
    samples. ``known``: :func:`spectra` of ``y`` when computed already."""
    m, n = y.shape
    if n < 4 * WINDOW:
        return []
    X, P, bg, over = spectra(y) if known is None else known
    ratio = P / np.maximum(bg, 1e-300)
    peak = P >= maximum_filter1d(P, size=7, mode="nearest")
    k = np.flatnonzero(peak & (ratio >= LINE))
    k = k[(k >= 3) & (k <= P.size - 4)]
    k = k[np.argsort(-ratio[k])][:max_lines]
    tops = over >= maximum_filter1d(over, size=7, mode="nearest")
    kw = np.flatnonzero(tops & (over >= 1))
    kw = kw[(kw >= 3) & (kw <= P.size - 4) & np.all(np.abs(kw[:, None] - k[None, :]) > 3, axis=1)]
    kw = kw[np.argsort(-over[kw])][:max_lines]
    lines = []
    for j in np.r_[k, kw].astype(int):
        ln = measure(y, dt, X, P, bg, int(j), float(over[j]), None if j in k else over)
        if ln is not None:
            lines.append(ln)
    return lines


def spatial_excess(X: np.ndarray) -> np.ndarray:
    """``T_j`` over its running median (:func:`background` over the lines it is defined at), over
    :func:`identifier.modal.harmonics_spatial.spatial_bar` for every line of ``X`` (m, lines):
    1 or more passes the spatial test; 0 where it is undefined (within ``2 WINDOW`` lines of either
    end, one channel); where it is smaller (over the lines where both are defined), ``T^L_j`` or
    ``T^R_j`` (:func:`identifier.modal.harmonics_spatial.sided`: whitened by one side alone) over
    the median of its own side's values on the lines 3 to ``WINDOW`` below (or above) ``j``, over
    the same bar: a line must stand over its background however that is taken (a step of the
    background, an excitation's band edge, inflates the two-sided ratio; a bump tens of lines wide,
    the one-sided ones)."""
    out = np.zeros(X.shape[1])
    bar = spatial_bar(X.shape[0], X.shape[1], WINDOW)
    if not np.isfinite(bar):
        return out
    T = whitened(X, WINDOW)
    ok = np.flatnonzero(np.isfinite(T))
    if ok.size <= 4 * WINDOW:
        return out
    seg = T[ok[0]:ok[-1] + 1]
    out[ok[0]:ok[-1] + 1] = seg / np.maximum(background(seg), 1e-300) / bar
    out[:ok[0] + WINDOW] = out[ok[-1] + 1 - WINDOW:] = 0.0  # the running median there is one-sided
    left, right = sided(X, WINDOW)
    below, above = side_medians(left, WINDOW)[0], side_medians(right, WINDOW)[1]
    with np.errstate(invalid="ignore", divide="ignore"):
        e = np.minimum(left / below, right / above) / bar  # NaN where either side is undefined
    return np.where(np.isfinite(e), np.minimum(out, e), out)
