"""Import measured files into a trace folder (``docs/trace-format.md``).

One input file becomes one trace file (one test): its channels go to
``/channels`` (or ``/excitation`` for commanded forces), converted to SI
from the file's own unit fields, with the conversion in each dataset's
attributes (``source``, ``source_unit``, ``si_factor``, ``sign``). The
folder is built beside ``--out`` and renamed at the end, so a failure leaves
nothing half-written.
"""
from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from structbench.models.channels import ROTATIONS, Channel
from structbench.harness.trace_writer import ChannelData, Trace, trace_bytes, write_atomic
from structbench.models.errors import UserError

from .csv_files import read_csv
from .geometry import FILE_NAME, Geometry, check_nodes
from .overrides import Mapped, apply_map, duplicate_error
from .sensor_map import UFF_DIRECTIONS, SensorMap, load_map
from .sep005 import read_sep005
from .signals import Signal, parse_name, uniform_dt
from .uff55 import read_uff55, results_document
from .uff58 import FUNCTION_TYPES, Record58, read_datasets
from .uff_geometry import GEOMETRY_KINDS, read_geometry_datasets
from .uff_spectra import SPECTRAL, frf_parts
from .units import conversion, time_factor

UFF_SUFFIXES = (".uff", ".unv", ".uf")
# UFF specific data type -> quantity (records 8-11 field 1)
UFF_QUANTITIES = {8: "displacement", 11: "velocity", 12: "acceleration", 9: "force", 13: "force"}


def _uff_signal(file: str, record: Record58, smap: SensorMap) -> Signal:
    where = f"{file} dataset {record.index}"
    if record.function_type not in (0, 1):
        raise UserError(f"function type {record.function_type} ("
                        f"{FUNCTION_TYPES.get(record.function_type, 'not a time response')}): only time "
                        "responses (1) can be imported", field=f"{where} record 6")
    if np.iscomplexobj(record.y):
        raise UserError(f"ordinate data type {record.ordinate_type} is complex: not a time response",
                        field=f"{where} record 7")
    if record.abscissa.data_type not in (0, 1, 17):
        raise UserError(f"abscissa data type {record.abscissa.data_type} is not time (17): no time axis",
                        field=f"{where} record 8")
    factor = time_factor(record.abscissa.units or "s", f"{where} record 8")
    time = record.x if factor == 1.0 else record.x * factor
    code = abs(record.direction)
    direction = smap.direction(UFF_DIRECTIONS[code - 1]) if 1 <= code <= 6 else None
    named = parse_name(record.id_lines[0])
    return Signal(file, where, record.id_lines[0], record.y, time, record.ordinate.units or None,
                  UFF_QUANTITIES.get(record.ordinate.data_type) or named.get("quantity"),
                  record.node or named.get("node"), named.get("direction") or direction, named.get("group"),
                  -1.0 if record.direction < 0 else 1.0)


@dataclass
class FileParts:
    """What one file holds: time ``signals`` (UFF 58, CSV, SEP005), its
    ``geometry`` (UFF 15/2411, 82, 2412, 18/2420; None without), modal
    results ``runs`` (UFF 55) and FRF file arrays ``frfs`` (spectral UFF 58)."""

    signals: list[Signal]
    geometry: Geometry | None = None
    runs: list[dict] = field(default_factory=list)
    frfs: list[dict] = field(default_factory=list)


