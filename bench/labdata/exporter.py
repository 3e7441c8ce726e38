"""Export a campaign's traces to the files labs use: UFF 58 (binary or
ASCII), CSV or SEP005 JSON, one file per trace, plus ``sensor-map.toml``
holding what those formats cannot (test, group, repetition, locations,
declared noise, excitation attributes), so that importing the files with
that map gives the traces back.

UFF: one dataset 58 per channel, function type 1 (time response), ID line 1
the channel's path (``channels/acceleration_7_w``), ID line 2 campaign, test
and repetition; the direction code from :data:`UFF_CODES` (0 = scalar for
other names: ID line 1 keeps the name). Even abscissa spacing when the
header's E13.5 increment reproduces the time axis exactly, else (binary
only) the abscissa values themselves.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from structbench.identifier.io.traces import Channel, Trace, read_traces
from structbench.models.errors import UserError

from .csv_files import write_csv
from .sensor_map import map_text
from .sep005 import channel_dict, write_sep005
from .uff58 import Axis, Record58, write_uff58

FORMATS = ("uff58", "csv", "sep005")
SUFFIX = {"uff58": ".uff", "csv": ".csv", "sep005": ".json"}
UFF_CODES = {"x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6, "u": 1, "v": 2, "w": 3, "theta": 5}
UFF_TYPES = {"displacement": 8, "velocity": 11, "acceleration": 12, "force": 13}


def _channels(trace: Trace) -> list[tuple[str, Channel]]:
    return ([(f"channels/{n}", c) for n, c in trace.channels.items()]
            + [(f"excitation/{n}", c) for n, c in trace.excitation.items()])


def _even(time: np.ndarray) -> bool:
    """Whether E13.5 start and increment give back ``time`` bit for bit."""
    start, step = float(f"{time[0]:13.5E}"), float(f"{time[1] - time[0]:13.5E}")
    return bool(np.array_equal(start + np.arange(time.size) * step, time))


def _uff_records(trace: Trace, binary: bool) -> list[Record58]:
    even = not binary or _even(trace.time)
    ids = (f"{trace.attrs.get('campaign', '')} {trace.test} repetition {trace.repetition}")[:80]
    return [Record58(i + 1, (path, ids, "NONE", trace.test[:80], "NONE"), 1, c.node, UFF_CODES.get(c.direction, 0),
                     c.node, UFF_CODES.get(c.direction, 0), Axis(17, (0, 0, 0), "Time", "s"),
                     Axis(UFF_TYPES[c.quantity], (0, 0, 0), c.quantity, c.unit), trace.time, c.data,
                     binary, 4, even)
            for i, (path, c) in enumerate(_channels(trace))]


def _map_entries(trace: Trace, file: str) -> tuple[dict, list[dict]]:
    test = {"file": file, "test": trace.test, "group": str(trace.attrs.get("group", trace.test)),
            "repetition": trace.repetition, "step": trace.step, "seed": int(trace.attrs.get("seed", 0))}
    attrs = dict(trace.excitation_attrs)
    if "spec" in attrs and not isinstance(attrs["spec"], str):
        attrs["spec"] = json.dumps(attrs["spec"])
    test |= {"excitation": attrs, "noise": dict(trace.noise_attrs)}
    channels = [{"file": file, "name": path, "location": [float(v) for v in c.location],
                 "noise_ratio": c.noise_ratio, "noise_mode": c.noise_mode}
                for path, c in _channels(trace)]
    return test, channels


def export_traces(campaign_dir: str | Path, fmt: str, out: str | Path, binary: bool = True) -> list[Path]:
    """Write every trace of ``campaign_dir`` to ``out/<trace>.<uff|csv|json>``
    and ``out/sensor-map.toml``; returns the data files written."""
    if fmt not in FORMATS:
        raise UserError(f"{fmt!r} is not one of {', '.join(FORMATS)}", field="--format")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise UserError("is a file, expected a folder", field="--out")
    traces = read_traces(campaign_dir)
    out.mkdir(parents=True, exist_ok=True)
    written, tests, channels = [], [], []
    for trace in traces:
        path = out / (trace.path.stem + SUFFIX[fmt])
        if fmt == "uff58":
            write_uff58(path, _uff_records(trace, binary), binary)
        elif fmt == "csv":
            write_csv(path, trace.time, [(p, c.unit, c.data) for p, c in _channels(trace)])
        else:
            write_sep005(path, [channel_dict(p, c.unit, c.quantity, c.node, c.direction, p.split("/")[0],
                                             trace.time, c.data) for p, c in _channels(trace)])
        test, entries = _map_entries(trace, path.name)
        tests.append(test)
        channels += entries
        written.append(path)
    first = traces[0]
    top = {"campaign": str(first.attrs.get("campaign", "")), "structure": first.structure}
    (out / "sensor-map.toml").write_text(map_text(top, channels, tests))
    return written
