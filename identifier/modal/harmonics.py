"""Harmonics (periodic components: mains multiples, rotating machinery) in
stationary records, told apart from modes.

A harmonic is a sinusoid ``a_c cos(omega t + phi_c)`` on every channel c,
added to the random response. Two established tests tell it from a mode
(Brincker, Andersen & Moller 2000; Jacobsen 2006):

1. the probability density of the response filtered to a narrow band
   around ``omega``: a sinusoid's is bimodal, kurtosis 1.5; a random
   (Gaussian) response's kurtosis is 3. For a sinusoid of power ``P_s``
   over Gaussian power ``P_g`` in the band, ``kappa = 3 - 1.5 rho^2``,
   ``rho = P_s / (P_s + P_g)``. The band-filtered response is evaluated
   through its complex envelope: the channels demodulated at ``omega``,
   ``z_c(b) = sum_j w_j y_c(t_bj) exp(-i omega t_bj)`` over ``K`` blocks
   of Hann weights ``w`` (a band about ``K`` spectral lines ``2 pi / T``
   of the record wide), combined over the channels by the matched weights
   ``conj(a_c) / sigma_c^2`` (``a_c``: the fitted complex amplitude,
   ``sigma_c^2``: the channel's power in the lines near ``omega``);
   ``kappa = 1.5 <|z|^4> / <|z|^2>^2``, the kurtosis of ``Re(z e^(i omega
   t))`` averaged over the carrier. A random response's estimate has the
   standard error ``3 / sqrt(K)``; ``K`` is chosen per line to make the
   drop ``1.5 rho^2`` largest against it (:func:`band_lines`);
2. the damping ratio of the SSI poles there: near zero, the median
   ``|zeta|`` over the model orders the pole is stable at under ``ZETA``
   (:mod:`identifier.modal`; a real structure's modes are damped more).

Candidates are the lines of each record's spectrum (:func:`detect`):
local maxima of the Hann-windowed periodogram summed over the RMS-scaled
channels that stand ``LINE`` times above the median of the lines 3 to
``WINDOW`` either side. Each line's frequency is refined (interpolation of
the log spectrum, then a parabola through the windowed transform's power
0.05 lines either side), its complex amplitude per channel fitted by least
squares and its band kurtosis ``kappa`` measured, with ``z = (3 - kappa)
sqrt(K) / 3``, its drop below a random response's in standard errors.
Lines of ``kappa < DOUBTFUL`` are candidates. Then (:func:`screen`,
:func:`confirm`):

- ``z >= SURE``: a harmonic (test ``kurtosis``), subtracted from the
  records before SSI, so that it takes no model order and biases no mode
  near it (subtracting a line that is a mode's own random peak instead
  would notch the mode: the weaker candidates are not subtracted);
- an SSI mode of near-zero damping at a candidate line of ``z >= LIKELY``,
  or else whose band kurtosis measured in the cleaned records (up to
  ``BLOCKS[1]`` lines) has ``z >= SURE``: a harmonic
  (``kurtosis+damping``), dropped from the modes;
- any other candidate line of ``z >= LIKELY`` that no narrow damped SSI
  mode explains (none within ``SKIRT`` half-power bandwidths ``zeta_r
  omega_r`` plus 1.5 lines whose bandwidth ``zeta_r omega_r T / pi`` is
  under ``WINDOW`` lines: the running median does not follow so narrow a
  peak, whose random spikes are lines; a broad mode's peak is smooth over
  ``WINDOW`` lines, and a line on it is a harmonic on the mode): a
  harmonic (``kurtosis``).

Fails (misses the harmonic) when its line does not stand ``LINE`` times
above the random response near it, or when the band the record allows
holds as much random power as the harmonic (a weak harmonic on a mode's
peak); takes a random peak for a harmonic when its kurtosis estimate
falls ``LIKELY`` standard errors under 3 by chance away from every narrow
damped SSI mode (about one line in ten such peaks). A mode of damping
under ``ZETA`` at a line of ``z >= LIKELY`` would be taken for a harmonic.
Frequencies that drift over the record (a machine run up) are not lines
and are not found; free responses are not searched. An undamped
structure's random response (``zeta = 0``: each mode a sinusoid of slowly
wandering amplitude, near-zero damping at every order) is taken for
harmonics: the tests cannot tell them apart (the chapter 5 beam without
its ``[parameters]`` damping: 15 of its lines listed in a 2000 s record).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import maximum_filter1d, median_filter

LINE = 20.0  # least periodogram line over the median of its neighbours ...
WINDOW = 64  # ... the lines 3 to WINDOW either side
SURE = 3.0  # band kurtosis this many of a random response's standard errors 3 / sqrt(K) under 3: a harmonic
LIKELY = 1.25  # ... this many: a harmonic unless a narrow damped SSI mode explains the line
DOUBTFUL = 2.6  # a line of band kurtosis below this is a candidate
SKIRT = 2.0  # a line within this many half-power bandwidths zeta omega (+1.5 lines) of a narrow damped mode is its peak
ZETA = 0.003  # median |zeta| over the stable poles below this: near-zero damping
MAX_LINES = 40  # lines tested per record (the strongest)
BLOCKS = (16, 1024)  # band of the kurtosis, in spectral lines: a power of 2 within these (band_lines)


@dataclass(eq=False)
class Line:
    """One spectral line: ``omega`` rad/s, its complex amplitude per channel
    (m,) in the channels' units, band kurtosis, line-to-median ratio and
    band width in spectral lines (``blocks``)."""

    omega: float
    amplitude: np.ndarray
    kurtosis: float
    ratio: float
    blocks: int
    test: str = "kurtosis"
    zeta: float | None = None
    on_mode: float | None = None

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


def _spectrum(y: np.ndarray) -> np.ndarray:
    """Hann-windowed transforms (m, n // 2 + 1) of the RMS-scaled channels."""
    rms = np.sqrt(np.mean(y**2, axis=1, keepdims=True))
    return np.fft.rfft(y / np.where(rms > 0, rms, 1.0) * np.hanning(y.shape[1]), axis=1)


def _power(y: np.ndarray, omega: float, t: np.ndarray, window: np.ndarray) -> float:
    return float(np.sum(np.abs(y @ (window * np.exp(-1j * omega * t)))**2))


def fit(y: np.ndarray, omega: float, t: np.ndarray) -> np.ndarray:
    """Least-squares complex amplitudes (m,) of ``a cos(omega t) + b sin(omega t)``
    in ``y`` (m, n): ``a - i b`` per channel."""
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
    """Kurtosis of ``y`` (m, n) filtered to ``blocks`` spectral lines around
    ``omega`` rad/s (module docstring), and the blocks used: at least 8
    samples and 2 periods per block, at least 8 blocks (else NaN)."""
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
    """Blocks ``K`` (the band in the record's spectral lines) that best tell
    the line at ``j`` from a random response: the line's power ``L`` (``P``
    over ``bg`` within 2 lines), the random power through the Hann blocks
    ``G_K = sum_k |W((k - j) / K)|^2 B_k`` (``B``: ``P`` with the line's
    lines replaced by ``bg``), ``rho = L / (L + G_K)``; the largest
    ``rho^2 sqrt(K)`` (the kurtosis drop ``1.5 rho^2`` over a random
    response's standard error ``3 / sqrt(K)``) over K = 16, 32, ..., 1024
    that the record holds (:func:`kurtosis`)."""
    least = max(8, int(np.ceil(4 * np.pi / (omega * dt))))
    B = P.copy()
    B[max(j - 3, 0):j + 4] = bg[max(j - 3, 0):j + 4]
    line = float(np.sum(P[max(j - 2, 0):j + 3] - bg[max(j - 2, 0):j + 3]))
    best, score = BLOCKS[0], -1.0
    for K in 2 ** np.arange(int(np.log2(BLOCKS[0])), int(np.log2(BLOCKS[1])) + 1):
        if n // K < least:
            break
        lo, hi = max(j - 6 * K, 0), min(j + 6 * K + 1, P.size)
        G = float(_hann_gain((np.arange(lo, hi) - j) / K) @ B[lo:hi])
        value = (line / (line + G))**2 * np.sqrt(K)
        if value > score:
            best, score = int(K), value
    return best


def detect(y: np.ndarray, dt: float, max_lines: int = MAX_LINES) -> list[Line]:
    """The lines of a stationary record ``y`` (m, n) sampled every ``dt`` s
    with their kurtosis (module docstring), strongest first; none when the
    record is under ``4 WINDOW`` samples."""
    m, n = y.shape
    if n < 4 * WINDOW:
        return []
    X = _spectrum(y)
    P = np.sum(np.abs(X)**2, axis=0)
    ring = np.ones(2 * WINDOW + 1, dtype=bool)
    ring[WINDOW - 2:WINDOW + 3] = False
    bg = median_filter(P, footprint=ring, mode="nearest")
    ratio = P / np.maximum(bg, 1e-300)
    peak = P >= maximum_filter1d(P, size=7, mode="nearest")
    k = np.flatnonzero(peak & (ratio >= LINE))
    k = k[(k >= 3) & (k <= P.size - 4)]
    k = k[np.argsort(-ratio[k])][:max_lines]
    t = np.arange(n) * dt
    window = np.hanning(n)
    lines = []
    for j in k:
        a, b, c = np.log(P[j - 1:j + 2])
        delta = 0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c < 0 else 0.0
        bin_w = 2 * np.pi / (n * dt)
        omega = (j + float(np.clip(delta, -0.5, 0.5))) * bin_w
        h = 0.05 * bin_w
        p0, p1, p2 = (_power(y, omega + d, t, window) for d in (-h, 0.0, h))
        if p0 - 2 * p1 + p2 < 0:
            omega += float(np.clip(0.5 * h * (p0 - p2) / (p0 - 2 * p1 + p2), -h, h))
        amplitude = fit(y, omega, t)
        lo, hi = max(j - WINDOW, 0), min(j + WINDOW + 1, P.size)
        near = np.r_[lo:max(j - 3, lo), min(j + 4, hi):hi]
        rms2 = np.mean(y**2, axis=1)
        noise = np.median(np.abs(X[:, near])**2, axis=1) * rms2 + 1e-300
        kappa, used = kurtosis(y, omega, dt, band_lines(P, bg, j, n, omega, dt), amplitude, noise)
        lines.append(Line(float(omega), amplitude, kappa, float(ratio[j]), used))
    return lines



@dataclass
class Screened:
    """Records (per trace, (m, n)) less the ``lines`` that are harmonics
    for sure; the ``doubtful`` ones SSI's modes decide (:func:`confirm`)."""

    records: list[np.ndarray]
    lines: list[Line]
    doubtful: list[Line]


def _merge(found: list[Line], tol: float) -> list[Line]:
    """One line per frequency (within ``tol`` rad/s), the one of the largest ratio."""
    out: list[Line] = []
    for ln in sorted(found, key=lambda x: -x.ratio):
        if all(abs(ln.omega - o.omega) > tol for o in out):
            out.append(ln)
    return sorted(out, key=lambda x: x.omega)


def screen(records: list[np.ndarray], dt: float) -> Screened:
    """The lines of each stationary record (:func:`detect`) of kurtosis
    under ``DOUBTFUL``: the ``sure`` ones (``z >= SURE``) subtracted from
    it and in ``lines``, the others in ``doubtful`` (module docstring)."""
    cleaned, sure, doubtful = [], [], []
    for y in records:
        found = [ln for ln in detect(y, dt) if ln.kurtosis < DOUBTFUL]
        here = [ln for ln in found if ln.z >= SURE]
        sure += here
        doubtful += [ln for ln in found if all(ln is not s for s in here)]
        cleaned.append(subtract(y, here, dt) if here else y)
    tol = 4 * np.pi / (min(y.shape[1] for y in records) * dt)
    return Screened(cleaned, _merge(sure, tol), _merge(doubtful, tol))


def confirm(screened: Screened, dt: float, omega: np.ndarray, zeta_abs: np.ndarray, zeta: np.ndarray
            ) -> tuple[np.ndarray, list[Line]]:
    """Which SSI modes (``omega`` (k,) rad/s, ``zeta_abs`` the median
    ``|zeta|`` over each one's stable poles, ``zeta`` its median) are
    harmonics, and every harmonic found:

    - the sure lines (test ``kurtosis``); an SSI mode left there of
      near-zero damping is their residue and dropped too;
    - an SSI mode of near-zero damping at its orders (``zeta_abs < ZETA``)
      at a doubtful line of ``z >= LIKELY``, or else whose band kurtosis measured in the
      cleaned records (over up to ``BLOCKS[1]`` lines) has ``z >= SURE``:
      ``kurtosis+damping``;
    - a doubtful line of ``z >= LIKELY`` that no narrow damped SSI mode
      explains (module docstring): ``kurtosis``."""
    y = max(screened.records, key=lambda r: r.shape[1])
    length = y.shape[1] * dt
    tol = 4 * np.pi / length
    drop = np.zeros(omega.size, dtype=bool)
    found = [Line(ln.omega, ln.amplitude, ln.kurtosis, ln.ratio, ln.blocks, ln.test) for ln in screened.lines]
    doubtful = list(screened.doubtful)
    t = np.arange(y.shape[1]) * dt
    for i in np.flatnonzero(zeta_abs < ZETA):
        close = max(tol, 1e-3 * omega[i])
        near = [ln for ln in found if abs(ln.omega - omega[i]) <= close]
        if near:
            drop[i] = True
            near[0].test, near[0].zeta = "kurtosis+damping", float(zeta[i])
            continue
        line = next((ln for ln in doubtful if abs(ln.omega - omega[i]) <= close), None)
        if line is None:  # no spectral line: the kurtosis alone must be low
            amplitude = fit(y, float(omega[i]), t)
            kappa, used = kurtosis(y, float(omega[i]), dt, BLOCKS[1], amplitude, np.mean(y**2, axis=1))
            line = Line(float(omega[i]), amplitude, kappa, float("nan"), used)
        else:
            doubtful.remove(line)
        if line.z >= (LIKELY if np.isfinite(line.ratio) else SURE):
            drop[i] = True
            found.append(Line(line.omega, line.amplitude, line.kurtosis, line.ratio, line.blocks,
                              "kurtosis+damping", float(zeta[i])))
    narrow = ~drop & (np.abs(zeta) * omega * length / np.pi < WINDOW)
    reach = SKIRT * np.abs(zeta[narrow]) * omega[narrow] + 1.5 * tol
    found += [ln for ln in doubtful if ln.z >= LIKELY and not np.any(np.abs(ln.omega - omega[narrow]) < reach)]
    return drop, sorted(found, key=lambda x: x.omega)


def on_modes(found: list[Line], omega: np.ndarray, zeta: np.ndarray) -> None:
    """Mark each harmonic inside a reported mode's half-power band
    ``|omega_h - omega_r| < zeta_r omega_r`` with that mode's ``omega`` (rad/s)."""
    for ln in found:
        inside = np.abs(ln.omega - omega) < np.abs(zeta) * omega
        ln.on_mode = float(omega[inside][np.argmin(np.abs(ln.omega - omega[inside]))]) if inside.any() else None
