"""Identifiability checks shared by the least-squares estimators: parameters
whose columns vanish (unexcited) or are linearly dependent raise
:class:`IdentificationError` naming them."""
from __future__ import annotations

import numpy as np

from structbench.models import Structure

from ..errors import IdentificationError


def not_identifiable(null: np.ndarray, labels: list[str]) -> list[str]:
    """Labels with weight in the (k, n_par) null-space directions ``null``."""
    weight = np.sqrt(np.sum(null**2, axis=0))
    return [lab for lab, w in zip(labels, weight) if w > 1e-2]


def raise_deficient(names: list[str], rank: int, total: int) -> None:
    listed = ", ".join(names[:30]) + (f" and {len(names) - 30} more" if len(names) > 30 else "")
    raise IdentificationError(f"rank deficient ({rank} of {total}): parameter(s) {listed} are not "
                              "identifiable from these measurements (is elastic motion excited?)",
                              field="parameters")


def check_excited(model: Structure, signal_norms: dict[str, float], column_norms: np.ndarray,
                  labels: list[str]) -> None:
    """Columns ``dX_j x`` that vanish against ``|dX_j|_F |x|`` (e.g. ``dK_j u``
    under rigid-body motion) carry no information: raise naming their parameters.
    ``signal_norms``: Frobenius norm of each kind's signal (mass: a, damping: v,
    stiffness: u); ``column_norms`` (n_unknown,)."""
    par, _, _, vals = model.triplets
    pattern = np.sqrt(np.bincount(par, vals**2, minlength=len(model.parameters)))  # |dX_j|_F
    capacity = np.array([f * signal_norms[p.kind] for f, p, u in
                         zip(pattern, model.parameters, model.kind_mask()) if u])
    dead = column_norms <= 1e-9 * capacity
    if dead.any():
        raise_deficient([lab for lab, d in zip(labels, dead) if d], int(np.sum(~dead)), len(labels))


def check_count(equations: int, unknowns: int) -> None:
    """At least as many scalar equations as unknowns."""
    if equations < unknowns:
        raise IdentificationError(f"fewer equations ({equations}) than unknowns ({unknowns}): use more "
                                  "sample times or more sensors", field="samples")
