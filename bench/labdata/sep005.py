"""SDyPy SEP005 time series: a list of channel dictionaries, stored as JSON.

Each channel: ``name``, ``data`` (list of numbers), ``unit_str``, and
``time`` (list, s) or ``fs`` (Hz); optional ``quantity`` (``d``, ``v``,
``a``, ``f``) and ``group``. structbench adds ``node``, ``direction`` (and
writes ``group`` = ``channels`` or ``excitation``); the name is a trace
channel name when structbench wrote the file, else matched against the
sensor map. Written files pass sdypy-sep005's ``assert_sep005``.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from structbench.models.errors import UserError

from .signals import GROUPS, Signal, parse_name

CODES = {"d": "displacement", "v": "velocity", "a": "acceleration", "f": "force"}


def _time(channel: dict[str, Any], n: int, where: str) -> np.ndarray:
    if channel.get("time") is not None:
        time = np.asarray(channel["time"], dtype=np.float64)
        if time.shape != (n,):
            raise UserError(f"'time' has {time.size} values, 'data' {n}", field=where)
        return time
    if not channel.get("fs"):
        raise UserError("neither 'time' nor 'fs': no time axis", field=where)
    return np.arange(n) / float(channel["fs"])


def _signal(file: str, i: int, channel: Any) -> Signal:
    where = f"{file} channel {i + 1}"
    if not isinstance(channel, dict) or "data" not in channel or "name" not in channel:
        raise UserError("not a SEP005 channel (needs 'name', 'data', 'unit_str')", field=where)
    data = np.asarray(channel["data"], dtype=np.float64)
    named = parse_name(str(channel["name"]))
    group = channel.get("group") if channel.get("group") in GROUPS else named.get("group")
    return Signal(file, where, str(channel["name"]), data, _time(channel, data.size, where),
                  channel.get("unit_str") or None, CODES.get(channel.get("quantity")) or named.get("quantity"),
                  channel.get("node", named.get("node")), channel.get("direction", named.get("direction")), group)


def read_sep005(path: str | Path) -> list[Signal]:
    """The channels of a SEP005 JSON file (a list of channel dictionaries)."""
    path = Path(path)
    try:
        channels = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise UserError(f"not JSON: {err}", field=path.name) from None
    if not isinstance(channels, list) or not channels:
        raise UserError("a SEP005 file is a JSON list of channel dictionaries", field=path.name)
    return [_signal(path.name, i, c) for i, c in enumerate(channels)]


def channel_dict(name: str, unit: str, quantity: str, node: int, direction: str, group: str,
                 time: np.ndarray, data: np.ndarray) -> dict[str, Any]:
    """One SEP005 channel with structbench's additions."""
    code = next(k for k, v in CODES.items() if v == quantity)
    return {"name": name, "data": data.tolist(), "unit_str": unit, "time": time.tolist(),
            "fs": 1.0 / float(time[1] - time[0]), "quantity": code, "group": group, "node": node,
            "direction": direction}


def write_sep005(path: str | Path, channels: list[dict[str, Any]]) -> None:
    Path(path).write_text(json.dumps(channels))
