"""Excitation of a test: forces at (node, direction) as functions of time,
initial conditions, actuator noise on amplitude and frequency, the
realisation of a random force per repetition, and recorded signals read from
files (CSV, UFF 58, HDF5): shaker drives, and ground accelerations as
equivalent nodal forces.

Forces are evaluated on the FMU communication grid ``t`` (s, shape (n,)) and
held over each communication step; several items at one DOF add up.
"""
from __future__ import annotations

import dataclasses
import hashlib
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from .disturbance import Disturbance
from .noise import derived_seed

Dof = tuple[int, str]


def ramp_envelope(t: np.ndarray, ramp: float) -> np.ndarray:
    """Soft start from 0 to 1 over ``ramp`` s: ``s - sin(2 pi s) / (2 pi)`` with
    ``s = t / ramp`` (zero slope at both ends, so little free vibration is
    excited); 1 from ``t = ramp`` on (and everywhere when ``ramp`` is 0)."""
    if ramp <= 0:
        return np.ones_like(t)
    s = np.clip(t / ramp, 0.0, 1.0)
    return s - np.sin(2 * np.pi * s) / (2 * np.pi)


@dataclass(frozen=True)
class Harmonic:
    """``A cos(omega t + phase)`` N (N m on rotations) after a soft-start ramp.

    ``settle`` (s) is the wait after the ramp before the analysis window; the
    window starts at ``ramp + settle``.
    """

    kind: ClassVar[str] = "harmonic"
    node: int
    direction: str
    amplitude: float
    omega: float
    phase: float = 0.0
    ramp: float = 0.0
    settle: float = 0.0

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        return self.amplitude * ramp_envelope(t, self.ramp) * np.cos(self.omega * t + self.phase)

    def perturbed(self, gain: float, omega_gain: float) -> "Harmonic":
        return dataclasses.replace(self, amplitude=self.amplitude * gain, omega=self.omega * omega_gain)

    @property
    def window_start(self) -> float:
        return self.ramp + self.settle


@dataclass(frozen=True)
class Impulse:
    """An impulse of ``impulse`` N s at ``time`` s.

    ``method = "pulse"``: a rectangular force ``impulse / dt`` over one
    sampling interval ``dt`` from ``time``. ``"initial-velocity"``: the exact
    impulse at t = 0 as initial velocities (``M^-1 I e``; modal FMUs
    ``qd0_r = I phi_r(x)``); no force input.
    """

    kind: ClassVar[str] = "impulse"
    node: int
    direction: str
    impulse: float
    time: float = 0.0
    method: str = "pulse"

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        if self.method != "pulse":
            return np.zeros_like(t)
        eps = 1e-9 * dt
        on = (t >= self.time - eps) & (t < self.time + dt - eps)
        return np.where(on, self.impulse / dt, 0.0)

    def perturbed(self, gain: float, omega_gain: float) -> "Impulse":
        return dataclasses.replace(self, impulse=self.impulse * gain)


@dataclass(frozen=True)
class RandomForce:
    """Band-limited Gaussian force of RMS ``rms`` N over ``band`` (rad/s):
    white noise from ``default_rng(seed)`` on the communication grid, cut to
    the band by FFT and scaled to the exact RMS over the record.
    ``per_repetition``: every repetition draws a realisation of its own
    (ambient, operational excitation; see :func:`realisations`); otherwise
    every repetition replays the same signal, as a shaker drive file would."""

    kind: ClassVar[str] = "random"
    node: int
    direction: str
    rms: float
    band: tuple[float, float]
    seed: int
    per_repetition: bool = False

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        n = t.size
        step = float(t[1] - t[0]) if n > 1 else dt
        spectrum = np.fft.rfft(np.random.default_rng(self.seed).standard_normal(n))
        omega = 2 * np.pi * np.fft.rfftfreq(n, step)
        spectrum[(omega < self.band[0]) | (omega > self.band[1])] = 0.0
        x = np.fft.irfft(spectrum, n)
        rms = np.sqrt(np.mean(x**2))
        return self.rms * x / rms if rms > 0 else x

    def perturbed(self, gain: float, omega_gain: float) -> "RandomForce":
        return dataclasses.replace(self, rms=self.rms * gain)