def read_file(path: Path, smap: SensorMap) -> FileParts:
    """The parts of one file, by its suffix (.uff/.unv, .csv, .json = SEP005)."""
    if not path.is_file():
        raise UserError("no such file", field=str(path))
    suffix = path.suffix.lower()
    if suffix in UFF_SUFFIXES:
        records, others = read_datasets(path)
        kinds = {d.kind for d in others}
        geometry = None
        if kinds & set(GEOMETRY_KINDS):
            unit = conversion(smap.length_unit, "sensor map length_unit") if smap.length_unit else None
            if unit is not None and unit.dimension != "length":
                raise UserError(f"{smap.length_unit!r} is not a length", field="sensor map length_unit")
            geometry = read_geometry_datasets(path.name, others, unit.factor if unit else None)
        runs = read_uff55(path.name, others, smap.directions.get, smap.structure or "") if 55 in kinds else []
        if not (records or geometry or runs):
            raise UserError(f"no dataset 58 (time data), 55 (modes) or geometry (15, 2411, 82, 2412, 18, 2420); "
                            f"found types: {', '.join(str(d.kind) for d in others) or 'none'}", field=path.name)
        spectral = [r for r in records if r.function_type in SPECTRAL]
        return FileParts([_uff_signal(path.name, r, smap) for r in records if r.function_type not in SPECTRAL],
                         geometry, runs, frf_parts(path.name, spectral, smap) if spectral else [])
    if suffix == ".csv":
        return FileParts(read_csv(path))
    if suffix == ".json":
        return FileParts(read_sep005(path))
    raise UserError(f"unknown file type {suffix!r}: .uff/.unv (UFF), .csv or .json (SEP005)", field=path.name)


def read_signals(path: Path, smap: SensorMap) -> list[Signal]:
    """The channels of one file (a file without any is a :class:`UserError`)."""
    signals = read_file(path, smap).signals
    if not signals:
        raise UserError("no time data (UFF dataset 58) in the file", field=path.name)
    return signals


def _channel(mapped: Mapped, time: np.ndarray, nodes: dict[int, np.ndarray] | None = None
             ) -> tuple[str, ChannelData]:
    s, entry = mapped.signal, mapped.entry
    missing = [k for k in ("unit", "node", "direction") if getattr(s, k) is None]
    if missing:
        raise UserError(f"channel {s.key!r} has no {', '.join(missing)}: give them in the sensor map", field=s.source)
    unit = conversion(s.unit, s.source)
    quantity = s.quantity or unit.quantity
    if unit.quantity != quantity:
        raise UserError(f"channel {s.key!r}: unit {s.unit!r} is a {unit.dimension}, not a {quantity}", field=s.source)
    if unit.rotation != (s.direction in ROTATIONS):
        raise UserError(f"channel {s.key!r}: unit {s.unit!r} does not fit direction {s.direction!r}",
                        field=s.source)
    if s.time is not time and (s.data.shape != time.shape or not np.array_equal(s.time, time)):
        raise UserError(f"channel {s.key!r} is not sampled at the file's first channel's times", field=s.source)
    factor = unit.factor * s.sign
    data = s.data if factor == 1.0 else s.data * factor
    group = "excitation" if entry.get("excitation", s.group == "excitation") else "channels"
    attrs = {"source": s.source, "source_unit": unit.label, "si_factor": factor, "sign": s.sign} | mapped.attrs()
    return group, ChannelData(Channel(quantity, int(s.node), str(s.direction)), data,
                              tuple(entry.get("location", (nodes or {}).get(int(s.node), (np.nan,) * 3))),
                              float(entry.get("noise_ratio", 0.0)), str(entry.get("noise_mode", "rms")), attrs)


def build_trace(path: Path, smap: SensorMap, campaign: str, report: Callable[[str], None] | None = None,
                signals: list[Signal] | None = None, nodes: dict[int, np.ndarray] | None = None) -> Trace:
    """The trace of one file (of its ``signals`` when already read);
    ``report`` receives one line per channel the sensor map overrides;
    ``nodes`` (the imported geometry's, m) give the channels' locations
    where the map gives none."""
    signals = read_signals(path, smap) if signals is None else signals
    time = signals[0].time
    dt = uniform_dt(time)
    if dt is None:
        raise UserError(f"channel {signals[0].key!r}: the time axis is not uniformly sampled", field=signals[0].source)
    groups: dict[str, list[ChannelData]] = {"channels": [], "excitation": []}
    named = []
    for signal in signals:
        mapped = apply_map(signal, smap)
        group, data = _channel(mapped, time, nodes)
        groups[group].append(data)
        named.append((f"{group}/{data.channel.name}", mapped))
        if mapped.changed and report is not None:
            report(mapped.note())
    if len({n for n, _ in named}) < len(named):
        raise duplicate_error(path.name, named)
    test = smap.test(path.name)
    name = str(test.get("test", path.stem))
    return Trace(campaign, name, str(test.get("group", name)), int(test.get("repetition", 0)), smap.structure or "",
                 "", "", int(test.get("seed", 0)), dt, float(test.get("step", dt)), time,
                 tuple(groups["channels"]), tuple(groups["excitation"]), dict(test.get("excitation", {})),
                 dict(test.get("noise", {})), {"source": path.name})


