"""Harmonics (periodic components: mains multiples, rotating machinery) in
stationary records, told apart from modes.

A harmonic is a sinusoid ``a_c cos(omega t + phi_c)`` on every channel c added to the random
response. Two established tests tell it from a mode (Brincker, Andersen & Moller 2000; Jacobsen 2006):

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
   ``|zeta|`` over the model orders the pole is stable at indistinguishable
   from 0 given the record (fewer than ``STILL`` decay times in it), and the
   shape of the pole's spectral peak: a mode's spreads over its half-power
   band, a sinusoid's over the window's main lobe (2 lines).

Candidates are the lines of each record's spectrum (:func:`detect`, in
:mod:`identifier.modal.harmonics_lines` with the kurtosis and the fits):
local maxima of the Hann-windowed periodogram summed over the RMS-scaled
channels that stand ``LINE`` times above the median of the lines 3 to
``WINDOW`` either side, frequency refined (log-spectrum interpolation, then
a parabola through the windowed transform's power 0.05 lines either side),
complex amplitude per channel fitted by least squares, band kurtosis
``kappa`` measured, ``z = (3 - kappa) sqrt(K) / 3`` its drop in standard
errors; never over a band that a stronger periodogram value passes (its
kurtosis would be that peak's: the skirt of a strong narrow mode has local
maxima above the running median). ``kappa < DOUBTFUL``: a candidate. With
``T`` the records' total length and, per SSI mode, ``D = |zeta| omega T``
its decay times in it (``|zeta|``: the median over its stable poles) and
``h = D / (2 pi)`` its half-power half-width in spectral lines ``2 pi / T``
(:func:`screen`, :func:`confirm`):

- ``z >= SURE``: a harmonic (``kurtosis``), subtracted before SSI so that it takes no model order
  and biases no mode near it (the weaker ones are not: a mode's own random peak would be notched);
- near-zero damping, relative to what the record resolves: ``D < STILL`` (the support tests'
  ``MIN_DECAYS``; zeta's short-record bias is ``1 / (omega T)``, one decay time; here ``D`` counts
  the signed median damping, so that a pole that grows at half its orders is still,
  :mod:`identifier.modal.support`), or ``|zeta| < ZETA_FLOOR``, the least damping the support tests
  count. At a sure line, a doubtful one of ``z >= LIKELY``, or else of band kurtosis ``z >= SURE``
  over up to ``BLOCKS[1]`` lines of the cleaned records: a harmonic (``kurtosis+damping``), dropped
  from the modes. ``D < STILL`` without a low kurtosis, when ``|zeta| < ZETA_FLOOR`` or the support
  tests would count ``max(zeta, ZETA_FLOOR) omega T`` at least ``STILL`` decay times and report it (a
  pole of negative signed median damping): one too (``damping``); the other ``D < STILL`` are left to
  the support tests, which reject them (no damping determined, no harmonic shown);
- a damped SSI mode whose peak is a line's (``line``, :func:`_pole_line`): the strongest line within
  ``r = max(h, 2)`` lines of it stands ``conc(r)`` times above what a mode of half-width ``h`` gives
  (``P_j`` over the median of the lines 4 to ``max(h, 8)`` from it, times the median of ``1 / (1 +
  (d / h)^2)`` there; a periodogram scatters exponentially about its mean, so that a mode's band of
  ``2 r + 1`` lines holds such a line with probability under ``LINE_P``: ``conc(r) = max(CONC,
  log2((2 r + 1) / LINE_P))``), when ``h >= H_MIN`` its band does not rise ``RISE`` times over the
  lines 2 to 4 half-widths away (a broad mode with a harmonic on it rises) or, rising, keeps no peak
  once the sinusoid is taken out (under ``PEAK_Z`` standard errors of a random background,
  :func:`identifier.modal.harmonics_poles.peak_left`: a median of the few lines of a narrow band
  rises twice over its surroundings by chance in about one band in six), and one sinusoid holds
  more of the pole's peak than a mode's random response of ``D`` decay times would (the coherent
  share, :func:`identifier.modal.harmonics_poles.coherent_share`: over ``share_bound(D) = 1 -
  SHARE_P^(1 / sqrt(D))``, as a mode's exceeds with probability about ``SHARE_P``);
- a narrow damped SSI mode (``h < H_MIN``), or a broader one whose line the ``line`` test does not
  reach and whose band keeps no peak once the sinusoid is taken out (``peak_left`` under ``PEAK_Z``: a
  weak line's poles stray several lines from it, with a half-width of several lines), at a line
  standing ``LINE`` times over its neighbours' median (or over the spatial test's bar) that one
  sinusoid holds over ``share_bound(D)`` of
  (``coherent``; the share is measured in every sensor's lines when the record has 2 channels or
  more, :func:`identifier.modal.harmonics_poles.coherent_share`): a weak harmonic that SSI
  fitted with a pole of a few decay times (its kurtosis is a random response's when the band holds
  more random power than the harmonic); when the pole's own band shows none, at the strongest such
  line within three standard deviations of its poles' frequencies over the orders (a weak line's
  poles stray several lines from it, and the pole's band then holds only its skirt);
- any other candidate of ``z >= LIKELY``, or any line of the spatial test whatever its kurtosis
  (``spectral``: in every sensor's lines, the whitened periodogram over Hotelling's quantile at
  ``SPATIAL_P / lines`` times its running median, :mod:`identifier.modal.harmonics_spatial`; a
  random response gives such a line somewhere in the record with probability about
  ``SPATIAL_P``), that no narrow damped SSI mode explains (none within
  ``SKIRT`` half-power bandwidths ``zeta_r omega_r`` plus 1.5 lines whose bandwidth ``2 h`` is under
  ``WINDOW`` lines: the running median does not follow so narrow a peak, whose random spikes are
  lines; a broad mode's peak is smooth over ``WINDOW`` lines, and a line on it is a harmonic on the
  mode): ``kurtosis`` (or ``spectral``). A sure line at a narrow damped mode is that mode's peak and
  not listed (it was subtracted: the mode stays, slightly biased) when its drop counted over ``min(K, D)`` values is
  under ``SURE``: a mode's envelope takes about one independent value per decay time, so a lightly
  damped mode of a short record (few values, many blocks) has a low kurtosis far more often than
  ``3 / sqrt(K)`` says.

Fails (misses the harmonic) when its line does not stand ``LINE`` times above the random response
near it or the band the record allows holds as much random power as the harmonic (weak, on a mode's
peak); it is then reported as a mode when SSI fits it a pole of ``STILL`` to about 10 decay times
whose peak the random background shares (``share_bound`` nears 1 as ``D`` falls to ``STILL``: 0.98
at 3 decay times, 0.89 at 10), a broader pole whose line stands under ``conc(r)`` times a mode's peak, or a pole
further beside the line than its frequencies scatter over the orders. A mode of ``D``
decay times is taken for a harmonic with probability about ``SHARE_P`` when a line stands in its
band (the coherent share's law, Monte Carlo, docs/modal-method.md). Takes for a harmonic a random
peak whose kurtosis falls ``LIKELY`` standard errors under 3 by chance away from every narrow damped
SSI mode (about one such peak in ten), and a mode of under ``STILL`` decay times or damping under
``ZETA_FLOOR`` with a low kurtosis (the record cannot tell it from a sinusoid). Drifting frequencies
(a run-up) are not lines; free responses are not searched. An undamped structure's random response
(each mode a sinusoid of wandering amplitude) is taken for harmonics (the chapter 5 beam without its
``[parameters]`` damping: 15 lines listed in a 2000 s record).
"""
from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .harmonics_lines import (BLOCKS, CONC, DOUBTFUL, H_MIN, LIKELY, LINE, MAX_LINES, RISE, SKIRT, STILL,  # noqa: F401
                              SURE, WINDOW, Line, Spectra, band_lines, detect, fit, kurtosis, measure, spectra,
                              subtract)
