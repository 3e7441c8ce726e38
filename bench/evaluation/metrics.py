"""Scores of identified quantities against the truth (pure functions)."""
from __future__ import annotations

import numpy as np


def normalized_rms(estimate: np.ndarray, truth: np.ndarray) -> float:
    """``sqrt(mean(((p_est - p_true) / p_true)^2))`` over parameters with
    non-zero truth (dimensionless)."""
    estimate, truth = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
    if estimate.shape != truth.shape:
        raise ValueError(f"estimate has shape {estimate.shape}, truth {truth.shape}")
    keep = truth != 0
    return float(np.sqrt(np.mean(((estimate[keep] - truth[keep]) / truth[keep]) ** 2)))


def relative_errors(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Per-parameter ``(p_est - p_true) / p_true`` (NaN where the truth is 0)."""
    estimate, truth = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(truth != 0, (estimate - truth) / truth, np.nan)


def frequency_error_pct(omega_est: np.ndarray, omega_true: np.ndarray) -> np.ndarray:
    """``100 (omega_est - omega_true) / omega_true`` per mode; 0 where both are
    rigid-body (0 rad/s), the absolute value otherwise."""
    est, true = np.asarray(omega_est, dtype=float), np.asarray(omega_true, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(true != 0, 100.0 * (est - true) / true, np.where(est == 0, 0.0, np.inf))
