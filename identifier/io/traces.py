"""Reader of trace files (HDF5, ``docs/trace-format.md``).

Reads only what an experimenter recorded: never ``truth.json``. Every error
names the file and the missing dataset or attribute.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
from h5py import h5d, h5o
import numpy as np

from structbench.models.channels import QUANTITIES, TRACE_FORMAT

from ..errors import IdentificationError
from .hdf5_reads import attributes, samples

CHANNEL_ATTRS = ("quantity", "unit", "node", "direction")
CHANNEL_FIELDS = CHANNEL_ATTRS + ("location", "noise_ratio", "noise_mode")  # the attributes a Channel keeps


@dataclass(frozen=True)
class Channel:
    """One logged signal: ``data`` (n,) in SI units at (``node``, ``direction``).

    ``location`` (m, shape (3,)) is NaN where the trace does not give it;
    ``noise_ratio`` and ``noise_mode`` are the sensor's declared noise
    (``noise_declared`` False when the trace does not declare it).
    """

    name: str
    data: np.ndarray
    quantity: str
    unit: str
    node: int
    direction: str
    location: np.ndarray
    noise_ratio: float = 0.0
    noise_mode: str = "rms"
    noise_declared: bool = True

    @property
    def dof(self) -> tuple[int, str]:
        return (self.node, self.direction)

    def sigma(self) -> np.ndarray:
        """Standard deviation of the declared sensor noise per sample, shape (n,).

        ``rms`` mode: ratio x RMS of the noise-free signal, estimated from the
        noisy record as ``RMS / sqrt(1 + ratio^2)``; ``proportional``: ratio x |x_k|.
        """
        if self.noise_mode == "proportional":
            return self.noise_ratio * np.abs(self.data)
        rms = np.sqrt(np.mean(self.data**2) / (1.0 + self.noise_ratio**2))
        return np.full(self.data.shape, self.noise_ratio * rms)


class _Named:
    """``test``, ``repetition`` and ``structure`` of a trace from its root
    attributes ``attrs`` and its file ``path``."""

    @property
    def test(self) -> str:
        return str(self.attrs.get("test", self.path.stem))

    @property
    def repetition(self) -> int:
        return int(self.attrs.get("repetition", 0))

    @property
    def structure(self) -> str:
        return str(self.attrs.get("structure", ""))


@dataclass(frozen=True)
class TraceInfo(_Named):
    """A trace file and its root attributes, read without the samples (what
    grouping traces into runs needs)."""

    path: Path
    attrs: dict[str, Any]


@dataclass(frozen=True)
class Trace(_Named):
    """One test (and repetition) as recorded.

    ``time`` (n,) s and ``dt`` s; ``step`` is the interval over which forces are
    held (s, ``dt`` unless the file says otherwise); ``channels`` and
    ``excitation`` map names to :class:`Channel`; ``attrs`` are the root
    attributes, ``excitation_attrs`` those of ``/excitation`` (``spec`` parsed
    from JSON), ``noise_attrs`` those of ``/noise``.
    """

    path: Path
    time: np.ndarray
    dt: float
    step: float
    channels: dict[str, Channel]
    excitation: dict[str, Channel]
    attrs: dict[str, Any]
    excitation_attrs: dict[str, Any] = field(default_factory=dict)
    noise_attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def omega(self) -> float:
        """Excitation frequency (rad/s) of a harmonic test."""
        if "omega" not in self.excitation_attrs:
            raise IdentificationError(f"{self.path.name}: /excitation has no attribute 'omega' "
                                      "(not a harmonic test)", field="omega")
        return float(self.excitation_attrs["omega"])

    def select(self, quantity: str) -> list[Channel]:
        """Channels of one quantity, sorted by (node, direction)."""
        return sorted((c for c in self.channels.values() if c.quantity == quantity), key=lambda c: c.dof)

    def channel(self, quantity: str, node: int, direction: str) -> Channel:
        """The channel ``<quantity>_<node>_<direction>``; a clear error if absent."""
        for c in self.channels.values():
            if c.quantity == quantity and c.dof == (node, direction):
                return c
        raise IdentificationError(f"{self.path.name}: missing channel {quantity}_{node}_{direction} "
                                  f"(channels: {', '.join(self.channels) or 'none'})", field="channels")

    def forces(self) -> list[Channel]:
        """Measured force channels if any, else the commanded ``/excitation`` forces."""
        return self.select("force") or [c for c in self.excitation.values() if c.quantity == "force"]

    def require_forces(self) -> list[Channel]:
        """:meth:`forces`, raising :class:`IdentificationError` when there are none."""
        found = self.forces()
        if not found:
            raise IdentificationError(f"{self.path.name}: no force channel and no /excitation force",
                                      field="channels")
        return found


def _number(value: Any, where: str, what: str, kind: type = float) -> Any:
    """``value`` as a finite float (or int), else an error naming ``what``."""
    try:
        number = kind(value)
        if isinstance(value, (bool, str, bytes)) or not np.isfinite(number) or number != value:
            raise ValueError
    except (TypeError, ValueError, OverflowError):
        raise IdentificationError(f"{where}: {what} is {value!r}, expected a finite "
                                  f"{'integer' if kind is int else 'number'}", field=what) from None
    return number


def _samples(parent: h5py.Group, key: str, where: str, name: str) -> tuple[np.ndarray, Any]:
    """A real, finite 1-D dataset ``parent[key]`` as floats, with its low-level identifier."""
    try:
        oid = h5o.open(parent.id, key.encode())
    except KeyError:  # a dangling link: the high-level lookup below says what it is
        oid = None
    data = samples(oid) if isinstance(oid, h5d.DatasetID) else None
    if data is None:  # not a 1-D dataset of numbers (or an enumeration): h5py decides and words the error
        ds = parent.get(key)
        if not isinstance(ds, h5py.Dataset) or ds.dtype.kind not in "iuf" or ds.ndim != 1:
            kind = f"a dataset of {ds.dtype} with shape {ds.shape}" if isinstance(ds, h5py.Dataset) else "a group"
            raise IdentificationError(f"{where}: {name} is {kind}, expected real numbers (1-D)", field=name)
        data, oid = np.asarray(ds[()], dtype=float), ds.id
    bad = np.flatnonzero(~np.isfinite(data))
    if bad.size:
        raise IdentificationError(f"{where}: {name} is {data[bad[0]]} at sample {bad[0]} "
                                  f"({bad.size} non-finite samples)", field=name)
    return data, oid


def _channel(group: h5py.Group, key: str, where: str, n: int, sensor: bool) -> Channel:
    name = f"{group.name}/{key}"
    data, oid = _samples(group, key, where, name)
    attrs = attributes(oid, CHANNEL_FIELDS)
    for field_name in CHANNEL_ATTRS:
        if field_name not in attrs:
            raise IdentificationError(f"{where}: dataset {name} has no attribute {field_name!r}", field=field_name)
    if attrs["quantity"] not in QUANTITIES:
        raise IdentificationError(f"{where}: {name} has quantity {attrs['quantity']!r}; "
                                  f"known: {', '.join(QUANTITIES)}", field="quantity")
    if data.shape != (n,):
        raise IdentificationError(f"{where}: {name} has shape {data.shape}, /time has ({n},)", field=name)
    if sensor and np.ptp(data) == 0:
        raise IdentificationError(f"{where}: {name} is constant ({data[0]}): a dead sensor", field=name)
    try:
        given = np.asarray(attrs.get("location", []), dtype=float).reshape(-1)[:3]
    except (TypeError, ValueError):
        raise IdentificationError(f"{where}: {name} has location {attrs['location']!r}, expected 3 numbers",
                                  field="location") from None
    location = np.zeros(3) if given.size else np.full(3, np.nan)
    location[:given.size] = given
    mode = attrs.get("noise_mode", "rms")
    if mode not in ("rms", "proportional"):
        raise IdentificationError(f"{where}: {name} has noise_mode {mode!r}, expected rms or proportional",
                                  field="noise_mode")
    return Channel(name=key, data=data, quantity=attrs["quantity"],
                   unit=str(attrs["unit"]), node=_number(attrs["node"], where, f"{name} node", int),
                   direction=str(attrs["direction"]), location=location,
                   noise_ratio=_number(attrs.get("noise_ratio", 0.0), where, f"{name} noise_ratio"),
                   noise_mode=mode, noise_declared="noise_ratio" in attrs)


def _group(f: h5py.File, name: str, where: str, sensor: bool, n: int) -> dict[str, Channel]:
    group = f[name]
    if not isinstance(group, h5py.Group):
        raise IdentificationError(f"{where}: /{name} is a dataset, expected a group", field=name)
    return {key: _channel(group, key, where, n, sensor) for key in group}


def _excitation_attrs(f: h5py.File, where: str) -> dict[str, Any]:
    attrs = attributes(f["excitation"].id)
    if isinstance(attrs.get("spec"), str):
        try:
            attrs["spec"] = json.loads(attrs["spec"])
        except ValueError:
            raise IdentificationError(f"{where}: /excitation attribute 'spec' is not JSON", field="spec") from None
    if "omega" in attrs:
        attrs["omega"] = _number(attrs["omega"], where, "/excitation omega")
    return attrs


def _root_attrs(f: h5py.File, where: str) -> dict[str, Any]:
    """The root attributes, ``format`` checked and ``repetition`` an integer."""
    attrs = attributes(f.id)
    if not isinstance(attrs.get("format"), str) or attrs["format"] != TRACE_FORMAT:
        raise IdentificationError(f"{where}: root attribute 'format' is {attrs.get('format')!r}, "
                                  f"expected {TRACE_FORMAT!r}", field="format")
    attrs["repetition"] = _number(attrs.get("repetition", 0), where, "repetition", int)
    return attrs


def _read(f: h5py.File, path: Path) -> Trace:
    where = path.name
    attrs = _root_attrs(f, where)
    for name in ("time", "channels"):
        if name not in f:
            raise IdentificationError(f"{where}: missing dataset or group /{name}", field=name)
    time, _ = _samples(f, "time", where, "/time")
    if time.size < 2 or np.any(np.diff(time) <= 0):
        raise IdentificationError(f"{where}: /time must hold at least two increasing samples", field="time")
    dt = _number(attrs.get("dt", time[1] - time[0]), where, "dt")
    step = _number(attrs.get("step", dt), where, "step")
    if dt <= 0 or step <= 0:
        raise IdentificationError(f"{where}: dt and step must be positive, got {dt} and {step}", field="dt")
    channels = _group(f, "channels", where, True, time.size)
    excitation, excitation_attrs = {}, {}
    if "excitation" in f:
        excitation = _group(f, "excitation", where, False, time.size)
        excitation_attrs = _excitation_attrs(f, where)
    noise_attrs = attributes(f["noise"].id) if "noise" in f else {}
    return Trace(path=path, time=time, dt=dt, step=step, channels=channels, excitation=excitation,
                 attrs=attrs, excitation_attrs=excitation_attrs, noise_attrs=noise_attrs)


def read_trace(path: str | Path) -> Trace:
    """Read one trace file; raises :class:`IdentificationError` naming the
    file and what is missing or unusable: non-finite samples, a constant
    (dead) sensor channel, wrong types or shapes, a damaged file."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            return _read(f, path)
    except (OSError, KeyError, RuntimeError) as err:  # h5py's errors on damaged files
        raise IdentificationError(f"cannot read trace file: {err}", field=str(path)) from None