@dataclass(frozen=True)
class Initial:
    """Initial displacement (m or rad) and velocity (m/s or rad/s) at one DOF;
    the other DOF start at rest."""

    kind: ClassVar[str] = "initial"
    node: int
    direction: str
    displacement: float = 0.0
    velocity: float = 0.0

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        return np.zeros_like(t)

    def perturbed(self, gain: float, omega_gain: float) -> "Initial":
        return self


@dataclass(frozen=True)
class RecordedForce:
    """``scale`` times a recorded force (N) at one DOF: ``signal`` is the
    file's channel in SI, resampled to the test's communication ``step`` from
    t = 0 (its first sample at ``time`` s, zero outside the record);
    ``sha256`` of ``signal`` stands for it in comparisons and the trace's spec."""

    kind: ClassVar[str] = "recorded"
    node: int
    direction: str
    file: str
    channel: str
    unit: str
    scale: float
    time: float
    step: float
    sha256: str
    signal: np.ndarray = field(compare=False, repr=False, metadata={"spec": False})

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        k = np.rint(t / self.step).astype(np.int64)
        inside = (k >= 0) & (k < self.signal.size)
        out = np.zeros_like(t)
        out[inside] = self.scale * self.signal[k[inside]]
        return out

    def perturbed(self, gain: float, omega_gain: float) -> "RecordedForce":
        return dataclasses.replace(self, scale=self.scale * gain)


@dataclass(frozen=True)
class GroundForce(RecordedForce):
    """The equivalent force ``-(M r)_i scale a_g(t)`` at one DOF of a recorded
    ground acceleration ``a_g`` (``signal``, m/s^2): ``mass`` is ``(M r)_i``
    (kg), ``r`` the structure's rigid translation in the ground's direction."""

    kind: ClassVar[str] = "ground"
    mass: float = 0.0

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        return -self.mass * super().force(t, dt)


Excitation = Harmonic | Impulse | RandomForce | Initial | RecordedForce | Disturbance


def is_force(item: Excitation) -> bool:
    """Does the item need a force input to the FMU?"""
    return (isinstance(item, (Harmonic, RandomForce, RecordedForce, Disturbance))
            or (isinstance(item, Impulse) and item.method == "pulse"))


def force_dofs(items: tuple[Excitation, ...]) -> list[Dof]:
    """DOF that receive a force, in order of first appearance."""
    return list(dict.fromkeys((i.node, i.direction) for i in items if is_force(i)))


def forces(items: tuple[Excitation, ...], dofs: list[Dof], t: np.ndarray, dt: float) -> np.ndarray:
    """Force at each of ``dofs`` on the grid ``t``, shape (n, len(dofs)), N."""
    out = np.zeros((t.size, len(dofs)))
    column = {d: j for j, d in enumerate(dofs)}
    for item in items:
        if is_force(item):
            out[:, column[(item.node, item.direction)]] += item.force(t, dt)
    return out


def perturb(items: tuple[Excitation, ...], rng: np.random.Generator, amplitude_ratio: float,
            frequency_ratio: float) -> tuple[Excitation, ...]:
    """Actuator noise: each item's amplitude times ``1 + amplitude_ratio z1``
    and frequency times ``1 + frequency_ratio z2``, two standard normal draws
    per item in order (drawn for every item, so the stream does not depend on
    the kinds), constant over the test."""
    z = rng.standard_normal((len(items), 2))
    return tuple(item.perturbed(1 + amplitude_ratio * za, 1 + frequency_ratio * zf)
                 for item, (za, zf) in zip(items, z))


def realisations(items: tuple[Excitation, ...], repetition: int) -> tuple[Excitation, ...]:
    """The excitation of one repetition: a random force with ``per_repetition``
    gets the seed ``derived_seed(seed, "repetition", repetition)``; every
    other item is the same in every repetition."""
    return tuple(dataclasses.replace(i, seed=derived_seed(i.seed, "repetition", repetition))
                 if isinstance(i, RandomForce) and i.per_repetition else i for i in items)


def varies(items: tuple[Excitation, ...]) -> bool:
    """Does the excitation differ from one repetition to the next?"""
    return any(isinstance(i, RandomForce) and i.per_repetition for i in items)


