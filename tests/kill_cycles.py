"""kill -9 at random moments of a parallel campaign, then resume: shared by
tests/test_bench_kill.py (a few cycles) and benchmarks/kill_resume.py (20).

The campaign runs on the C test FMU (well-behaved) with 2 workers: many
short tests, with repetitions, sensor and actuator noise. Between the kill
and the resume one trace file that status.json has booked may be damaged;
the resume must find it by its checksum and simulate it again.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from faulty_fixtures import build_faulty

TESTS = 24


def campaign_text(fmu: Path) -> str:
    tests = []
    for i in range(TESTS):
        kind = i % 3
        extra = ("repetitions = 4\nnoise = {sensor = 0.02}\n" if kind == 1 else
                 "repetitions = 2\nnoise = {sensor = 0.01, actuator_amplitude = 0.02}\n" if kind == 2 else "")
        tests.append(f'[[tests]]\nname = "t{i:02d}"\n{extra}excitation = [{{kind = "harmonic", node = 1, '
                     f'dir = "z", amplitude = 1.0, omega = {2.0 + i * 0.5}}}]\n')
    return f"""\
name = "kill"
structure = "{fmu}"
seed = 7

[mapping]
force = "F_{{node}}_{{dir}}"
displacement = "u_{{node}}_{{dir}}"
velocity = "v_{{node}}_{{dir}}"
acceleration = "a_{{node}}_{{dir}}"

[locations]
1 = [0.0, 0.0, 0.0]

[defaults]
dt = 0.001
duration = 10.0
sensors = [{{nodes = "all", dirs = ["z"], quantities = ["displacement", "velocity", "acceleration", "force"]}}]

""" + "\n".join(tests)


def command(campaign: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "structbench.cli", "run", str(campaign), "--out", str(out), "--jobs", "2"]


@dataclass
class Bench:
    """The campaign, its uninterrupted reference run, when that run wrote
    its first trace and when it ended (s after its start)."""

    campaign: Path
    reference: Path
    first: float
    seconds: float


def prepare(root: Path) -> Bench:
    fmu = build_faulty(root)
    campaign = root / "kill.toml"
    campaign.write_text(campaign_text(fmu))
    reference = root / "reference"
    start = time.monotonic()
    process = subprocess.Popen(command(campaign, reference), stdout=subprocess.DEVNULL)
    first = None
    while process.poll() is None:
        if first is None and (reference / "traces").is_dir() and any((reference / "traces").glob("*.h5")):
            first = time.monotonic() - start
        time.sleep(0.01)
    assert process.returncode == 0
    seconds = time.monotonic() - start
    return Bench(campaign, reference, first if first is not None else 0.0, seconds)


def _booked(out: Path) -> list[str]:
    try:
        tests = json.loads((out / "status.json").read_text())["tests"]
    except (OSError, ValueError, KeyError):
        return []
    return sorted(name for t in tests.values() for name in t.get("sha256", {}))


@dataclass
class Cycle:
    """What one kill/resume cycle saw."""

    killed_after: float
    traces_at_kill: int
    damaged: str | None
    resumed_code: int
    identical: bool


def kill_cycle(bench: Bench, out: Path, rng: np.random.Generator, damage: bool, booked_first: bool = False
               ) -> Cycle:
    """Start the campaign into ``out``, kill -9 it (and its workers) at a random
    moment (with ``booked_first``: the moment the first trace is booked in
    ``status.json``), maybe damage a booked trace, resume and compare with
    the reference."""
    delay = float(rng.uniform(bench.first, bench.seconds))  # while traces are being written
    process = subprocess.Popen(command(bench.campaign, out), start_new_session=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if booked_first:
        start = time.monotonic()
        while process.poll() is None and not _booked(out):
            time.sleep(0.005)
        delay = time.monotonic() - start
    else:
        time.sleep(delay)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    traces = sorted((out / "traces").glob("*.h5")) if (out / "traces").is_dir() else []
    damaged = None
    booked = _booked(out)
    if damage and booked:
        damaged = booked[int(rng.integers(len(booked)))]
        path = out / "traces" / damaged
        data = bytearray(path.read_bytes())
        data[len(data) // 2] ^= 0xFF
        path.write_bytes(bytes(data))
    code = subprocess.run(command(bench.campaign, out), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    return Cycle(delay, len(traces), damaged, code, same_files(bench.reference / "traces", out / "traces"))


def same_files(a: Path, b: Path) -> bool:
    """The same file names (none lost, none extra, no temporary files) with the same bytes."""
    names = sorted(p.name for p in a.iterdir())
    return names == sorted(p.name for p in b.iterdir()) and all(
        (a / n).read_bytes() == (b / n).read_bytes() for n in names)