def _write_new(path: Path, write: Callable[[Path], object]) -> Path:
    if path.exists():
        raise UserError("exists; import into a folder without it", field=str(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")
    write(tmp)
    tmp.replace(path)
    return path


def _text(text: str) -> Callable[[Path], object]:
    return lambda path: path.write_text(text)


def import_files(files: Sequence[str | Path], out: str | Path, map_file: str | Path | None = None,
                 name: str | None = None, report: Callable[[str], None] | None = None,
                 frf_writer: Callable[[Path, dict], object] | None = None) -> list[Path]:
    """Import ``files`` into the folder ``out``: time data to
    ``out/traces/<file stem>.h5`` (``out`` must be new or empty), geometry to
    ``out/geometry.json`` (docs/geometry-format.md), modal results (UFF 55)
    to ``out/results/uff55-<file stem>.json``, FRFs (spectral UFF 58) to
    ``out/frf/<file stem>[-<force>].h5`` through ``frf_writer(path, arrays)``
    (the API's: this package writes no FRF files); without time data ``out``
    may be an existing campaign folder (to score the modes against its
    truth). Returns the files written, traces first. ``report`` receives one
    line per channel whose fields the sensor map overrides."""
    out = Path(out)
    if not files:
        raise UserError("no input files", field="FILE")
    smap = load_map(map_file)
    campaign = name or smap.campaign or out.name
    paths = [Path(f) for f in files]
    stems = [p.stem for p in paths]
    if len(set(stems)) < len(stems):
        raise UserError("two input files have the same name (without suffix)", field="FILE")
    parts = [read_file(p, smap) for p in paths]
    geometry = None
    for p, fp in zip(paths, parts):
        if fp.geometry is not None:
            geometry = fp.geometry if geometry is None else geometry
            if geometry is not fp.geometry:
                geometry.merge(fp.geometry, p.name)
    if geometry is not None:
        check_nodes(geometry, "FILE")
    nodes = {n: tuple(float(v) for v in xyz) for n, xyz in geometry.nodes.items()} if geometry else None
    traces = [(p.stem, build_trace(p, smap, campaign, report, fp.signals, nodes)) for p, fp in zip(paths, parts)
              if fp.signals]
    writes = {f"results/uff55-{p.stem}.json": _text(json.dumps(results_document(
        fp.runs, campaign, smap.structure or "", p.name), indent=1) + "\n") for p, fp in zip(paths, parts) if fp.runs}
    for p, fp in zip(paths, parts):
        for arrays in fp.frfs:
            if frf_writer is None:
                raise UserError("holds FRFs (UFF 58 function types 2-9): import them through structbench.import_data",
                                field=p.name)
            stem = p.stem if len(fp.frfs) == 1 else f"{p.stem}-{arrays['force']['name']}"
            writes[f"frf/{stem}.h5"] = (lambda a: lambda path: frf_writer(path, a | {"attrs": a["attrs"] | {
                "campaign": campaign}}))(arrays)
    if geometry is not None:
        writes[FILE_NAME] = _text(json.dumps(geometry.document(), indent=1) + "\n")
    if not traces:
        if out.exists() and not out.is_dir():
            raise UserError("is a file, expected a folder", field="--out")
        return [_write_new(out / rel, write) for rel, write in writes.items()]
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise UserError("exists and is not empty; import time data into a new folder", field="--out")
    tmp = out.with_name(f".{out.name}.import-{os.getpid()}")
    try:
        (tmp / "traces").mkdir(parents=True)
        for stem, trace in traces:
            write_atomic(tmp / "traces" / f"{stem}.h5", trace_bytes(trace))
        for rel, write in writes.items():
            _write_new(tmp / rel, write)
        if out.exists():
            out.rmdir()
        tmp.rename(out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return [out / "traces" / f"{stem}.h5" for stem, _ in traces] + [out / rel for rel in writes]