def kind_label(items: tuple[Excitation, ...]) -> str:
    """``harmonic``, ``impulse+initial``, ...: the kinds in order, joined by ``+``."""
    return "+".join(dict.fromkeys(i.kind for i in items))


def spec(item: Excitation) -> dict:
    """The item as a JSON-ready dict with its ``kind`` (a recorded signal by its sha256)."""
    return {"kind": item.kind, **{f.name: getattr(item, f.name) for f in dataclasses.fields(item)
                                  if f.metadata.get("spec", True)}}


# ---- recorded signals --------------------------------------------------------
G = 9.80665  # m/s^2 per g
SIGNAL_UNITS = {  # quantity -> unit label -> factor to SI
    "force": {"N": 1.0, "kN": 1e3, "mN": 1e-3, "lbf": 4.4482216152605, "kgf": G},
    "acceleration": {"m/s^2": 1.0, "mm/s^2": 1e-3, "cm/s^2": 1e-2, "gal": 1e-2, "Gal": 1e-2, "in/s^2": 0.0254,
                     "ft/s^2": 0.3048, "g": G, "G": G},
}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
SIGNAL_FILES = {".csv": "csv", ".uff": "uff", ".unv": "uff", ".uf": "uff", ".h5": "hdf5", ".hdf5": "hdf5"}


class SignalFileError(ValueError):
    """A recorded signal that cannot be used (the message names the file's part)."""


@dataclass(frozen=True)
class Recording:
    """One channel of a signal file: ``values`` in SI every ``dt`` s."""

    channel: str
    unit: str
    values: np.ndarray
    dt: float


def normalize_unit(label: str) -> str:
    """``m/s²``, ``m/s**2``, ``m/sec^2``, ``m/s2`` -> ``m/s^2``."""
    text = label.strip().replace("²", "^2").replace("**", "^").replace("µ", "u")
    return re.sub(r"/s2$", "/s^2", re.sub(r"sec\b", "s", text))


def _pick(names: list[str], channel: str | None, what: str) -> int:
    if channel is None:
        if len(names) != 1:
            raise SignalFileError(f"holds {len(names)} {what} ({', '.join(names[:6])}); name one with channel")
        return 0
    if channel not in names:
        raise SignalFileError(f"no {what[:-1]} {channel!r}; it holds {', '.join(names[:6]) or 'none'}")
    return names.index(channel)


def _csv(path: Path, channel: str | None) -> tuple[str, str | None, np.ndarray, np.ndarray]:
    header = path.open(encoding="utf-8").readline().strip().split(",")
    columns = [re.fullmatch(r"\s*(.*?)\s*(?:\[(.*)\])?\s*", h).groups() for h in header]
    if len(columns) < 2 or columns[0][0].lower() not in ("time", "t"):
        raise SignalFileError("expected a header row 'time [s],NAME [UNIT],...'")
    j = 1 + _pick([c[0] for c in columns[1:]], channel, "columns")
    try:
        table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, encoding="utf-8")
    except ValueError as err:
        raise SignalFileError(f"not a table of numbers: {err}") from None
    time_unit = normalize_unit(columns[0][1] or "s")
    if time_unit not in TIME_UNITS:
        raise SignalFileError(f"time column: unknown unit {time_unit!r}; known: {', '.join(TIME_UNITS)}")
    return columns[j][0], columns[j][1], table[:, 0] * TIME_UNITS[time_unit], table[:, j]


def _uff_label(dataset: dict, key: str) -> str | None:
    """A UFF 58 units label, ``None`` when blank or ``NONE`` (UFF writers' empty label)."""
    label = str(dataset.get(key, "")).strip()
    return None if label.upper() in ("", "NONE") else label


def _uff(path: Path, channel: str | None) -> tuple[str, str | None, np.ndarray, np.ndarray]:
    import pyuff
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as err:  # pyuff raises bare Exceptions on malformed files
        raise SignalFileError(f"not a readable UFF file: {err}") from None
    sets = [s for s in (sets if isinstance(sets, list) else [sets]) if s.get("type") == 58]
    d = sets[_pick([str(s.get("id1", "")).strip() for s in sets], channel, "datasets (58, ID line 1)")]
    if d.get("func_type") not in (0, 1):
        raise SignalFileError(f"dataset {d.get('id1')!r} is function type {d.get('func_type')}, not a time record")
    time_unit = normalize_unit(_uff_label(d, "abscissa_axis_units_lab") or "s")
    if time_unit not in TIME_UNITS:
        raise SignalFileError(f"abscissa unit {time_unit!r} is not a time unit")
    unit = _uff_label(d, "ordinate_axis_units_lab")
    return str(d["id1"]).strip(), unit, np.asarray(d["x"], float) * TIME_UNITS[time_unit], np.asarray(d["data"])


