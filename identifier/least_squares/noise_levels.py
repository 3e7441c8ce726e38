"""Sensor noise levels estimated from the data, for channels that do not declare theirs.

For a record sampled finely compared with its content, the second difference
``d_k = x_{k+1} - 2 x_k + x_{k-1}`` of the signal is small (``dt^2 x''``)
while that of white noise ``n_k`` of standard deviation ``sigma`` has
variance ``6 sigma^2``. Hence ``sigma ~ 1.4826 MAD(d) / sqrt(6)`` (median
absolute deviation: robust to the few large second differences at force
steps). Fails (over-estimates) when the signal is not oversampled: when
``dt^2 |x''|`` is comparable with the noise, e.g. high modes near the
Nyquist frequency.
"""
from __future__ import annotations

import numpy as np


def estimate_sigma(data: np.ndarray) -> float:
    """Standard deviation of white noise on an oversampled record ``data`` (n,), same unit."""
    d = np.diff(np.asarray(data, dtype=float), 2)
    if d.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(6.0))
