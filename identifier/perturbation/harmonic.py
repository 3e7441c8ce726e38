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

EXCLUDE = 2  # frequency bins (2 pi / record length) around a forced frequency where no free one is sought


def design(t: np.ndarray, omegas: Sequence[float]) -> np.ndarray:
    """Columns ``cos(omega t), sin(omega t)`` per frequency (``1, t`` for 0), (n, 2 len(omegas))."""
    cols = []
    for w in omegas:
        cols += [np.ones_like(t), t - t.mean()] if w == 0 else [np.cos(w * t), np.sin(w * t)]
    return np.column_stack(cols) if cols else np.empty((t.size, 0))


def residual_projector(X: np.ndarray):
    """``B -> B - X c(B)``: the part of ``B`` (n, ...) that the columns of ``X``
    (n, p) do not fit, by least squares (column-scaled normal equations,
    factored once; SVD if they are singular)."""
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    Xs = X / scale
    try:
        factor = la.cho_factor(Xs.T @ Xs)
        fit = lambda B: la.cho_solve(factor, Xs.T @ B)  # noqa: E731
    except la.LinAlgError:
        fit = lambda B: la.lstsq(Xs, B)[0]  # noqa: E731
    return lambda B: B - Xs @ fit(B)


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


def moving_misfit(t: np.ndarray, y: np.ndarray, fixed_for):
    """``misfit(x)``: the residual sum of squares of ``y`` (n, c) fitted by a
    sinusoid at ``x`` (rad/s) and the columns of ``design(t, fixed_for(x))``,
    by least squares. The fixed columns are projected out once per distinct
    set (``y`` and the two moving columns through the cached projector), so
    that a search over ``x`` costs two projected columns per evaluation."""
    cache: dict[tuple[float, ...], tuple] = {}

    def misfit(x: float) -> float:
        fixed = tuple(float(v) for v in fixed_for(x))
        if fixed not in cache:
            project = residual_projector(design(t, fixed))
            cache[fixed] = (project, project(y))
        project, rest = cache[fixed]
        U = project(np.column_stack([np.cos(x * t), np.sin(x * t)]))
        c = la.lstsq(U.T @ U, U.T @ rest)[0]  # 2 x 2 normal equations (singular: least norm)
        return float(np.sum((rest - U @ c) ** 2))
    return misfit


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

    def basis(self, omegas: Sequence[float]) -> tuple[np.ndarray, int]:
        """Design over the forced component, allowed a small frequency error
        (its first-order terms ``t cos``, ``t sin``), then ``omegas``; and the
        number of leading forced columns."""
        forced = design(self.t, self.known)
        if self.known:
            tc = (self.t - self.t.mean())[:, None]
            forced = np.hstack([forced, tc * forced])
        return np.hstack([forced, design(self.t, omegas)]), forced.shape[1]


def _search(records: Sequence[Record], guesses: np.ndarray, dt: float, prominence: float) -> np.ndarray:
    """Peak of the summed Hann periodogram of the records near each guess, or
    NaN where there is no clear peak. Each record's forced component is
    fitted out and its spectrum ignored within :data:`EXCLUDE` bins of that
    frequency (an actuator frequency error leaves a residual there)."""
    n_fft = 1 << int(np.ceil(np.log2(8 * max(r.t.size for r in records))))
    grid = 2 * np.pi * np.fft.rfftfreq(n_fft, dt)
    power = np.zeros(grid.size)
    for r in records:
        X = r.basis([0.0])[0]
        rest = r.y - X @ coefficients(X, r.y)
        part = np.sum(np.abs(np.fft.rfft(rest * np.hanning(r.t.size)[:, None], n_fft, axis=0)) ** 2, axis=1)
        for w in r.known:
            part[np.abs(grid - w) < EXCLUDE * 2 * np.pi / (r.t[-1] - r.t[0])] = 0.0
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
            X, lead = r.basis([*fixed, *w])
            coef = coefficients(X, r.y)
            resid = r.y - X @ coef
            lead += 2 * fixed.size
            a, b = coef[lead::2], coef[lead + 1::2]  # (K, c)
            s, c = np.sin(np.outer(r.t, w)), np.cos(np.outer(r.t, w))
            # d(fit)/d(omega_k) of channel ch is -a_k,ch T_s[:, k] + b_k,ch T_c[:, k] with T = t sin, t cos:
            # project the 2K columns T off X once (Kaufman), then combine per channel through their Gram
            T = r.t[:, None] * np.hstack([s, c])
            P = residual_projector(X)(T)
            G = P.T @ P
            K = w.size
            Gss, Gsc, Gcc = G[:K, :K], G[:K, K:], G[K:, K:]
            jtj += Gss * (a @ a.T) - Gsc * (a @ b.T) - Gsc.T * (b @ a.T) + Gcc * (b @ b.T)
            TR = T.T @ resid  # (2K, c): the residual is orthogonal to X already
            jtr += np.sum(-a * TR[:K] + b * TR[K:], axis=1)
        d = np.sqrt(np.diag(jtj))
        d[d == 0] = 1.0
        step = la.lstsq(jtj / np.outer(d, d), jtr / d)[0] / d
        w += step
        if np.max(np.abs(step) / np.maximum(w, 1e-12)) < 1e-10:
            break
    return w


def _significance(records: Sequence[Record], omegas: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """Per frequency, the chi-square statistic of its fitted cosine and sine
    amplitudes (over records and channels) against their standard errors,
    divided by its expectation when there is no such component."""
    z = np.zeros(omegas.size)
    dof = 0
    for r in records:
        X, lead = r.basis([*fixed, *omegas])
        lead += 2 * fixed.size
        scale = np.linalg.norm(X, axis=0)
        inverse = np.diag(la.inv((X / scale).T @ (X / scale))) / scale**2
        coef = coefficients(X, r.y)
        s2 = np.sum((r.y - X @ coef) ** 2, axis=0) / max(r.t.size - X.shape[1], 1)
        var = inverse[lead:, None] * s2[None, :]
        z += np.sum((coef[lead:] ** 2 / np.maximum(var, 1e-300)).reshape(omegas.size, 2, -1), axis=(1, 2))
        dof += 2 * r.y.shape[1]
    return z / dof


def free_frequencies(records: Sequence[Record], guesses: Sequence[float], dt: float,
                     prominence: float = 100.0, significance: float = 300.0) -> np.ndarray:
    """Natural frequencies (rad/s) of the free vibration in the records, one
    per guess (a model's natural frequencies); NaN where the data show no
    clear peak within 15 % of the guess (or half-way to the next guess).

    Peaks of the summed Hann periodogram (power above ``prominence`` times its
    median) seed a joint Gauss-Newton fit of all records, in which the modes
    without a peak keep their guessed frequency. An estimate is dropped when
    it leaves its search band or when its amplitudes are not significant: their
    chi-square against the fit's standard errors must exceed ``significance``
    times its expectation under no component (numerical noise of a
    noise-free record makes spurious peaks, too).
    """
    guesses = np.asarray(guesses, dtype=float)
    found = _search(records, guesses, dt, prominence)
    ok = np.isfinite(found) & (guesses > 0)
    if not ok.any():
        return found
    fixed = np.unique(guesses[~ok])
    refined = _refine(records, found[ok], fixed)
    significant = _significance(records, refined, fixed) > significance
    out = np.full(guesses.size, np.nan)
    keep = (np.abs(refined / guesses[ok] - 1) < 0.15) & significant
    out[np.flatnonzero(ok)] = np.where(keep, refined, np.nan)
    return out
