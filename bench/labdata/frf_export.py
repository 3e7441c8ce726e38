"""FRFs as UFF dataset 58 files: function type 4 (frequency response
function, complex double) and type 6 (coherence, real double), written by
pyuff.

Per response channel of an FRF (``docs/frf-format.md``) two datasets, in
the order of the responses: the FRF, then its coherence. Record 6: response
node and direction code, reference (force) node and direction code
(``x y z rx ry rz`` = 1..6, ``u v w theta`` = 1, 2, 3, 5, others 0).
Record 7: even abscissa spacing (minimum and increment in Hz) when the
header's E13.5 minimum and increment give the lines back exactly, else the
abscissa values (uneven spacing; in ASCII files printed E13.5, in binary
files doubles). Records 8-10: abscissa specific data type 18 (frequency) in ``Hz``;
ordinate 8/11/12 (displacement, velocity, acceleration) with the response's
SI unit; ordinate denominator 13 (force) in ``N`` (``N m`` on rotations).
ID line 1 ``<estimator> <response> / <force>`` (``coherence ...`` for
type 6), line 2 campaign and group, line 3 analysis, window and averages,
line 4 the FRF's unit, line 5 the source file.

Takes any object with the attributes of
:class:`structbench.identifier.io.frf_files.Frf` (this package reads no FRF
files itself: the API hands them over).
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pyuff

from .exporter import UFF_CODES, UFF_TYPES

FREQUENCY = 18  # UFF specific data type of a frequency abscissa


class FrfLike(Protocol):
    """What the export reads of an FRF."""

    frequency: np.ndarray
    frf: np.ndarray
    coherence: np.ndarray
    responses: Sequence[Any]
    force: Any
    estimator: str
    analysis: str
    window: str
    n_averages: np.ndarray
    attrs: dict[str, Any]

    @property
    def units(self) -> list[str]: ...


def _even(frequency: np.ndarray) -> bool:
    """Whether E13.5 minimum and increment give back ``frequency`` bit for bit."""
    if frequency.size < 2:
        return True
    start, step = float(f"{frequency[0]:13.5E}"), float(f"{frequency[1] - frequency[0]:13.5E}")
    return bool(np.array_equal(start + np.arange(frequency.size) * step, frequency))


def frf_sets(frf: FrfLike, binary: bool, source: str = "") -> list[dict[str, Any]]:
    """pyuff dataset dictionaries: per response its FRF (type 4) and coherence (type 6)."""
    f = np.asarray(frf.frequency, dtype=float)
    even = _even(f)
    spacing = {"abscissa_spacing": 1, "abscissa_min": float(f[0]),
               "abscissa_inc": float(f[1] - f[0]) if f.size > 1 else 0.0} if even else \
        {"abscissa_spacing": 0, "abscissa_min": 0.0, "abscissa_inc": 0.0}
    group = f"{frf.attrs.get('campaign', '')} {frf.attrs.get('group', '')}".strip()[:80] or "NONE"
    how = f"{frf.analysis} {frf.window} {int(np.max(frf.n_averages, initial=0))} averages"[:80]
    force_unit = "N m" if UFF_CODES.get(frf.force.direction, 0) in (4, 5, 6) else "N"
    sets = []
    for i, r in enumerate(frf.responses):
        common = dict(binary=int(binary), id2=group, id3=how, id4=frf.units[i][:80], id5=(source or "NONE")[:80],
                      rsp_node=int(r.node), rsp_dir=UFF_CODES.get(r.direction, 0), ref_node=int(frf.force.node),
                      ref_dir=UFF_CODES.get(frf.force.direction, 0), x=f, abscissa_spec_data_type=FREQUENCY,
                      abscissa_axis_units_lab="Hz", **spacing)
        sets.append(pyuff.prepare_58(func_type=4, id1=f"{frf.estimator} {r.name} / {frf.force.name}"[:80],
                                     data=np.asarray(frf.frf[i], dtype=complex),
                                     ordinate_spec_data_type=UFF_TYPES.get(r.quantity, 0),
                                     ordinate_axis_units_lab=r.unit, orddenom_spec_data_type=UFF_TYPES["force"],
                                     orddenom_axis_units_lab=force_unit, **common))
        sets.append(pyuff.prepare_58(func_type=6, id1=f"coherence {r.name} / {frf.force.name}"[:80],
                                     data=np.asarray(frf.coherence[i], dtype=float), ordinate_spec_data_type=0,
                                     ordinate_axis_units_lab="1", orddenom_spec_data_type=0,
                                     orddenom_axis_units_lab="1", **common))
    return sets


def write_frf_uff58(path: str | Path, frf: FrfLike, binary: bool = True, source: str = "") -> Path:
    """Write ``frf`` to the UFF file ``path`` (replaced if present); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.unlink(missing_ok=True)  # pyuff 2.5's "overwrite" loses a binary file's first dataset: "add" to a new file
    pyuff.UFF(str(path)).write_sets(frf_sets(frf, binary, source), "add")
    return path
