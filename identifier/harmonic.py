"""Sinusoids in sampled records: complex amplitudes at known frequencies, and
free-vibration frequencies estimated from the data.

A record ``y`` (n, c) at times ``t`` (n,) is fitted by least squares with
``sum_j Re(Y_j exp(i omega_j t))``; a frequency of 0 contributes a constant
and a linear drift (rigid-body motion). Frequencies above the Nyquist
frequency are used as they are: their samples alias by themselves.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la


def design(t: np.ndarray, omegas: Sequence[float]) -> np.ndarray:
    """Columns ``cos(omega t), sin(omega t)`` per frequency (``1, t`` for 0), (n, 2 len(omegas))."""
    cols = []
    for w in omegas:
        cols += [np.ones_like(t), t - t.mean()] if w == 0 else [np.cos(w * t), np.sin(w * t)]
    return np.column_stack(cols)


def coefficients(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares ``c`` in ``X c ~ y`` by the column-scaled normal equations
    (sinusoid columns are nearly orthogonal; SVD if they are not)."""
    scale = np.linalg.norm(X, axis=0)
    Xs = X / scale
    try:
        c = la.cho_solve(la.cho_factor(Xs.T @ Xs), Xs.T @ y)
    except la.LinAlgError:
        c = la.lstsq(Xs, y)[0]
    return c / (scale[:, None] if c.ndim == 2 else scale)


def amplitudes(t: np.ndarray, y: np.ndarray, omegas: Sequence[float]) -> np.ndarray:
    """Complex amplitudes ``Y_j`` (len(omegas), c) of ``y`` (n, c): ``y ~ Re(Y e^{i omega t})``."""
    coef = coefficients(design(t, omegas), y)
    return coef[0::2] - 1j * coef[1::2]


def resolvable(omegas: Sequence[float], fixed: float, span: float, dt: float) -> list[float]:
    """``omegas`` without those whose alias lies within half a bin (``pi / span``)
    of ``fixed`` or of an earlier kept one: the record cannot tell them apart."""
    def alias(w: float) -> float:
        return abs((w + np.pi / dt) % (2 * np.pi / dt) - np.pi / dt)

    kept: list[float] = []
    for w in omegas:
        if all(abs(alias(w) - alias(k)) > np.pi / span for k in [fixed, *kept]):
            kept.append(w)
    return kept


@dataclass
class Record:
    """One windowed record: times (n,), samples (n, c) and its known forced
    frequency (rad/s; ``None`` for a free response)."""

    t: np.ndarray
    y: np.ndarray
    forced: float | None = None

    @property
    def known(self) -> list[float]:
        """Frequencies fitted besides the free ones."""
        return [] if self.forced is None else [self.forced]


def _search(records: Sequence[Record], guesses: np.ndarray, dt: float, prominence: float) -> np.ndarray:
    """Peak of the summed Hann periodogram of the records near each guess, or
    NaN where there is no clear peak. Each record's forced component is
    fitted out and its spectrum ignored within two bins of that frequency."""
    n_fft = 1 << int(np.ceil(np.log2(8 * max(r.t.size for r in records))))
    grid = 2 * np.pi * np.fft.rfftfreq(n_fft, dt)
    power = np.zeros(grid.size)
    for r in records:
        X = design(r.t, [*r.known, 0.0])
        rest = r.y - X @ coefficients(X, r.y)
        part = np.sum(np.abs(np.fft.rfft(rest * np.hanning(r.t.size)[:, None], n_fft, axis=0)) ** 2, axis=1)
        for w in r.known:
            part[np.abs(grid - w) < 4 * np.pi / (r.t[-1] - r.t[0])] = 0.0
        power += part
    floor = np.median(power[power > 0])
    nyquist = np.pi / dt
    folded = np.abs((guesses + nyquist) % (2 * nyquist) - nyquist)
    found = np.full(guesses.size, np.nan)
    for i, (g, f) in enumerate(zip(guesses, folded)):
        others = np.delete(folded, i)
        half = min(0.15 * f, np.min(np.abs(others - f)) / 2 if others.size else f)
        band = np.flatnonzero((np.abs(grid - f) <= half) & (power > 0))
        if band.size < 3:
            continue
        k = band[np.argmax(power[band])]
        if k in (band[0], band[-1]) or power[k - 1] == 0 or power[k + 1] == 0 or power[k] < prominence * floor:
            continue
        a, b, c = np.log(power[k - 1:k + 2])
        peak = grid[k] + 0.5 * (a - c) / (a - 2 * b + c) * (grid[1] - grid[0])
        found[i] = g + (peak - f) * (1 if (g + nyquist) % (2 * nyquist) - nyquist >= 0 else -1)
    return found


def _refine(records: Sequence[Record], omegas: np.ndarray, fixed: np.ndarray, iterations: int = 10
            ) -> np.ndarray:
    """Gauss-Newton on the shared free frequencies ``omegas`` (variable
    projection, Kaufman's Jacobian); components at ``fixed`` are fitted too."""
    w = omegas.copy()
    for _ in range(iterations):
        jtj = np.zeros((w.size, w.size))
        jtr = np.zeros(w.size)
        for r in records:
            X = design(r.t, [*r.known, *fixed, *w])
            coef = coefficients(X, r.y)
            resid = r.y - X @ coef
            lead = 2 * (len(r.known) + fixed.size)
            a, b = coef[lead::2], coef[lead + 1::2]  # (K, c)
            s, c = np.sin(np.outer(r.t, w)), np.cos(np.outer(r.t, w))
            for ch in range(r.y.shape[1]):
                D = r.t[:, None] * (-a[:, ch] * s + b[:, ch] * c)  # d(fit)/d(omega), (n, K)
                D -= X @ coefficients(X, D)
                jtj += D.T @ D
                jtr += D.T @ resid[:, ch]
        d = np.sqrt(np.diag(jtj))
        d[d == 0] = 1.0
        step = la.lstsq(jtj / np.outer(d, d), jtr / d)[0] / d
        w += step
        if np.max(np.abs(step) / np.maximum(w, 1e-12)) < 1e-10:
            break
    return w


def free_frequencies(records: Sequence[Record], guesses: Sequence[float], dt: float,
                     prominence: float = 100.0) -> np.ndarray:
    """Natural frequencies (rad/s) of the free vibration in the records, one
    per guess (a model's natural frequencies); NaN where the data show no
    clear peak within 15 % of the guess (or half-way to the next guess).

    Peaks of the summed Hann periodogram (power above ``prominence`` times its
    median) seed a joint Gauss-Newton fit of all records, in which the modes
    without a peak keep their guessed frequency; an estimate that leaves its
    search band is dropped.
    """
    guesses = np.asarray(guesses, dtype=float)
    found = _search(records, guesses, dt, prominence)
    ok = np.isfinite(found) & (guesses > 0)
    if not ok.any():
        return found
    refined = _refine(records, found[ok], np.unique(guesses[~ok]))
    out = np.full(guesses.size, np.nan)
    out[np.flatnonzero(ok)] = np.where(np.abs(refined / guesses[ok] - 1) < 0.15, refined, np.nan)
    return out
