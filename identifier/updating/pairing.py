"""Measured modes reported twice, found before the updating pairs them.

A modal identifier can report one physical mode twice (two poles of a
split mode, a little apart in frequency, with the same shape). One-to-one
pairing then has to give the second copy another model mode, and with few
sensors a far higher model mode can look the same at them (spatial
aliasing: on the damage beam, 5 sensors, model modes 5 and 15 agree to MAC
1.00). Its eigenvalue residual, tens of thousands of standard errors, then
drives every parameter to a bound.

At the prior (``alpha = 0``) the pairing cost ``C`` (c, k) of
:meth:`.residuals.Residuals.cost` (``1 - MAC + FREQUENCY_TIE |log(lambda
ratio)|``) gives each measured mode with a shape its best model mode
``j_i = argmin_j C[j, i]``. Measured modes ``i != i'`` with ``j_i = j_i'``
whose measured shapes agree (``MAC(b_i, b_i') >= DUPLICATE_MAC``) are one
mode reported twice: the one of least cost to ``j`` is kept, the others are
left out of the data and named (:func:`duplicates`). Modes without a shape
(frequencies only) are never left out: frequency alone cannot tell a
duplicate from a close pair that the prior's error reorders.

Shapes: ``C`` (c, k) with ``c`` the model modes computed, ``k`` the
measured ones; ``b`` (m, k) the measured shapes at ``m`` DOF.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from structbench.models.mac import mac

from .data import ModalData
from .residuals import Residuals

DUPLICATE_MAC = 0.9  # measured shapes at least this alike, with the same best model mode: one mode twice


def _alike(b: np.ndarray) -> np.ndarray:
    """MAC (k, k) between the measured shapes ``b`` (m, k); 0 for a mode without one."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nan_to_num(mac(b, b))


def duplicates(res: Residuals) -> list[tuple[int, int, int]]:
    """``(left_out, kept, model_mode)`` (0-based: measured, measured, model)
    for each measured mode that repeats another at the prior (module
    docstring), the kept one of least pairing cost; empty when none."""
    model = res.model
    M, K = model.matrices(np.zeros(model.q))
    lam, phi = model.modes(M, K, res.count, res.k + 2)
    cost = res.cost(lam, phi[model.sensors])
    best = np.argmin(cost, axis=0)
    alike = _alike(res.b) >= DUPLICATE_MAC
    out: list[tuple[int, int, int]] = []
    for j in np.unique(best[res.shaped]):
        group = np.flatnonzero((best == j) & res.shaped)
        if group.size < 2:
            continue
        keep = int(group[np.argmin(cost[j, group])])
        out += [(int(i), keep, int(j)) for i in group if i != keep and alike[i, keep]]
    return out


def without_duplicates(res: Residuals, numbers: list[int]) -> tuple[list[int], list[dict[str, Any]]]:
    """The measured modes to keep (0-based, into ``res.data``) and one entry
    per mode left out: ``mode`` and ``kept`` (1-based numbers ``numbers``
    gives them in the data the user named), ``omega`` of both (rad/s),
    ``model_mode`` (1-based), ``mac`` of the two measured shapes, ``text``."""
    found = duplicates(res)
    if not found:
        return list(range(res.k)), []
    omega = np.sqrt(res.data.lam)
    alike = _alike(res.b)
    left = []
    for i, kept, j in found:
        text = (f"measured mode {numbers[i]} ({omega[i]:.4g} rad/s) repeats mode {numbers[kept]} "
                f"({omega[kept]:.4g} rad/s, shapes MAC {alike[i, kept]:.3f}): both pair best with model mode "
                f"{j + 1} at the prior; left out")
        left.append({"mode": numbers[i], "omega": float(omega[i]), "kept": numbers[kept],
                     "kept_omega": float(omega[kept]), "model_mode": j + 1, "mac": float(alike[i, kept]),
                     "text": text})
    drop = {i for i, _, _ in found}
    return [i for i in range(res.k) if i not in drop], left


def deduplicated(res: Residuals, data: ModalData, modes: list[int] | None) -> tuple[ModalData, list[dict[str, Any]]]:
    """``data`` without the modes :func:`without_duplicates` leaves out, and
    the list of them; ``modes``: the 0-based numbers ``data`` was selected
    with from the file (None: all of them), to name the modes by."""
    numbers = [m + 1 for m in modes] if modes is not None else list(range(1, data.lam.size + 1))
    keep, left = without_duplicates(res, numbers)
    return (data.select(keep) if left else data), left
