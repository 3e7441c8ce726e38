"""A campaign killed half-way (kill -9) and started again equals an uninterrupted one."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

from structbench.cli import main
from structbench import run_campaign
from bench_fixtures import assert_same_traces

CAMPAIGN = """\
name = "resume"
structure = "ch4-cantilever-case1"
seed = 11

[defaults]
dt = 0.01
duration = 300.0
sensors = [{nodes = "all", quantities = ["displacement"]}]

[[tests]]
name = "sweep"
[[tests.excitation]]
kind = "stepped-sine"
node = 7
dir = "w"
amplitude = 1.0
omegas = [0.5, 0.9, 1.3, 1.7, 2.1, 2.5, 2.9, 3.3, 3.7, 4.1, 4.5, 4.9]
ramp = 20.0

[[tests]]
name = "mc"
repetitions = 12
noise = {sensor = 0.02}
excitation = [{kind = "harmonic", node = 7, dir = "w", amplitude = 1.0, omega = 2.0, ramp = 20.0}]

[[tests]]
name = "actuator"
repetitions = 3
noise = {sensor = 0.01, actuator_amplitude = 0.01, actuator_frequency = 0.01}
excitation = [{kind = "harmonic", node = 7, dir = "w", amplitude = 1.0, omega = 2.0, ramp = 20.0}]
"""
TOTAL = 12 + 12 + 3


def states(folder) -> dict:
    return {k: (v["state"], v["present"]) for k, v in json.loads((folder / "status.json").read_text())["tests"].items()}


def test_killed_and_resumed_campaign_equals_an_uninterrupted_one(tmp_path):
    campaign = tmp_path / "resume.toml"
    campaign.write_text(CAMPAIGN)
    fmus = tmp_path / "fmus"
    reference = tmp_path / "reference"
    assert run_campaign(campaign, reference, jobs=1, fmu_dir=fmus).failed == 0

    killed = tmp_path / "killed"
    traces = killed / "traces"
    process = subprocess.Popen([sys.executable, "-m", "structbench.cli", "run", str(campaign), "--out", str(killed),
                                "--jobs", "1", "--fmu-dir", str(fmus)], start_new_session=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while not (traces.is_dir() and len(list(traces.glob("*.h5"))) >= 6) and time.monotonic() < deadline:
        assert process.poll() is None, "the campaign ended before it could be killed"
        time.sleep(0.01)
    os.killpg(process.pid, signal.SIGKILL)  # the CLI and its workers
    process.wait()
    written = len(list(traces.glob("*.h5")))
    assert 6 <= written < TOTAL

    assert main(["run", str(campaign), "--out", str(killed), "--jobs", "1", "--fmu-dir", str(fmus)]) == 0
    assert not list(traces.glob(".*.tmp"))
    summary = json.loads((killed / "status.json").read_text())["summary"]
    assert summary["done"] == 12 + 2 and summary["skipped"] >= 1
    assert_same_traces(reference, killed)
    assert states(reference) == states(killed)
    assert (reference / "truth.json").read_text() == (killed / "truth.json").read_text()
