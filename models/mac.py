"""The modal assurance criterion, the one definition every layer uses.

``MAC(a, b) = |a^H b|^2 / ((a^H a) (b^H b))``: 1 for collinear shapes, 0 for
orthogonal ones; real or complex shapes, invariant to scaling either.
"""
from __future__ import annotations

import numpy as np


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC between every column of ``a`` (m, k_a) and of ``b`` (m, k_b): (k_a, k_b) in [0, 1]."""
    a, b = np.asarray(a), np.asarray(b)
    cross = np.abs(a.conj().T @ b) ** 2
    return cross / np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))


def paired_mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC between matching columns of ``a`` (m, t) and ``b`` (..., m, t): (..., t)."""
    return np.abs(np.sum(a.conj() * b, -2)) ** 2 / np.sum(np.abs(a) ** 2, -2) / np.sum(np.abs(b) ** 2, -2)