from .harmonics_poles import PEAK_Z, _pole_line, coherent_share, conc, hann_gain, peak_left, share_bound  # noqa: F401
from .support import ZETA_FLOOR


@dataclass
class Screened:
    """Records (per trace, (m, n)) less the sure harmonics ``lines``; SSI's modes decide the
    ``doubtful``. ``spectra``: per record, its :func:`spectra` when :func:`screen` left it as it was
    (else None; empty: none known)."""

    records: list[np.ndarray]
    lines: list[Line]
    doubtful: list[Line]
    spectra: list[Spectra | None] = field(default_factory=list)


def _merge(found: list[Line], tol: float) -> list[Line]:
    """One line per frequency (within ``tol`` rad/s), the one of the largest ratio."""
    out: list[Line] = []
    for ln in sorted(found, key=lambda x: -x.ratio):
        if all(abs(ln.omega - o.omega) > tol for o in out):
            out.append(ln)
    return sorted(out, key=lambda x: x.omega)


def screen(records: list[np.ndarray], dt: float, known: Sequence[Line] = ()) -> Screened:
    """Each record's lines of kurtosis under ``DOUBTFUL`` (:func:`detect`): those of ``z >= SURE``
    subtracted from it and in ``lines``, the others in ``doubtful``. ``known``: harmonics found
    before (a first pass's :func:`confirm`), each refitted per record (its phase is the record's),
    subtracted and listed as found, in place of a detected line within two lines of it."""
    tol = 4 * np.pi / (min(y.shape[1] for y in records) * dt)
    cleaned, sure, doubtful, kept = [], [], [], []
    for y in records:
        known_here = spectra(y) if y.shape[1] >= 4 * WINDOW else None
        found = [ln for ln in detect(y, dt, known=known_here) if ln.kurtosis < DOUBTFUL or ln.evidence >= 1]
        here = [ln for ln in found if ln.z >= SURE and all(abs(ln.omega - k.omega) > tol for k in known)]
        t = np.arange(y.shape[1]) * dt
        again = [replace(k, amplitude=fit(y, k.omega, t)) for k in known]
        sure += here
        doubtful += [ln for ln in found if ln.z < SURE and all(abs(ln.omega - k.omega) > tol for k in known)]
        cleaned.append(subtract(y, here + again, dt) if here or again else y)
        kept.append(None if here or again else known_here)
    return Screened(cleaned, _merge(sure, tol) + list(known), _merge(doubtful, tol), kept)


