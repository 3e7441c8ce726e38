"""A measured channel as a lab file gives it, before the sensor map and SI.

Every reader (UFF 58, CSV, SEP005) turns a file into :class:`Signal` records;
the sensor map fills in what the file lacks and the importer converts them
to SI trace channels. Channel names follow the trace format,
``[channels/|excitation/]<quantity>_<node>_<direction>``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np


GROUPS = ("channels", "excitation")
_NAME = re.compile(r"^(?:(channels|excitation)/)?(displacement|velocity|acceleration|force)_(\d+)_(\w+)$")


@dataclass(frozen=True)
class Signal:
    """One channel of a file: ``data`` (n,) in the file's ``unit`` at the
    sample times ``time`` (n,) s; ``key`` is how the file names it (UFF ID line
    1, CSV header, SEP005 ``name``), ``source`` where it is (for messages).
    ``sign`` is -1 when the sensor points along a negative axis. Fields the
    file does not give are None."""

    file: str
    source: str
    key: str
    data: np.ndarray
    time: np.ndarray
    unit: str | None = None
    quantity: str | None = None
    node: int | None = None
    direction: str | None = None
    group: str | None = None
    sign: float = 1.0

    @property
    def dataset(self) -> int | None:
        """The number in ``source`` (UFF dataset, CSV column, SEP005 channel,
        counted from 1), which the sensor map's ``dataset`` matches."""
        last = self.source.rsplit(" ", 1)[-1]
        return int(last) if last.isdigit() else None

    def filled(self, **given: object) -> "Signal":
        """A copy with the fields that are None taken from ``given``."""
        return replace(self, **{k: v for k, v in given.items() if v is not None and getattr(self, k) is None})


def parse_name(name: str) -> dict[str, object]:
    """``group``, ``quantity``, ``node``, ``direction`` of a trace channel name
    (empty when ``name`` is not one)."""
    found = _NAME.match(name.strip())
    if found is None:
        return {}
    group, quantity, node, direction = found.groups()
    return {"group": group, "quantity": quantity, "node": int(node), "direction": direction}


def uniform_dt(time: np.ndarray) -> float | None:
    """The sampling interval of uniformly spaced ``time`` (s), else None.

    The mean interval ``(t[-1] - t[0]) / (n - 1)`` (``t[1] - t[0]`` when the two
    agree to 1e-9) when every sample lies within ``1e-3 dt + 1e-5 max|t|`` of
    ``t[0] + k dt``, so uneven abscissas printed with E13.5 pass."""
    if time.size < 2:
        return None
    dt = float(time[-1] - time[0]) / (time.size - 1)
    if not dt > 0:
        return None
    deviation = np.abs(time - (time[0] + np.arange(time.size) * dt)).max()
    if deviation > 1e-3 * dt + 1e-5 * np.abs(time).max():
        return None
    first = float(time[1] - time[0])
    return first if abs(first - dt) <= 1e-9 * dt else dt
