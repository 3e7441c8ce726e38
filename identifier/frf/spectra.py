"""Averaged auto and cross spectra of one force and many responses.

Three ways to get the per-average spectra ``F_k`` (m,) and ``X_k`` (c, m):

- :func:`welch`: segments of ``L`` samples every ``hop`` samples, the
  segment mean removed (``detrend``), multiplied by a window ``w`` and
  transformed by ``rfft`` (random tests; with ``L = hop = n`` and a boxcar
  window, the whole transient record: impulse tests);
- :func:`harmonic`: a least-squares fit of ``a cos(omega t) + b sin(omega t)
  + d`` to each block of whole periods of a steady-state window, ``c = a - i b``
  (stepped-sine and harmonic tests: one line per test).

Both return :class:`Products`, the sums over averages of ``|F_k|^2``,
``|X_k|^2`` and ``conj(F_k) X_k``, which add up over records
(:meth:`Products.add`). No loop runs over samples: segments are strided
views, transformed in chunks of response channels to bound the memory.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft
from numpy.lib.stride_tricks import sliding_window_view

CHUNK_VALUES = 1 << 23  # windowed samples transformed at once (64 MiB of float64)


@dataclass
class Products:
    """Sums over ``count`` (m,) averages: ``force`` (m,) ``sum |F_k|^2``,
    ``response`` (c, m) ``sum |X_k|^2``, ``cross`` (c, m) ``sum conj(F_k) X_k``;
    ``effective`` (m,) the number of independent averages they are worth;
    ``scale`` (m,) turns a mean into the stated spectra (one-sided density
    for Welch, 1 for harmonic amplitudes)."""

    frequency: np.ndarray
    force: np.ndarray
    response: np.ndarray
    cross: np.ndarray
    count: np.ndarray
    effective: np.ndarray
    scale: np.ndarray

    def add(self, other: Products) -> Products:
        """The sums of two records' products on the same lines."""
        return Products(self.frequency, self.force + other.force, self.response + other.response,
                        self.cross + other.cross, self.count + other.count, self.effective + other.effective,
                        self.scale)

    def means(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(S_ff (m,), S_xx (c, m), S_fx (c, m))``: the averaged products times :attr:`scale`."""
        n = np.maximum(self.count, 1)
        return (self.scale * self.force / n, self.scale * self.response / n, self.scale * self.cross / n)


def overlap_correlation(window: np.ndarray, hop: int, segments: int) -> float:
    """Welch's variance factor ``1 + 2 sum_j (1 - j/K) rho(j hop)`` with
    ``rho(s) = (sum_n w_n w_(n+s))^2 / (sum_n w_n^2)^2``: ``K`` overlapping
    segments average like ``K`` / factor independent ones (white input)."""
    L = window.size
    lags = np.arange(1, segments) * hop
    lags = lags[lags < L]
    if lags.size == 0:
        return 1.0
    energy = float(window @ window)
    # sum_n w_n w_(n+s), s = 0 .. L-1, by FFT zero-padded to 2 L (no wrap-around): O(L log L), where
    # np.correlate is O(L^2) dot products
    spectrum = sfft.rfft(window, 2 * L)
    full = sfft.irfft(spectrum.real**2 + spectrum.imag**2, 2 * L)[:L]
    rho = (full[lags] / energy) ** 2
    j = np.arange(1, lags.size + 1)
    return float(1.0 + 2.0 * np.sum((1.0 - j / segments) * rho))


def _transform(x: np.ndarray, window: np.ndarray, hop: int, detrend: bool) -> np.ndarray:
    """Windowed rfft of the segments of ``x`` (..., n): (..., K, m), each
    segment's mean removed before the window when ``detrend``."""
    frames = sliding_window_view(x, window.size, axis=-1)[..., ::hop, :]
    if detrend:
        segments = frames - frames.mean(axis=-1)[..., None]
        segments *= window
    else:
        segments = frames * window
    return sfft.rfft(segments, axis=-1)


def welch(force: np.ndarray, responses: np.ndarray, dt: float, window: np.ndarray, hop: int,
          detrend: bool = True) -> Products:
    """Welch products of one record: ``force`` (n,) N, ``responses`` (c, n).

    Segments of ``L = window.size`` samples every ``hop`` samples
    (``K = (n - L) // hop + 1``); ``scale = 2 / (fs sum w^2)`` makes the means
    one-sided densities as :func:`scipy.signal.csd` computes them (DC and the
    Nyquist line not doubled: the ratios, FRF and coherence, do not depend on it).
    """
    L = window.size
    n = force.shape[-1]
    if n < L:
        raise ValueError(f"record of {n} samples is shorter than one segment ({L})")
    F = _transform(force, window, hop, detrend)  # (K, m)
    K, m = F.shape
    c = responses.shape[0]
    Fc = np.conj(F)
    response = np.empty((c, m))
    cross = np.empty((c, m), dtype=complex)
    step = max(1, CHUNK_VALUES // (K * L))
    for lo in range(0, c, step):  # chunks of channels, each transformed at once
        X = _transform(responses[lo:lo + step], window, hop, detrend)
        response[lo:lo + step] = np.einsum("ckm,ckm->cm", X.real, X.real) + np.einsum("ckm,ckm->cm", X.imag, X.imag)
        cross[lo:lo + step] = np.einsum("ckm,km->cm", X, Fc)
    factor = overlap_correlation(window, hop, K)
    scale = np.full(m, 2.0 * dt / float(window @ window))
    scale[0] /= 2.0
    if L % 2 == 0:
        scale[-1] /= 2.0
    return Products(sfft.rfftfreq(L, dt), np.sum(F.real**2 + F.imag**2, axis=0), response, cross,
                    np.full(m, K), np.full(m, K / factor), scale)


def harmonic(force: np.ndarray, responses: np.ndarray, time: np.ndarray, omega: float, blocks: int) -> Products:
    """Line products at ``omega`` (rad/s) from one steady-state window.

    ``force`` (n,), ``responses`` (c, n), ``time`` (n,) s. The window is cut
    into ``K = min(blocks, whole periods)`` (at least 1) equal blocks; in each,
    ``a cos(omega t) + b sin(omega t) + d`` is fitted by least squares to every
    channel and ``c = a - i b`` is the complex amplitude (``Re(c e^(i omega t))``).
    Each block is one average; noise and transients not at ``omega`` scatter
    the blocks' amplitudes and lower the coherence.
    """
    n = time.size
    periods = omega * (time[-1] - time[0] + (time[1] - time[0])) / (2.0 * np.pi)
    K = int(max(1, min(blocks, np.floor(periods))))
    L = n // K
    signals = np.vstack([force[None, :], responses])[:, :K * L].reshape(-1, K, L).transpose(1, 2, 0)  # (K, L, 1+c)
    t = time[:K * L].reshape(K, L)
    design = np.stack([np.cos(omega * t), np.sin(omega * t), np.ones_like(t)], axis=-1)  # (K, L, 3)
    normal = np.einsum("kla,klb->kab", design, design)
    rhs = np.einsum("kla,klc->kac", design, signals)
    ab = np.linalg.solve(normal, rhs)  # (K, 3, 1+c)
    amp = ab[:, 0, :] - 1j * ab[:, 1, :]  # (K, 1+c)
    F, X = amp[:, 0], amp[:, 1:].T  # (K,), (c, K)
    one = np.ones(1)
    return Products(np.array([omega / (2.0 * np.pi)]), np.array([np.sum(np.abs(F) ** 2)]),
                    np.sum(np.abs(X) ** 2, axis=1)[:, None], (X @ np.conj(F))[:, None],
                    one * K, one * K, one)
