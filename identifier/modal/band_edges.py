"""The band a record holds, and the candidate modes at its edges.

An anti-alias or band-pass filter, or resampling by FFT, leaves a record
whose spectrum ends in a cliff: past an edge frequency only a floor is
left, decades down. SSI fits poles to such an edge (the filter's own, or
its ringing after the start of a free decay) that the other tests take for
modes. No structure's response has a cliff, and a candidate at one is not
told from the filter: a candidate whose half-power band reaches within
``MARGIN`` of an edge, or lies past it, is not reported.

Spectrum ``S_k`` at the lines ``omega_k = 2 pi k / T`` rad/s: the records
cut to the shortest (``n`` samples, ``T = n dt``), each channel's mean
removed and scaled to unit RMS, tapered by the 4-term Blackman-Harris
window (sidelobes under -92 dB: a strong peak's leakage does not fill a
stopband), periodograms summed over channels and records, averaged over
``SMOOTH`` lines. An upper edge at line ``e`` on scale ``A`` (each of
``SCALES``):

    log10 min{S_k: e (1 - 2A) <= k <= e (1 - A)} - log10 max{S_k: k >= e (1 + A)} >= CLIFF,

the level just under ``e`` stands ``CLIFF`` decades over everything past
``e (1 + A)`` up to the Nyquist frequency; a lower edge is the mirror image
(over every line under ``e (1 - A)`` from line ``SMOOTH`` up). A scale is
not tried at ``e`` where its window ``A e`` holds under ``LINES`` lines or
its stopband (from ``e (1 + A)`` up, or from ``e (1 - A)`` down) is
narrower than its window: a response to a force held over each sample
step has a zero at the Nyquist frequency, which falls steeply only within
a few per cent of it. The record's band ends at the highest ``e (1 - A)``
of its upper edges on any scale (the passband reaches that far) and starts
at the lowest ``e (1 + A)`` of its lower ones.

Why a response has no cliff: one mode's ``L(omega) = 1 / ((w_0^2 -
omega^2)^2 + (2 zeta w_0 omega)^2)`` (times ``omega^2q`` for a velocity or
acceleration, which only rises) at the end of the window farther from
``w_0`` is at most ``((3A) / (A / 2))^2 = 36`` times (1.6 decades) its
value at any frequency past ``e (1 + A)``, wherever ``w_0`` lies, and
sensor noise is white. Fails (an edge where there is none) where many
light modes crowd one window and nothing follows them; misses a gentle
filter (a Butterworth band-pass falls 0.3 decades in 5 %), whose poles it
leaves to the other tests.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal.windows import blackmanharris

from .peak_test import scaled_transforms

CLIFF = 3.0  # decades the level falls across an edge
SCALES = (0.1, 0.05, 0.025)  # half-gaps A of an edge, shares of its frequency
SMOOTH = 8  # lines averaged
LINES = 24  # least lines in a window
MARGIN = 0.1  # a candidate's half-power band within this share of an edge: not told from a filter's pole


def spectrum(records: list[np.ndarray]) -> np.ndarray:
    """``S`` (n // 2 + 1,) of the module docstring for records (m, n_i)."""
    taper = blackmanharris(min(y.shape[1] for y in records))
    total = sum((np.abs(Y) ** 2).sum(axis=0) for Y in scaled_transforms(records, taper))
    return uniform_filter1d(total, SMOOTH, mode="nearest")


def _range_min(values: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``min(values[lo_i : hi_i + 1])`` for each i (a sparse table; ``lo <= hi``)."""
    table = [values]
    while 2 ** len(table) <= values.size:
        step = 2 ** (len(table) - 1)
        table.append(np.minimum(table[-1][:-step], table[-1][step:]))
    level = np.floor(np.log2(hi - lo + 1)).astype(int)
    out = np.empty(lo.size)
    for j in np.unique(level):
        at = level == j
        out[at] = np.minimum(table[j][lo[at]], table[j][hi[at] - 2**j + 1])
    return out


def _at(lines: np.ndarray, share: float, rounding: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """The line indices ``rounding(lines share)`` (int)."""
    return rounding(lines * share).astype(int)


def band(records: list[np.ndarray], dt: float) -> tuple[float, float, float, float]:
    """The band ``(low, high)`` rad/s the records (m, n_i) sampled at ``dt`` s
    hold (module docstring; 0 and the Nyquist frequency where no edge is
    found) and the largest falls (decades) across a lower and an upper edge
    (-inf where none was tried)."""
    n = min(y.shape[1] for y in records)
    level = spectrum(records)
    logs = np.log10(np.maximum(level, level.max() * 1e-30 + 1e-300))
    line = np.arange(logs.size)
    above = np.maximum.accumulate(logs[::-1])[::-1]  # max over k >= i
    below = np.maximum.accumulate(np.r_[np.full(SMOOTH, -np.inf), logs[SMOOTH:]])  # max over SMOOTH <= k <= i
    low, high, fall_low, fall_high = np.inf, 0.0, -np.inf, -np.inf
    for scale in SCALES:
        wide = line[scale * line >= LINES]
        inside = np.floor(wide * (1 + 2 * scale)) < logs.size
        upper = wide[inside]  # edges whose stopband is as wide as their window
        lower = wide[inside & (wide * (1 - 2 * scale) >= SMOOTH)]
        up = _range_min(logs, _at(upper, 1 - 2 * scale, np.ceil), _at(upper, 1 - scale, np.floor)) \
            - above[_at(upper, 1 + scale, np.ceil)]
        down = _range_min(logs, _at(lower, 1 + scale, np.ceil), _at(lower, 1 + 2 * scale, np.floor)) \
            - below[_at(lower, 1 - scale, np.floor)]
        fall_high, fall_low = max(fall_high, up.max(initial=-np.inf)), max(fall_low, down.max(initial=-np.inf))
        if np.any(up >= CLIFF):
            high = max(high, float(upper[up >= CLIFF].max() * (1 - scale)))
        if np.any(down >= CLIFF):
            low = min(low, float(lower[down >= CLIFF].min() * (1 + scale)))
    to_rad = 2.0 * np.pi / (n * dt)
    return (low * to_rad if fall_low >= CLIFF else 0.0, high * to_rad if fall_high >= CLIFF else np.pi / dt,
            float(fall_low), float(fall_high))


def at_edges(edges: tuple[float, float, float, float], omega: np.ndarray, zeta: np.ndarray) -> list[str]:
    """Per candidate (k,) at ``omega`` rad/s, damping ``zeta``: why it is not told from a filter's pole (its
    half-power band ``omega (1 -+ zeta)`` reaches within ``MARGIN`` of an edge of a record's band, ``edges``
    as :func:`band` returns them, or past it), ``""`` where it is not."""
    omega, z = np.asarray(omega, float), np.abs(np.asarray(zeta, float))
    low, high, fall_low, fall_high = edges
    upper = (fall_high >= CLIFF) & (omega * (1 + z) >= high * (1 - MARGIN))
    lower = (fall_low >= CLIFF) & (omega * (1 - z) <= low * (1 + MARGIN))
    return [f"at the record's upper band edge, {high:.6g} rad/s (its spectrum falls {fall_high:.3g} decades there: "
            "a filter or resampling, whose poles are not told from modes)" if up else
            f"at the record's lower band edge, {low:.6g} rad/s (its spectrum falls {fall_low:.3g} decades there: "
            "a filter, whose poles are not told from modes)" if down else "" for up, down in zip(upper, lower)]


def edge_warnings(edges: tuple[float, float, float, float]) -> list[str]:
    """What a record's band, ``edges`` as :func:`band` returns them, leaves out, said once: each edge found."""
    low, high, fall_low, fall_high = edges
    ends = [(f"starts at {low:.4g}", fall_low)] if fall_low >= CLIFF else []
    ends += [(f"ends at {high:.4g}", fall_high)] if fall_high >= CLIFF else []
    return [f"the record's band {where} rad/s (its spectrum falls {fall:.3g} decades there: a filter or "
            f"resampling); modes within {MARGIN * 100:g} % of that edge or past it are not told from the filter's "
            "poles and not reported" for where, fall in ends]
