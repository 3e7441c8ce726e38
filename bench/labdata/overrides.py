"""The sensor map's overrides of what a file says about a channel, and the
one error for channels that end up with the same name.

A ``[[channels]]`` entry's ``quantity``, ``node``, ``direction``, ``unit`` and
``sign`` replace the file's (:data:`~.sensor_map.OVERRIDES`); every value
that differs from a value the file gives is an *override*: it is reported
(one line per channel) and kept in the channel's dataset attributes
``overrides`` (JSON ``{"field": {"file": value, "map": value}}``) and
``map_entry`` (``channels[i]`` of the map). Two channels with the same name
(two datasets labelled node 1 +Z, one of them mislabelled at acquisition)
give one :class:`UserError` listing the datasets and the ``[[channels]]``
entries (TOML) that would repair them.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, replace
from typing import Any

from structbench.models.errors import UserError

from .sensor_map import OVERRIDES, SensorMap, map_text
from .signals import Signal


@dataclass(frozen=True)
class Mapped:
    """A file's signal after the sensor map: ``signal`` with the map's values,
    ``entry`` the map entry (``{}`` if none) at ``index``, ``changed`` the
    overridden fields as (file value, map value)."""

    signal: Signal
    original: Signal
    entry: dict[str, Any]
    index: int | None
    changed: dict[str, tuple[Any, Any]]

    def attrs(self) -> dict[str, str]:
        """Dataset attributes recording the overrides (empty when none)."""
        if not self.changed:
            return {}
        return {"overrides": json.dumps({k: {"file": a, "map": b} for k, (a, b) in self.changed.items()}),
                "map_entry": f"channels[{self.index}]"}

    def note(self) -> str:
        """One line for the import's output: where, what changed, which entry."""
        changes = ", ".join(f"{k} {_show(a)} -> {_show(b)}" for k, (a, b) in self.changed.items())
        return f"{self.signal.source} ({self.original.key!r}): {changes} (sensor map channels[{self.index}])"


def _show(value: Any) -> str:
    if isinstance(value, float) and value.is_integer():
        return f"{value:+.0f}"
    return repr(value) if isinstance(value, str) else str(value)


def apply_map(signal: Signal, smap: SensorMap) -> Mapped:
    """``signal`` with its map entry's values; fields the file lacks come from
    the map too (not overrides)."""
    index, entry = smap.match(signal)
    given = {k: entry[k] for k in OVERRIDES if k in entry}
    changed = {k: (getattr(signal, k), v) for k, v in given.items()
               if getattr(signal, k) is not None and getattr(signal, k) != v}
    return Mapped(replace(signal, **given), signal, entry, index, changed)


def duplicate_error(file: str, named: list[tuple[str, Mapped]]) -> UserError:
    """The error for the channel names (``group/name``) that more than one
    signal of ``file`` gets: each name with its datasets, and a
    ``[[channels]]`` entry per later dataset (the first keeps the name) that
    moves it to a free node of its quantity and direction; the node is a
    guess (the lowest free one) the user checks."""
    by_name: dict[str, list[Mapped]] = {}
    for name, mapped in named:
        by_name.setdefault(name, []).append(mapped)
    twice = {n: ms for n, ms in by_name.items() if len(ms) > 1}
    used: dict[tuple[str, str], set[int]] = {}
    for name, mapped in named:
        s = mapped.signal
        used.setdefault((str(s.quantity), str(s.direction)), set()).add(int(s.node or 0))
    parts, entries = [], []
    for name, members in twice.items():
        listed = ", ".join(f"{m.signal.source} ({m.original.key!r})" for m in members)
        parts.append(f"{name} is given by {listed}")
        for m in members[1:]:
            s = m.signal
            taken = used[(str(s.quantity), str(s.direction))]
            node = next(n for n in range(1, len(taken) + 2) if n not in taken)
            taken.add(node)
            entry: dict[str, Any] = {"file": file, "dataset": s.dataset, "node": node}
            if s.direction is not None:
                entry["direction"] = s.direction
            entries.append(entry)
    fix = map_text({}, entries, []).strip()
    return UserError(f"channel(s) {sorted(twice)} appear twice: {'; '.join(parts)}. One of each is mislabelled: "
                     "the sensor map (--map) entry below moves the later dataset(s) to the lowest free node; "
                     f"check that it is the true one, then paste it into the map:\n\n{fix}\n", field=file)
