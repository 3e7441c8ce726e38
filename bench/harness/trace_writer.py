"""Trace files (HDF5, ``docs/trace-format.md``), written atomically.

A :class:`Trace` is serialised to bytes in memory (so a worker on another
machine can return it) and put in place with a temporary file and
``os.replace``: a trace file that exists is complete.
"""
from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import h5py
import numpy as np

from structbench.models.channels import TRACE_FORMAT, TRACE_FORMAT_VERSION, Channel


def software() -> str:
    """``structbench <version>``."""
    try:
        return f"structbench {version('structbench')}"
    except PackageNotFoundError:
        return "structbench unknown"


@dataclass(frozen=True)
class ChannelData:
    """One channel's samples (n,) with what the trace says about it;
    ``attrs`` are further dataset attributes (an import's unit conversion)."""

    channel: Channel
    data: np.ndarray
    location: tuple[float, float, float]
    noise_ratio: float
    noise_mode: str
    attrs: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Trace:
    """Everything one trace file holds (never the truth).

    ``excitation`` holds the commanded (noise-free) forces; ``excitation_attrs``
    and ``noise_attrs`` become the attributes of ``/excitation`` and ``/noise``;
    ``attrs`` are further root attributes (an import's source files).
    """

    campaign: str
    test: str
    group: str
    repetition: int
    structure: str
    fmu_name: str
    fmu_sha256: str
    seed: int
    dt: float
    step: float
    time: np.ndarray
    channels: tuple[ChannelData, ...]
    excitation: tuple[ChannelData, ...]
    excitation_attrs: dict
    noise_attrs: dict
    attrs: dict = field(default_factory=dict)

    def root_attrs(self) -> dict:
        return {"format": TRACE_FORMAT, "format_version": TRACE_FORMAT_VERSION, "campaign": self.campaign,
                "test": self.test, "group": self.group, "repetition": self.repetition,
                "structure": self.structure, "fmu_name": self.fmu_name, "fmu_sha256": self.fmu_sha256,
                "software": software(), "seed": self.seed, "dt": self.dt, "step": self.step} | self.attrs


def _channel(group: h5py.Group, c: ChannelData) -> None:
    ds = group.create_dataset(c.channel.name, data=np.asarray(c.data, dtype=np.float64))
    ds.attrs.update({"quantity": c.channel.quantity, "unit": c.channel.unit, "node": c.channel.node,
                     "direction": c.channel.direction, "location": np.asarray(c.location, dtype=np.float64),
                     "noise_ratio": float(c.noise_ratio), "noise_mode": c.noise_mode})
    _attrs(ds, c.attrs)


def _attrs(obj: h5py.HLObject, attrs: dict) -> None:
    for key, value in attrs.items():
        obj.attrs[key] = json.dumps(value) if isinstance(value, (dict, list)) else value


def trace_bytes(trace: Trace) -> bytes:
    """The HDF5 file image of a trace."""
    buffer = io.BytesIO()
    with h5py.File(buffer, "w", track_order=True) as f:
        _attrs(f, trace.root_attrs())
        f.create_dataset("time", data=np.asarray(trace.time, dtype=np.float64)).attrs["unit"] = "s"
        channels = f.create_group("channels", track_order=True)
        for c in trace.channels:
            _channel(channels, c)
        excitation = f.create_group("excitation", track_order=True)
        _attrs(excitation, trace.excitation_attrs)
        for c in trace.excitation:
            _channel(excitation, c)
        _attrs(f.create_group("noise"), trace.noise_attrs)
    return buffer.getvalue()


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and ``os.replace``."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def write_trace(path: str | Path, trace: Trace) -> None:
    """Write one trace file atomically."""
    write_atomic(Path(path), trace_bytes(trace))
