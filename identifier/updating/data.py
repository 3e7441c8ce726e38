"""Identified modal data for model updating: from a ``modal`` results file
(docs/results-format.md) or a modal-data file a lab hands over
(docs/modal-data-format.md).

:class:`ModalData` holds ``k`` modes at ``m`` DOF: eigenvalues ``lam`` (k,)
rad^2/s^2 and their standard errors ``lam_std`` (k,) (NaN: not stated),
shapes ``shapes`` (m, k) at ``dofs`` (a column of NaN: a mode without a
shape) in any scaling and sign, and their standard errors ``shape_std``
(m, k) in the units of that column (NaN: not stated).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import IdentificationError
from ..io.json_checks import load_json

FORMAT = "structbench-modal-data"
QUANTITIES = ("displacement", "velocity", "acceleration")


@dataclass
class ModalData:
    """Measured modes (see the module docstring); ``source`` names the file."""

    lam: np.ndarray
    lam_std: np.ndarray
    shapes: np.ndarray
    shape_std: np.ndarray
    dofs: list[tuple[int, str]]
    source: str = ""

    @property
    def omega(self) -> np.ndarray:
        return np.sqrt(self.lam)

    def select(self, modes: list[int] | None) -> "ModalData":
        """Only the modes ``modes`` (0-based, in this order)."""
        if modes is None:
            return self
        idx = np.asarray(modes, dtype=int)
        if idx.size == 0 or idx.min() < 0 or idx.max() >= self.lam.size:
            raise IdentificationError(f"modes {list(modes)} outside the {self.lam.size} modes of {self.source}",
                                      field="modes")
        return ModalData(self.lam[idx], self.lam_std[idx], self.shapes[:, idx], self.shape_std[:, idx],
                         self.dofs, self.source)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise IdentificationError(f"expected a finite number, got {value!r}", field=where)
    return float(value)


def _dof(value: Any, where: str) -> tuple[int, str]:
    if (isinstance(value, list) and len(value) == 2 and isinstance(value[0], int)
            and not isinstance(value[0], bool) and isinstance(value[1], str)):
        return int(value[0]), value[1]
    raise IdentificationError(f"expected [node, direction] such as [7, \"x\"], got {value!r}", field=where)


def channel_dof(name: str) -> tuple[int, str]:
    """``(node, direction)`` of a channel name ``<quantity>_<node>_<direction>``."""
    quantity, _, rest = name.partition("_")
    node, _, direction = rest.partition("_")
    if quantity not in QUANTITIES or not node.isdigit() or not direction:
        raise IdentificationError(f"sensor {name!r} is not <quantity>_<node>_<direction>", field="sensors")
    return int(node), direction


def from_document(doc: dict[str, Any], source: str = "") -> ModalData:
    """A modal-data document (docs/modal-data-format.md) as :class:`ModalData`."""
    where = source or "modal data"
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise IdentificationError(f"{where}: not a modal-data file (format must be {FORMAT!r})", field="format")
    dofs = [_dof(d, f"dofs[{i}]") for i, d in enumerate(doc.get("dofs") or [])]
    modes = doc.get("modes")
    if not isinstance(modes, list) or not modes:
        raise IdentificationError(f"{where}: no modes", field="modes")
    m, k = len(dofs), len(modes)
    lam, lam_std = np.empty(k), np.full(k, np.nan)
    shapes, shape_std = np.full((m, k), np.nan), np.full((m, k), np.nan)
    for i, mode in enumerate(modes):
        at = f"modes[{i}]"
        if not isinstance(mode, dict):
            raise IdentificationError(f"{where}: expected an object", field=at)
        unknown = sorted(set(mode) - {"omega", "omega_std", "shape", "shape_std"})
        if unknown:
            raise IdentificationError(f"{where}: unknown key(s) {unknown}", field=at)
        omega = _number(mode.get("omega"), f"{at}.omega")
        if omega <= 0:
            raise IdentificationError(f"{where}: omega must be positive (rad/s), got {omega}", field=f"{at}.omega")
        lam[i] = omega**2
        if mode.get("omega_std") is not None:
            lam_std[i] = 2 * omega * _number(mode["omega_std"], f"{at}.omega_std")
        if mode.get("shape") is not None:
            shape = mode["shape"]
            if not isinstance(shape, list) or len(shape) != m:
                raise IdentificationError(f"{where}: a shape needs one number per entry of dofs ({m})",
                                          field=f"{at}.shape")
            shapes[:, i] = [_number(v, f"{at}.shape[{j}]") for j, v in enumerate(shape)]
            std = mode.get("shape_std")
            if std is not None:
                std = [std] * m if not isinstance(std, list) else std
                if len(std) != m:
                    raise IdentificationError(f"{where}: shape_std needs one number or one per dof",
                                              field=f"{at}.shape_std")
                shape_std[:, i] = [_number(v, f"{at}.shape_std[{j}]") for j, v in enumerate(std)]
    return ModalData(lam, lam_std, shapes, shape_std, dofs, source)


def from_run(run: dict[str, Any], source: str = "") -> ModalData:
    """One run of a ``modal`` (or ``rayleigh``) results file: ``omega``,
    ``omega_std`` (rad/s), ``mode_shapes`` over ``sensors`` and their
    standard errors ``mode_shapes_std`` (NaN where absent: a ``rayleigh``
    or imported file, or a mode without them)."""
    where = source or "modal results"
    omega = np.asarray(run.get("omega") or [], dtype=float)
    if omega.size == 0:
        raise IdentificationError(f"{where}: the run holds no modes", field="omega")
    quantity = (run.get("details") or {}).get("quantity")
    if quantity == "mixed":
        raise IdentificationError(f"{where}: its shapes mix sensor quantities, which are not comparable entry by "
                                  "entry; identify the modes with one quantity (--option quantity=...)",
                                  field="details.quantity")
    sensors = list(run.get("sensors") or [])
    dofs = [channel_dof(s) for s in sensors]
    shapes = np.asarray(run.get("mode_shapes") or [], dtype=float)
    shapes = shapes.T if shapes.size else np.full((len(dofs), omega.size), np.nan)
    if shapes.shape != (len(dofs), omega.size):
        raise IdentificationError(f"{where}: mode_shapes do not match omega and sensors", field="mode_shapes")
    std = np.asarray(run.get("omega_std") or [np.nan] * omega.size, dtype=float)
    shape_std = np.asarray(run.get("mode_shapes_std") or [], dtype=float)
    shape_std = shape_std.T if shape_std.shape == shapes.T.shape else np.full_like(shapes, np.nan)
    keep = omega > 0
    return ModalData(omega[keep] ** 2, (2 * omega * std)[keep], shapes[:, keep], shape_std[:, keep], dofs, source)


def load(path: str | Path, tests: list[str] | None = None, repetition: int | None = None) -> ModalData:
    """A modal-data file, or the run of a results file whose ``tests`` equal
    ``tests`` and whose ``repetition`` is ``repetition`` (either alone where
    the other is None or matches no run; a file of one run: that run)."""
    path = Path(path)
    doc = load_json(path)
    if isinstance(doc, dict) and doc.get("format") == "structbench-result":
        runs = doc.get("runs") or []
        same_tests = [r for r in runs if tests is not None and sorted(r.get("tests", [])) == sorted(tests)]
        same_rep = [r for r in runs if repetition is not None and r.get("repetition") == repetition]
        chosen = [r for r in same_tests if r in same_rep] or same_tests or same_rep
        chosen = chosen or (runs if len(runs) == 1 else [])
        if not chosen:
            raise IdentificationError(f"{path}: no run of tests {tests} or repetition {repetition} among its "
                                      f"{len(runs)} runs", field="modal")
        return from_run(chosen[0], f"{path.name} (repetition {chosen[0].get('repetition')})")
    return from_document(doc, str(path.name))
