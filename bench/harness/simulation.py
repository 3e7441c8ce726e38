"""One test on one FMU instance: excitation -> FMU -> sensor noise -> traces.

Sensor noise is added after the simulation, so repetitions that differ only
in sensor noise share one simulation; with actuator noise or a random force
drawn anew per repetition every repetition simulates with its own excitation.
"""
from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from structbench.models.channels import Channel

from .excitation import Excitation, Harmonic, force_dofs, forces, kind_label, spec
from .fmu_setup import Bench
from .noise import noisy_channels
from .output_check import SimulationError, check_output, first_bad  # noqa: F401 - SimulationError re-exported
from .test_entries import TestSpec
from .trace_writer import ChannelData, Trace, trace_bytes, write_atomic


@dataclass(frozen=True)
class Record:
    """Noise-free result of one simulation at the sample times ``time`` (n,):
    ``signals`` per channel name (load cells: the force the structure felt)
    and ``commanded`` forces per excitation name, each (n,)."""

    time: np.ndarray
    signals: dict[str, np.ndarray]
    commanded: dict[str, np.ndarray]


@dataclass
class Outcome:
    """What a worker hands back for one test: trace files as (name, image,
    sha256) (image None when the worker wrote the file itself), the
    noise-free record when asked for, or the error that stopped it."""

    test: str
    files: list[tuple[str, bytes | None, str]] = field(default_factory=list)
    record: Record | None = None
    error: str | None = None


class Rig:
    """One FMU instance set up for a campaign: its parameters are set once,
    initial conditions per run (those of earlier runs back to zero); the
    interface and solver tolerance of ``bench.options``."""

    def __init__(self, bench: Bench):
        from .fmu_session import FmuSession  # imported lazily: workers only

        self.session = FmuSession(bench.fmu, interface=bench.options.interface,
                                  relative_tolerance=bench.options.relative_tolerance)
        if bench.parameters:
            self.session.set_parameters(dict(bench.parameters))
        self.touched: set[str] = set()

    def run(self, inputs: list[str], outputs: list[str], force: np.ndarray, step: float,
            initial: Mapping[str, float], substeps: int = 1) -> np.ndarray:
        """(n_steps, len(outputs)) from a fresh start with ``initial`` set,
        ``substeps`` FMU steps per communication step of ``step`` s."""
        values = {name: 0.0 for name in self.touched} | dict(initial)
        self.session.reset()
        if values:
            self.session.set_parameters(values)
        self.touched |= set(initial)
        return self.session.run(inputs, outputs, force, step, substeps=substeps)

    def close(self) -> None:
        self.session.close()


def _grid(test: TestSpec) -> np.ndarray:
    """Communication times (s) covering the samples ``0 .. duration``."""
    return np.arange((test.n_samples - 1) * test.substeps + 1) * test.step


def commanded(test: TestSpec, items: tuple[Excitation, ...]) -> dict[str, np.ndarray]:
    """The noise-free forces of ``items`` (a repetition's commanded excitation)
    per ``force_<node>_<dir>``, at the sample times."""
    dofs = force_dofs(items)
    f = forces(items, dofs, _grid(test), test.dt)[::test.substeps]
    return {Channel("force", *d).name: f[:, j] for j, d in enumerate(dofs)}


def simulate(rig: Rig, bench: Bench, test: TestSpec, repetition: int) -> Record:
    """Run a repetition's applied excitation and sample every channel; raises
    :class:`SimulationError` when an output is not finite or diverges
    (:mod:`.output_check`), before any noise is added."""
    items = test.applied_excitation(repetition)
    mapping = bench.mapping
    dofs = force_dofs(items)
    force = forces(items, dofs, _grid(test), test.dt)
    motion = [c for c in test.channels if c.quantity != "force"]
    y = rig.run([mapping.variable("force", *d) for d in dofs],
                [mapping.variable(c.quantity, c.node, c.direction) for c in motion],
                force, test.step, bench.initial_values(items), bench.options.substeps)[::test.substeps]
    felt = force[::test.substeps]
    signals = {c.name: y[:, j] for j, c in enumerate(motion)}
    check_output(signals, felt, test.dt)
    signals |= {c.name: felt[:, dofs.index(c.dof)] for c in test.channels if c.quantity == "force"}
    return Record(np.arange(test.n_samples) * test.dt, {c.name: signals[c.name] for c in test.channels},
                  commanded(test, test.commanded_excitation(repetition)))