class Screens:
    """:func:`screen`, once per records' content, ``dt`` and ``known`` within one identification
    (its further passes screen the same records again); the records are not changed after it."""

    def __init__(self) -> None:
        self._done: dict[tuple, Screened] = {}

    def __call__(self, records: list[np.ndarray], dt: float, known: Sequence[Line] = ()) -> Screened:
        digest = hashlib.blake2b(digest_size=16)
        for y in records:
            digest.update(str(y.shape).encode())
            digest.update(np.ascontiguousarray(y, dtype=float))
        key = (digest.digest(), dt, tuple(known))  # a Line is hashed by identity
        if key not in self._done:
            self._done[key] = screen(records, dt, known)
        return self._done[key]


def unsubtracted(found: list[Line], screened: Screened) -> list[Line]:
    """The harmonics of ``found`` that :func:`screen` did not subtract (those :func:`confirm` found
    through the SSI modes): they still take model orders of the records' SSI."""
    return [ln for ln in found if all(ln.omega != s.omega for s in screened.lines)]


def confirm(screened: Screened, dt: float, omega: np.ndarray, zeta_abs: np.ndarray, zeta: np.ndarray,
            scatter: np.ndarray) -> tuple[np.ndarray, list[Line]]:
    """Which SSI modes (``omega`` (k,) rad/s, ``zeta_abs`` the median
    ``|zeta|`` over each one's stable poles, ``zeta`` its median, ``scatter``
    the standard deviation of their frequencies, rad/s) are harmonics (k,),
    and every harmonic found: the sure lines, then the module docstring's
    rules in its order."""
    longest = max(range(len(screened.records)), key=lambda i: screened.records[i].shape[1])
    y = screened.records[longest]
    n = y.shape[1]
    length = n * dt
    total = sum(r.shape[1] for r in screened.records) * dt
    tol = 4 * np.pi / length
    bin_w = 2 * np.pi / length
    drop = np.zeros(omega.size, dtype=bool)
    found = [Line(ln.omega, ln.amplitude, ln.kurtosis, ln.ratio, ln.blocks, ln.test) for ln in screened.lines]
    doubtful = list(screened.doubtful)
    t = np.arange(n) * dt
    X = P = bg = over = None
    for i in range(omega.size):
        close = max(tol, 1e-3 * omega[i])
        still = max(zeta[i], 0.0) * omega[i] * total < STILL  # signed: poles that grow at half the orders
        if still or zeta_abs[i] < ZETA_FLOOR:
            near = [ln for ln in found if abs(ln.omega - omega[i]) <= close]
            if near:
                drop[i] = True
                near[0].test, near[0].zeta = "kurtosis+damping", float(zeta[i])
                continue
            line = next((ln for ln in doubtful if abs(ln.omega - omega[i]) <= close and ln.kurtosis < DOUBTFUL), None)
            if line is None:  # no spectral line: the kurtosis alone
                amplitude = fit(y, float(omega[i]), t)
                kappa, used = kurtosis(y, float(omega[i]), dt, BLOCKS[1], amplitude, np.mean(y**2, axis=1))
                line = Line(float(omega[i]), amplitude, kappa, float("nan"), used)
            else:
                doubtful.remove(line)
            if line.z >= (LIKELY if np.isfinite(line.ratio) else SURE):
                test = "kurtosis+damping"
            elif still and (zeta_abs[i] < ZETA_FLOOR or max(zeta[i], ZETA_FLOOR) * omega[i] * total >= STILL):
                test = "damping"  # support would count it damped at the floor (or |zeta|) and report it
            else:  # no sign of a sinusoid: support judges it (under STILL decay times: rejected)
                continue
            drop[i] = True
            found.append(Line(line.omega, line.amplitude, line.kurtosis, line.ratio, line.blocks, test,
                              float(zeta[i])))
        elif n >= 4 * WINDOW:
            if P is None:
                ready = screened.spectra[longest] if longest < len(screened.spectra) else None
                X, P, bg, over = spectra(y) if ready is None else ready
            w, h = float(omega[i]), float(zeta_abs[i] * omega[i] / bin_w)
            j, excess, rise = _pole_line(P, w, float(zeta_abs[i]), bin_w)
            rises = bool(np.isfinite(rise) and rise >= RISE)  # a broad mode with a line on it
            strong = excess >= conc(int(np.ceil(max(h, 2.0))))
            broad = not ((strong and not rises) or h < H_MIN)
            if broad and not strong and not _line_near(P, bg, over, w, h, bin_w):
                continue  # no line there that the coherent test could take: a mode
            share, ratio, k = coherent_share(y, dt, P, bg, w, float(zeta_abs[i]), X)
            bare = False  # a broad pole whose band keeps no peak once the sinusoid is out
            if broad:
                if not (share >= share_bound(2 * np.pi * h) and peak_left(y, dt, P, w, float(zeta_abs[i]), X) < PEAK_Z):
                    continue
                rises, bare = False, True
            line_like = strong and not rises
            if h < H_MIN and not share >= share_bound(2 * np.pi * h):  # a weak line's poles stray beside it
                share, ratio, k = _beside(y, X, dt, P, bg, w, float(zeta_abs[i]), 3 * float(scatter[i]) / bin_w)
            sinusoid = share >= share_bound(2 * np.pi * h)  # NaN: no peak
            test = "line" if line_like and sinusoid else ""
            if not test and (h < H_MIN or bare) and (ratio >= LINE or (k >= 0 and over[k] >= 1)) and sinusoid:
                test, j = "coherent", k
            if not test:
                continue
            drop[i] = True
            line = next((ln for ln in found + doubtful if abs(ln.omega - j * bin_w) <= tol), None)
            if line is not None and line in doubtful:
                doubtful.remove(line)
            elif line is None:
                line = measure(y, dt, X, P, bg, j) or Line(j * bin_w, fit(y, j * bin_w, t), float("nan"),
                                                           float(P[j] / max(bg[j], 1e-300)), 0)
            if all(line is not f for f in found):
                found.append(Line(line.omega, line.amplitude, line.kurtosis, line.ratio, line.blocks, test,
                                  float(zeta[i])))
    narrow = ~drop & (np.abs(zeta) * omega * length / np.pi < WINDOW)
    reach = SKIRT * np.abs(zeta[narrow]) * omega[narrow] + 1.5 * tol
    decays = (zeta_abs * omega * total)[narrow]
    for ln in [f for f in found if f.test == "kurtosis"]:  # a sure line at a narrow damped mode: its random
        at = np.abs(ln.omega - omega[narrow]) < reach  # envelope has about zeta omega T independent values
        if at.any() and (3 - ln.kurtosis) * np.sqrt(min(ln.blocks, decays[at].min())) / 3 < SURE:
            found.remove(ln)
    for ln in doubtful:  # a line alone (its kurtosis, or its evidence against the record's random lines)
        if ((ln.z >= LIKELY or ln.evidence >= 1) and not np.any(np.abs(ln.omega - omega[narrow]) < reach)
                and all(abs(ln.omega - f.omega) > tol for f in found)):
            ln.test = "kurtosis" if ln.z >= LIKELY else "spectral"
            found.append(ln)
    return drop, sorted(found, key=lambda x: x.omega)