def read_info(path: str | Path) -> TraceInfo:
    """The root attributes of one trace file (``format`` and ``repetition``
    checked as :func:`read_trace` does), without reading the samples."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            return TraceInfo(path, _root_attrs(f, path.name))
    except (OSError, KeyError, RuntimeError) as err:  # h5py's errors on damaged files
        raise IdentificationError(f"cannot read trace file: {err}", field=str(path)) from None


def read_contents(path: str | Path) -> dict[str, Any]:
    """What one trace file holds, without its samples: test, repetition,
    ``dt`` (s), sample count and duration (s), channel names, the excitation's
    kind and ``omega`` (rad/s, harmonic tests) and the lab file it was
    imported from (``source``, if any); errors as :func:`read_trace`."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            attrs = _root_attrs(f, path.name)
            time = f["time"]
            span = (float(time[-1] - time[0]) if time.shape[0] else 0.0) if time.ndim == 1 else 0.0
            excitation = _excitation_attrs(f, path.name) if "excitation" in f else {}
            info = TraceInfo(path, attrs)
            return {"file": path.name, "test": info.test, "repetition": info.repetition,
                    "dt": _number(attrs.get("dt", 0.0), path.name, "dt"), "samples": int(time.shape[0]),
                    "duration": span, "channels": list(f["channels"]),
                    "excitation": str(excitation.get("kind", "")), "omega": excitation.get("omega")} | (
                {"source": str(attrs["source"])} if "source" in attrs else {})
    except (OSError, KeyError, RuntimeError) as err:  # h5py's errors on damaged files
        raise IdentificationError(f"cannot read trace file: {err}", field=str(path)) from None


