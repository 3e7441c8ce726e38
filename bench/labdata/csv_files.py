"""CSV time records: a header row, then one row per sample.

The first column is the time axis, each other column one channel. A header
cell is ``name`` or ``name [unit]``: the name is matched against the sensor
map (or is a trace channel name, ``acceleration_7_w``, with ``excitation/``
in front for a commanded force), the unit in brackets is the file's unit
(converted to SI; the time column's unit defaults to ``s``). Comma
separated, ``.`` as the decimal mark, no quoting.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from structbench.models.errors import UserError

from .signals import Signal, parse_name
from .units import time_factor

_HEADER = re.compile(r"^\s*(.*?)\s*(?:\[(.*)\])?\s*$")
TIME_NAMES = ("time", "t")


def _header(cell: str) -> tuple[str, str | None]:
    name, unit = _HEADER.match(cell).groups()
    return name, (unit.strip() if unit else None)


def read_csv(path: str | Path) -> list[Signal]:
    """The channels of a CSV file (data in the file's units)."""
    path = Path(path)
    with open(path, encoding="utf-8") as f:
        header = [_header(c) for c in f.readline().rstrip("\r\n").split(",")]
    if len(header) < 2:
        raise UserError("line 1: the header needs a time column and at least one channel", field=path.name)
    (time_name, time_unit), columns = header[0], header[1:]
    if time_name.lower() not in TIME_NAMES:
        raise UserError(f"line 1: the first column is {time_name!r}, not the time axis (header 'time [s]')",
                        field=path.name)
    try:
        table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=np.float64)
    except ValueError as err:
        raise UserError(f"malformed data: {err}", field=path.name) from None
    if table.shape[1] != len(header) or table.shape[0] < 2:
        raise UserError(f"{table.shape[0]} rows of {table.shape[1]} values; the header names {len(header)} "
                        "columns and a record needs two rows at least", field=path.name)
    time = table[:, 0] * time_factor(time_unit or "s", f"{path.name} column 1")
    return [Signal(path.name, f"{path.name} column {j + 2}", name, table[:, j + 1].copy(), time, unit,
                   **parse_name(name))
            for j, (name, unit) in enumerate(columns)]


def write_csv(path: str | Path, time: np.ndarray, columns: list[tuple[str, str, np.ndarray]]) -> None:
    """``time [s]`` then ``name [unit]`` per column; values with 17
    significant digits (exact round trip)."""
    header = ",".join(["time [s]"] + [f"{name} [{unit}]" for name, unit, _ in columns])
    table = np.column_stack([time] + [data for _, _, data in columns])
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.17g")