def _line_near(P: np.ndarray, bg: np.ndarray, over: np.ndarray, omega: float, h: float, bin_w: float) -> bool:
    """Whether the band of :func:`coherent_share` around a pole at ``omega`` rad/s (half-width ``h``
    lines) holds a line the ``coherent`` test could take: ``P`` over ``LINE`` times ``bg`` less the
    loss of a line 0.75 lines off (the most the share's fit corrects), or the spatial test's
    ``over`` at 1 or more; False where that band runs off the spectrum (no share)."""
    j0, r = int(round(omega / bin_w)), int(np.ceil(max(2 * h, 3.0)))
    if j0 - r < 1 or j0 + r >= P.size - 1:
        return False
    band = slice(j0 - r, j0 + r + 1)
    return bool(np.any(P[band] >= LINE * hann_gain(0.75) * np.maximum(bg[band], 1e-300)) or np.any(over[band] >= 1))


def _beside(y: np.ndarray, X: np.ndarray, dt: float, P: np.ndarray, bg: np.ndarray, omega: float, zeta: float,
            reach: float) -> tuple[float, float, int]:
    """:func:`coherent_share` at the strongest line (over ``LINE`` times ``bg``, less the loss of a line
    half a line off) within ``reach``
    lines of a narrow pole at ``omega`` rad/s whose own band shows no sinusoid: a weak sinusoid's
    SSI poles stray from its line by several lines (about their scatter over the orders), so that
    the pole's band holds only the line's skirt. ``(nan, 0, -1)`` without such a line."""
    bin_w = 2 * np.pi / (y.shape[1] * dt)
    j0, r = int(round(omega / bin_w)), int(np.ceil(reach))
    band = np.arange(max(j0 - r, 1), min(j0 + r + 1, P.size - 1))
    if not band.size:
        return float("nan"), 0.0, -1
    j = int(band[np.argmax(P[band] / np.maximum(bg[band], 1e-300))])
    if P[j] < LINE * hann_gain(0.5) * bg[j]:  # a line between two lines puts 0.72 of its power in each
        return float("nan"), 0.0, -1
    return coherent_share(y, dt, P, bg, j * bin_w, zeta * omega / (j * bin_w), X)


def on_modes(found: list[Line], omega: np.ndarray, zeta: np.ndarray) -> None:
    """Mark each harmonic in a reported mode's band ``|omega_h - omega_r| < zeta_r omega_r`` with its ``omega``."""
    for ln in found:
        inside = np.abs(ln.omega - omega) < np.abs(zeta) * omega
        ln.on_mode = float(omega[inside][np.argmin(np.abs(ln.omega - omega[inside]))]) if inside.any() else None
