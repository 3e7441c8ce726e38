"""The ``[[tests]]`` entries of a campaign file (merged with ``[defaults]``):
excitation, sensors, noise and sampling, validated into :class:`TestSpec`."""
from __future__ import annotations

import math
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from structbench.fmus.spec import parameter_names
from structbench.models import ModalModel, Model
from structbench.models.errors import UserError
from structbench.models.channels import QUANTITIES, ROTATIONS, Channel

from .excitation import (Excitation, GroundForce, Harmonic, Impulse, Initial, RandomForce, RecordedForce,
                         SignalFileError, digest, force_dofs, is_force, perturb, read_recording, realisations,
                         resample, varies)
from . import disturbance
from .external import VariableMap
from .noise import MODES, NoiseSpec, actuator_rng, derived_seed
from .toml_lines import Path as KeyPath
from .toml_table import CampaignError, Table


class Reader(Protocol):
    """What the test entries need of the campaign file being read: an error
    at a key path, and recording the FMU variable a (quantity, DOF) needs."""

    def error(self, key: KeyPath, message: str) -> CampaignError: ...

    def want(self, key: KeyPath, mapping: VariableMap, quantity: str, node: int, direction: str) -> None: ...

    path: Path  # the campaign file (recorded signals' paths are relative to it)

    def parameters(self, model: Model | None, fmu: Path | None) -> dict[str, float]: ...

TEST_KEYS = ("name", "description", "dt", "step", "duration", "repetitions", "excitation", "sensors", "noise",
             "timeout")
MAX_STEPS = 1e8  # communication steps of one test (memory: 800 MB per signal)
MAX_REPETITIONS = 100_000
DEFAULT_TIMEOUT = 600.0  # s, wall-clock limit of one task of a test (local workers)
EXCITATION_KEYS = {
    "harmonic": ("kind", "node", "dir", "amplitude", "omega", "phase", "ramp", "settle"),
    "stepped-sine": ("kind", "node", "dir", "amplitude", "omegas", "phase", "ramp", "settle", "window"),
    "impulse": ("kind", "node", "dir", "impulse", "time", "method"),
    "random": ("kind", "node", "dir", "rms", "band", "seed", "realisation"),
    "initial": ("kind", "node", "dir", "displacement", "velocity"),
    "recorded": ("kind", "node", "dir", "file", "channel", "unit", "scale", "time"),
    "ground": ("kind", "dir", "file", "channel", "unit", "scale", "time"),
    "disturbance": disturbance.KEYS,
}
SENSOR_KEYS = ("nodes", "dirs", "quantities")
NOISE_KEYS = ("sensor", "mode", "actuator_amplitude", "actuator_frequency", "seed")
IMPULSE_METHODS = ("pulse", "initial-velocity")
REALISATIONS = ("shared", "per-repetition")  # a random force: replayed, or new in every repetition
TEST_NAME = re.compile(r"^[A-Za-z0-9_-]+$")

@dataclass(frozen=True)
class TestSpec:
    """One test: a simulation of ``duration`` s sampled every ``dt`` s with FMU
    communication step ``step`` s (``dt`` a whole multiple of ``step``)."""

    name: str
    group: str
    dt: float
    step: float
    duration: float
    excitation: tuple[Excitation, ...]
    channels: tuple[Channel, ...]
    noise: NoiseSpec
    repetitions: int
    base_seed: int
    timeout: float = DEFAULT_TIMEOUT

    @property
    def n_samples(self) -> int:
        return round(self.duration / self.dt) + 1

    @property
    def substeps(self) -> int:
        """Communication steps per sampling interval."""
        return round(self.dt / self.step)

    @property
    def force_dofs(self) -> list[tuple[int, str]]:
        return force_dofs(self.excitation)

    def seed(self, repetition: int) -> int:
        """Noise seed of a repetition (see :mod:`structbench.harness.noise`)."""
        return derived_seed(self.base_seed, self.name, repetition)

    @property
    def simulates_each_repetition(self) -> bool:
        """Actuator noise or a per-repetition random force: every repetition
        needs a simulation of its own (else they share one)."""
        return self.noise.actuator or varies(self.excitation)

    def commanded_excitation(self, repetition: int) -> tuple[Excitation, ...]:
        """The excitation a repetition asks for (its random-force realisation)."""
        return realisations(self.excitation, repetition)

    def applied_excitation(self, repetition: int) -> tuple[Excitation, ...]:
        """What the actuators apply in a repetition: the commanded excitation,
        perturbed by actuator noise from that repetition's seed."""
        items = self.commanded_excitation(repetition)
        if not self.noise.actuator:
            return items
        return perturb(items, actuator_rng(self.seed(repetition)), self.noise.actuator_amplitude,
                       self.noise.actuator_frequency)

    def trace_name(self, repetition: int) -> str:
        """``<test>.h5``, or ``<test>.r003.h5`` when the test has repetitions."""
        return f"{self.name}.h5" if self.repetitions == 1 else f"{self.name}.r{repetition:03d}.h5"