def _hdf5(path: Path, channel: str | None) -> tuple[str, str | None, np.ndarray, np.ndarray]:
    import h5py
    try:
        with h5py.File(path, "r") as f:
            names: list[str] = []
            f.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) and name != "time"
                         and obj.ndim == 1 else None)
            dataset = f[names[_pick(names, channel.strip("/") if channel else None, "datasets")]]
            name, values = dataset.name, dataset[()]
            unit = dataset.attrs.get("unit", dataset.attrs.get("units"))
            if "dt" in dataset.attrs or "dt" in f.attrs:
                dt = float(dataset.attrs.get("dt", f.attrs.get("dt")))
                time = np.arange(values.size) * dt
            elif "time" in f:
                time = f["time"][()]
            else:
                raise SignalFileError(f"{name}: no sampling (a dt attribute or a /time dataset)")
    except OSError as err:
        raise SignalFileError(f"not a readable HDF5 file: {err}") from None
    unit = unit.decode() if isinstance(unit, bytes) else unit
    return name, None if unit is None else str(unit), time, values


def read_recording(path: Path, channel: str | None, quantity: str, unit: str | None = None) -> Recording:
    """The channel ``channel`` (the only one when None) of a CSV, UFF 58 or
    HDF5 file as a ``quantity`` (``force`` or ``acceleration``) in SI, its
    unit from the file or, overriding it, ``unit``; uniform sampling."""
    reader = SIGNAL_FILES.get(path.suffix.lower())
    if reader is None:
        raise SignalFileError(f"unknown signal file type {path.suffix!r}; known: {', '.join(SIGNAL_FILES)}")
    if not path.is_file():
        raise SignalFileError("no such file")
    name, file_unit, time, values = {"csv": _csv, "uff": _uff, "hdf5": _hdf5}[reader](path, channel)
    label = normalize_unit(unit or file_unit or "")
    known = SIGNAL_UNITS[quantity]
    if label not in known:
        said = f"unit {label!r}" if label else "no unit (give unit)"
        raise SignalFileError(f"{name}: {said} is not a {quantity} unit; known: {', '.join(known)}")
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or values.size < 2 or time.shape != values.shape:
        raise SignalFileError(f"{name}: expected at least two samples with their times")
    finite = np.isfinite(values) & np.isfinite(time)
    if not finite.all():
        raise SignalFileError(f"{name}: not finite at sample {int(np.argmin(finite))}")
    dt = (time[-1] - time[0]) / (time.size - 1)
    if not dt > 0 or np.abs(np.diff(time) - dt).max() > 1e-3 * dt + 1e-5 * np.abs(time).max():
        raise SignalFileError(f"{name}: sample times are not uniformly spaced and increasing")
    return Recording(name, label, values * known[label], float(dt))


def resample(recording: Recording, step: float, n: int, start: float = 0.0) -> np.ndarray:
    """``recording`` on the grid ``k step`` (k < n) with its first sample at
    ``start``: linear interpolation, after an FFT low-pass to ``pi / step``
    when the recording is sampled finer than ``step``; zero outside it."""
    x = recording.values
    if recording.dt < step * (1 - 1e-9):
        spectrum = np.fft.rfft(x)
        spectrum[2 * np.pi * np.fft.rfftfreq(x.size, recording.dt) > np.pi / step] = 0.0
        x = np.fft.irfft(spectrum, x.size)
    t = start + np.arange(x.size) * recording.dt
    return np.interp(np.arange(n) * step, t, x, left=0.0, right=0.0)


def digest(signal: np.ndarray) -> str:
    """sha256 (hex) of a resampled signal's float64 bytes."""
    return hashlib.sha256(np.ascontiguousarray(signal, dtype=np.float64).tobytes()).hexdigest()
