"""A group of weighted records reduced, exactly, to what poles near one
``center`` can explain.

For poles ``lambda`` with ``|lambda - center| T <= sqrt(2)`` (record length
``T``, ``s = t / T``),

    e^(lambda t) = e^(center t) sum_{k <= ORDER} ((lambda - center) T)^k s^k / k!

to a relative error below ``REACH^(ORDER+1) / (ORDER+1)! < 1e-14``. So every
such pole's columns (with
the fixed poles' columns, offset and drift projected out, ``I - Q_f Q_f^T``)
lie in the span of ``V``, the orthonormal basis of the projected
``Re, Im of s^k e^(center t)`` (``2 (ORDER + 1)`` columns). The residual
of a fit by such poles then splits into ``V^T (Z - E A)`` (a few dozen rows)
and ``(I - V V^T) Z``, which no such pole changes: the fit works with
``V^T Z`` (k x M) and the constant ``||(I - V V^T) Z||^2`` alone, and its
Gauss-Newton matrix ``J^T J`` is that of the whole residual.
"""
from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np
import scipy.linalg as la

from .free_decay_fit import Group, against, fixed_part

ORDER = 18
REACH = np.sqrt(2.0)  # largest |lambda - center| T the expansion serves


@dataclass(frozen=True)
class Local:
    """``zv`` (k, M) the data in the basis ``V``, ``taylor`` (k, ORDER + 1)
    complex ``V^T s^j e^(center t)``, ``outside`` (M,) the squared norm of
    each column outside ``V``, ``center`` (complex, 1/s) and ``span`` T s."""

    zv: np.ndarray
    taylor: np.ndarray
    outside: np.ndarray
    center: complex
    span: float


def local_space(group: Group, fixed: np.ndarray, center: complex) -> Local:
    """The group reduced near ``center`` with the poles ``fixed`` (their residues free) projected out."""
    fx = fixed_part(group, fixed)
    span = float(group.t[-1])
    cols = (group.t / span)[:, None] ** np.arange(ORDER + 1) * np.exp(center * group.t)[:, None]
    real = against(fx, np.column_stack([cols.real, cols.imag]))
    v = la.qr(real, mode="economic")[0]
    zv = v.T @ fx.zf
    taylor = v.T @ real[:, :ORDER + 1] + 1j * (v.T @ real[:, ORDER + 1:])
    return Local(zv, taylor, np.sum(fx.zf**2, axis=0) - np.sum(zv**2, axis=0), center, span)


def columns(loc: Local, poles: np.ndarray) -> np.ndarray:
    """``V^T [Re e^(lambda_a t), Im e^(lambda_a t)]_a`` (k, 2p) for poles (p,) near the center."""
    d = (poles - loc.center) * loc.span
    k = np.arange(ORDER + 1)
    ev = loc.taylor @ (d[None, :] ** k[:, None] / np.array([factorial(j) for j in k], float)[:, None])
    return np.stack([ev.real, ev.imag], axis=2).reshape(ev.shape[0], -1)