def _excitation_attrs(items: tuple[Excitation, ...]) -> dict:
    attrs = {"kind": kind_label(items), "spec": json.dumps([spec(i) for i in items])}
    harmonic = next((i for i in items if isinstance(i, Harmonic)), None)
    if harmonic is not None:
        attrs |= {"omega": harmonic.omega, "window_start": harmonic.window_start}
    return attrs


def _noise_attrs(test: TestSpec, seed: int) -> dict:
    noise = test.noise
    ratios = {q: noise.ratio(q) for q in sorted({c.quantity for c in test.channels})}
    return {"sensor_ratio": max(ratios.values(), default=0.0), "sensor_mode": noise.mode,
            "sensor_ratios": json.dumps(ratios), "actuator_amplitude_ratio": noise.actuator_amplitude,
            "actuator_frequency_ratio": noise.actuator_frequency, "seed": seed}


def make_trace(bench: Bench, test: TestSpec, repetition: int, record: Record) -> Trace:
    """The trace of one repetition: ``record`` plus that repetition's sensor noise."""
    seed = test.seed(repetition)
    mode = test.noise.mode
    ratios = {c.name: test.noise.ratio(c.quantity) for c in test.channels}
    noisy = noisy_channels(record.signals, ratios, mode, seed)
    for name, x in noisy.items():  # never a trace with a non-finite sample
        first_bad(f"{test.trace_name(repetition)}: {name}", x, test.dt)
    channels = tuple(ChannelData(c, noisy[c.name], bench.locations[c.node], ratios[c.name], mode)
                     for c in test.channels)
    excitation = tuple(ChannelData(Channel("force", *d), record.commanded[Channel("force", *d).name],
                                   bench.locations[d[0]], 0.0, mode) for d in force_dofs(test.excitation))
    opts = bench.options  # how the FMU ran, when not the default (default traces stay bit-identical)
    driven = {} if (opts.interface, opts.substeps) == ("co-simulation", 1) else (
        {"fmu_interface": opts.interface, "substeps": opts.substeps}
        | ({"relative_tolerance": opts.relative_tolerance} if opts.interface == "model-exchange" else {}))
    return Trace(bench.campaign, test.name, test.group, repetition, bench.structure, bench.fmu_name,
                 bench.fmu_sha256, seed, test.dt, test.step, record.time, channels, excitation,
                 _excitation_attrs(test.commanded_excitation(repetition)), _noise_attrs(test, seed), driven)


def run_test(rig: Rig, bench: Bench, test: TestSpec, repetitions: Sequence[int], record: Record | None = None,
             keep_record: bool = False, out_dir: Path | None = None) -> Outcome:
    """Traces of ``repetitions`` of a test; failures are returned, not raised.

    Without actuator noise one simulation (or the given ``record``) serves
    all repetitions; ``keep_record`` returns it for further repetitions.
    With ``out_dir`` the files are written here, else their images returned.
    """
    outcome = Outcome(test.name)
    try:
        for r in repetitions:
            if test.simulates_each_repetition:
                rec = simulate(rig, bench, test, r)
            else:
                record = record if record is not None else simulate(rig, bench, test, r)
                rec = record
            image: bytes | None = trace_bytes(make_trace(bench, test, r, rec))
            digest = hashlib.sha256(image).hexdigest()
            if out_dir is not None:
                write_atomic(out_dir / test.trace_name(r), image)
                image = None
            outcome.files.append((test.trace_name(r), image, digest))
        outcome.record = record if keep_record else None
    except Exception as err:  # an FMU error, NaN, ...: recorded, the campaign goes on
        outcome.error = f"{type(err).__name__}: {err}"
    return outcome