def trace_files(source: str | Path | list[str | Path]) -> list[Path]:
    """``DIR/traces/*.h5`` of a campaign folder, ``DIR/*.h5``, or the given files."""
    if isinstance(source, (str, Path)) and Path(source).is_dir():
        folder = Path(source) / "traces" if (Path(source) / "traces").is_dir() else Path(source)
        files = sorted(folder.glob("*.h5"))
        if not files:
            raise IdentificationError(f"no trace files (*.h5) in {folder}", field="traces")
        return files
    paths = [Path(source)] if isinstance(source, (str, Path)) else [Path(p) for p in source]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise IdentificationError(f"no such trace file(s): {', '.join(missing)}", field="traces")
    return paths


def read_traces(source: str | Path | list[str | Path]) -> list[Trace]:
    """All traces of a campaign folder (or the given files), sorted by (test, repetition)."""
    return sorted((read_trace(p) for p in trace_files(source)), key=lambda t: (t.test, t.repetition))


def read_infos(source: str | Path | list[str | Path]) -> list[TraceInfo]:
    """:func:`read_info` of every trace of a campaign folder (or the given
    files), sorted by (test, repetition) as :func:`read_traces` sorts."""
    return sorted((read_info(p) for p in trace_files(source)), key=lambda t: (t.test, t.repetition))