class TestReader:
    """One ``[[tests]]`` entry (merged with ``[defaults]``) into TestSpecs."""

    def __init__(self, table: Table, model: Model | None, locations: Mapping[int, Any],
                 mapping: VariableMap, seed: int, reader: Reader):
        self.t, self.model, self.locations, self.mapping, self.reader = table, model, locations, mapping, reader
        table.allow(TEST_KEYS, "a test")
        self.name = table.string("name")
        if not TEST_NAME.match(self.name):
            raise table.error("name", f"{self.name!r}: use letters, digits, '-' and '_' only")
        self.dt = table.number("dt", positive=True)
        self.step = table.number("step", self.dt, positive=True)
        if self.dt < self.step * (1 - 1e-9):
            raise table.error("dt", f"sampling interval {self.dt} s is shorter than the communication step "
                                    f"{self.step} s (the FMU's outputs exist only at communication points)")
        if self.dt / self.step > MAX_STEPS:
            raise table.error("step", f"{self.dt / self.step:.3g} communication steps per sampling interval; "
                                      f"at most {MAX_STEPS:.0e} steps per test")
        if abs(self.dt / self.step - round(self.dt / self.step)) > 1e-6:
            raise table.error("dt", f"sampling interval {self.dt} s is not a whole number of communication "
                                    f"steps ({self.step} s)")
        self.repetitions = table.integer("repetitions", 1, low=1)
        if self.repetitions > MAX_REPETITIONS:
            raise table.error("repetitions", f"at most {MAX_REPETITIONS}, got {self.repetitions}")
        self.timeout = table.number("timeout", DEFAULT_TIMEOUT, positive=True)
        noise = table.table("noise")
        self.noise = self._noise(noise, noise.integer("seed", seed, low=0))

    # ---- pieces ------------------------------------------------------
    def _dof(self, item: Table, node: int, direction: str, key: str) -> None:
        if self.model is None:
            return
        if node not in self.model.nodes:
            ids = sorted(self.model.nodes)
            raise item.error(key, f"unknown node {node} in {self.model.name} (nodes {ids[0]}..{ids[-1]})")
        try:
            self.model.dof_index(node, direction)
        except UserError:
            free = [d for n, d in self.model.dofs if n == node]
            raise item.error(key, f"no free DOF ({node}, {direction!r}) in {self.model.name}; free directions "
                                  f"at node {node}: {free or 'none (supported)'}") from None

    def _noise(self, table: Table, seed: int) -> NoiseSpec:
        table.allow(NOISE_KEYS, "noise")
        sensor = table.get("sensor", 0.0)
        if isinstance(sensor, dict):
            ratios = table.table("sensor")
            ratios.allow(QUANTITIES, "noise.sensor")
            sensor = {q: ratios.number(q, low=0.0) for q in ratios.data}
        else:
            level = table.number("sensor", 0.0, low=0.0)
            sensor = {q: level for q in QUANTITIES} if level else {}
        return NoiseSpec(sensor, table.string("mode", "rms", MODES),
                         table.number("actuator_amplitude", 0.0, low=0.0),
                         table.number("actuator_frequency", 0.0, low=0.0), seed)

    def _excitation(self, item: Table, index: int, duration: float | None
                    ) -> tuple[Excitation | tuple[Excitation, ...], tuple[float, ...], float | None]:
        """An item (a ground motion: one per DOF); for a stepped sine a
        template with its frequencies and window."""
        kind = item.string("kind", choices=tuple(EXCITATION_KEYS))
        item.allow(EXCITATION_KEYS[kind], f"a {kind} excitation")
        if kind == "ground":
            return self._ground(item, duration), (), None
        node, direction = item.integer("node"), item.string("dir")
        self._dof(item, node, direction, "node")
        if kind == "stepped-sine":
            return self._stepped_sine(item, node, direction, duration)
        if kind == "disturbance":  # bench/harness/disturbance.py
            seed = derived_seed(self.noise.seed, self.name, "disturbance", index)
            return disturbance.read(item, node, direction, seed, self.dt), (), None
        build = {"harmonic": self._harmonic, "impulse": self._impulse, "random": self._random,
                 "initial": self._initial, "recorded": self._recorded}[kind]
        return build(item, node, direction, index, duration), (), None

    def _harmonic(self, item: Table, node: int, direction: str, index: int = 0, duration: float | None = None,
                  omega: float | None = None) -> Harmonic:
        return Harmonic(node, direction, item.number("amplitude"),
                        item.number("omega", low=0.0) if omega is None else omega, item.number("phase", 0.0),
                        item.number("ramp", 0.0, low=0.0), item.number("settle", 0.0, low=0.0))

    def _stepped_sine(self, item: Table, node: int, direction: str, duration: float | None
                      ) -> tuple[Harmonic, tuple[float, ...], float | None]:
        omegas = item.get("omegas")
        if not isinstance(omegas, list) or not omegas:
            raise item.error("omegas", "expected a non-empty list of frequencies (rad/s)")
        listed = Table(self.reader, dict(enumerate(omegas)), {}, item.at("omegas"))
        values = tuple(listed.number(i, low=0.0) for i in range(len(omegas)))
        window = item.number("window", low=0.0) if "window" in item.data else None
        if window is None and duration is None:
            raise item.error("window", "a stepped sine needs a window (s) or the test's duration")
        return self._harmonic(item, node, direction, omega=0.0), values, window

    def _impulse(self, item: Table, node: int, direction: str, index: int, duration: float | None) -> Impulse:
        method = item.string("method", "pulse", IMPULSE_METHODS)
        time = item.number("time", 0.0, low=0.0)
        if method == "initial-velocity" and time != 0:
            raise item.error("time", "an initial-velocity impulse acts at t = 0")
        if method == "initial-velocity" and self.model is None:
            raise item.error("method", "initial-velocity impulses need the structure's model; "
                                       "use method = \"pulse\" on an external FMU")
        if duration is not None and time >= duration:
            raise item.error("time", f"impulse at {time} s is after the end of the test ({duration} s)")
        return Impulse(node, direction, item.number("impulse"), time, method)

    def _random(self, item: Table, node: int, direction: str, index: int, duration: float | None) -> RandomForce:
        band = item.get("band")
        nyquist = math.pi / self.dt
        if not (isinstance(band, list) and len(band) == 2 and all(
                isinstance(b, (int, float)) and not isinstance(b, bool) for b in band)
                and 0 <= band[0] < band[1] <= nyquist * (1 + 1e-9)):
            raise item.error("band", f"expected [low, high] rad/s with 0 <= low < high <= pi/dt = {nyquist:g}, "
                                     f"got {band!r}")
        seed = item.integer("seed", derived_seed(self.noise.seed, self.name, "random", index), low=0)
        realisation = item.string("realisation", "shared", choices=REALISATIONS)
        return RandomForce(node, direction, item.number("rms", low=0.0), (float(band[0]), float(band[1])), seed,
                           realisation == "per-repetition")

    def _initial(self, item: Table, node: int, direction: str, index: int, duration: float | None) -> Initial:
        if isinstance(self.model, ModalModel):
            raise item.error("kind", "initial conditions at a point are not defined for a modal model; "
                                     "use an impulse")
        return Initial(node, direction, item.number("displacement", 0.0), item.number("velocity", 0.0))

    def _signal(self, item: Table, quantity: str, duration: float | None) -> tuple[dict[str, Any], np.ndarray]:
        """A recorded signal's fields and its values on the communication grid."""
        if duration is None:
            raise item.error("kind", "a recorded signal needs the test's duration")
        file = item.string("file")
        channel = item.string("channel") if "channel" in item.data else None
        unit = item.string("unit") if "unit" in item.data else None
        try:
            recording = read_recording(self.reader.path.parent / file, channel, quantity, unit)
        except SignalFileError as err:
            raise item.error("file", f"{file}: {err}") from None
        time = item.number("time", 0.0, low=0.0)
        signal = resample(recording, self.step, round(duration / self.step) + 1, time)
        fields = {"file": file, "channel": recording.channel, "unit": recording.unit,
                  "scale": item.number("scale", 1.0), "time": time, "step": self.step, "sha256": digest(signal)}
        return fields, signal

    def _recorded(self, item: Table, node: int, direction: str, index: int, duration: float | None
                  ) -> RecordedForce:
        fields, signal = self._signal(item, "force", duration)
        return RecordedForce(node, direction, **fields, signal=signal)

    def _ground(self, item: Table, duration: float | None) -> tuple[GroundForce, ...]:
        """A ground acceleration in ``dir`` as the forces ``-M r a_g`` at every
        DOF where ``M r`` is not zero (``r``: 1 on the DOF of that direction)."""
        direction = item.string("dir")
        model = self.model
        if model is None or isinstance(model, ModalModel):
            raise item.error("kind", "ground motion needs a finite-element structure's mass matrix "
                                     "(a built-in or TOML structure, not an external FMU or a modal model)")
        directions = sorted({d for _, d in model.dofs})
        if direction not in directions or direction in ROTATIONS:
            raise item.error("dir", f"{direction!r}: not a translation of {model.name} (directions: "
                                    f"{', '.join(directions)})")
        overrides = self.reader.parameters(model, None)  # [parameters]: the structure tested is the true one
        if overrides:
            names = parameter_names(model)
            values = dict(zip(names, model.values)) | overrides
            model = model.with_values(np.array([values[n] for n in names]))
        r = np.array([d == direction for _, d in model.dofs], dtype=float)
        mass = model.mass().toarray() @ r
        fields, signal = self._signal(item, "acceleration", duration)
        return tuple(GroundForce(node, d, **fields, signal=signal, mass=float(m))
                     for (node, d), m in zip(model.dofs, mass) if m != 0.0)

    def _channels(self, force_at: list[tuple[int, str]]) -> dict[Channel, KeyPath]:
        """Channels in order (per sensor entry, quantity-major), each with its key."""
        groups = self.t.tables("sensors")
        if not groups:
            raise self.t.error("sensors", "a test needs at least one [[tests.sensors]] entry")
        channels: dict[Channel, KeyPath] = {}
        for g in groups:
            g.allow(SENSOR_KEYS, "sensors")
            quantities = g.get("quantities")
            if not isinstance(quantities, list) or not quantities:
                raise g.error("quantities", f"expected a list of quantities from {', '.join(QUANTITIES)}")
            for i, q in enumerate(quantities):
                if q not in QUANTITIES:
                    raise self.reader.error(g.at("quantities") + (i,), f"unknown quantity {q!r}; "
                                                                       f"known: {', '.join(QUANTITIES)}")
            dofs = self._sensor_dofs(g)
            for q in quantities:
                for node, direction in dofs:
                    if q == "force" and (node, direction) not in force_at:
                        raise g.error("quantities", f"a load cell (force) at ({node}, {direction!r}) needs a "
                                                    f"force excitation there")
                    channels.setdefault(Channel(q, node, direction), g.where)
        return channels

    def _sensor_dofs(self, g: Table) -> list[tuple[int, str]]:
        nodes = g.get("nodes")
        if nodes == "all":
            nodes = sorted({n for n, _ in self.model.dofs}) if self.model is not None else sorted(self.locations)
        elif not isinstance(nodes, list) or not nodes or not all(
                isinstance(n, int) and not isinstance(n, bool) for n in nodes):
            raise g.error("nodes", f"expected \"all\" or a list of node ids, got {nodes!r}")
        if not nodes:
            raise g.error("nodes", "\"all\" names no node (list the external FMU's nodes in [locations])")
        dirs = g.get("dirs", None)
        if dirs is None and self.model is None:
            raise g.error("dirs", "an external FMU's sensors need their directions (dirs)")
        if dirs is not None and (not isinstance(dirs, list) or not dirs or not all(isinstance(d, str) for d in dirs)):
            raise g.error("dirs", f"expected a list of direction names, got {dirs!r}")
        out = []
        for node in nodes:
            if self.model is not None and node not in self.model.nodes:
                self._dof(g, node, "", "nodes")
            at = [d for n, d in self.model.dofs if n == node] if dirs is None else dirs
            for direction in at:
                self._dof(g, node, direction, "dirs" if dirs is not None else "nodes")
                out.append((node, direction))
        return out

    # ---- assembly ----------------------------------------------------
    def specs(self) -> Iterator[TestSpec]:
        """The entry's tests, one at a time (a stepped sine: one per frequency)."""
        duration = self.t.number("duration", positive=True) if "duration" in self.t.data else None
        items, stepped = [], None
        for j, item in enumerate(self.t.tables("excitation")):
            built, omegas, window = self._excitation(item, j, duration)
            if omegas:
                if stepped is not None:
                    raise item.error("kind", "one stepped sine per test")
                stepped = (len(items), built, omegas, window)
            items.extend(built) if isinstance(built, tuple) else items.append(built)
        if not items:
            raise self.t.error("excitation", "a test needs at least one [[tests.excitation]] entry")
        if stepped is None:
            if duration is None:
                raise self.t.error("duration", "missing (required)")
            yield self._spec(self.name, tuple(items), self._whole(duration, "duration"))
            return
        j, template, omegas, window = stepped
        if duration is None:
            length = template.ramp + template.settle + window
            if length / self.step > MAX_STEPS:
                raise self.t.error("excitation", f"ramp, settle and window ({length:.3g} s) are more than "
                                                 f"{MAX_STEPS:.0e} communication steps")
            duration = math.ceil(length / self.dt - 1e-9) * self.dt
        else:
            duration = self._whole(duration, "duration")
        for k, omega in enumerate(omegas):
            expanded = list(items)
            expanded[j] = Harmonic(template.node, template.direction, template.amplitude, omega,
                                   template.phase, template.ramp, template.settle)
            yield self._spec(f"{self.name}-{k + 1:02d}", tuple(expanded), duration)

    def _whole(self, duration: float, key: str) -> float:
        ratio = duration / self.dt
        if ratio * round(self.dt / self.step) > MAX_STEPS:
            raise self.t.error(key, f"{duration} s at a {self.step} s step are more than {MAX_STEPS:.0e} "
                                    "communication steps")
        if abs(ratio - round(ratio)) > 1e-6 * max(1.0, ratio):
            raise self.t.error(key, f"{duration} s is not a whole number of sampling intervals ({self.dt} s)")
        return round(ratio) * self.dt

    def _spec(self, name: str, items: tuple[Excitation, ...], duration: float) -> TestSpec:
        force_at = force_dofs(items)
        channels = self._channels(force_at)
        for j, item in enumerate(items):
            key = self.t.at("excitation") + (j, "node")
            if is_force(item):
                self.reader.want(key, self.mapping, "force", item.node, item.direction)
            if isinstance(item, Initial):
                for q, v in (("initial_displacement", item.displacement), ("initial_velocity", item.velocity)):
                    if v:
                        self.reader.want(key, self.mapping, q, item.node, item.direction)
        for c, key in channels.items():
            if c.quantity != "force":
                self.reader.want(key, self.mapping, c.quantity, c.node, c.direction)
        return TestSpec(name, self.name, self.dt, self.step, duration, items, tuple(channels), self.noise,
                        self.repetitions, self.noise.seed, self.timeout)


