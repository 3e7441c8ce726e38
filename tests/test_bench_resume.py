"""A campaign killed half-way (kill -9) and started again equals an uninterrupted one;
an old folder without checksums keeps the traces that check out."""
from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np

from structbench.cli import main
from structbench import run_campaign
from bench_fixtures import assert_same_traces
from faulty_fixtures import CALM, CAMPAIGN as FAULTY, build_faulty

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


def test_an_old_folder_without_checksums_keeps_its_good_traces(tmp_path):
    """status.json without sha256 (as written before checksums): on resume the
    traces that hold the right test and repetition are checksummed and kept;
    a truncated one, one holding another repetition and one with a NaN are
    simulated again. Re-simulated traces are bit-identical to the first run."""
    campaign = tmp_path / "calm.toml"
    campaign.write_text(FAULTY.format(kind="calm", fmu=build_faulty(tmp_path), code=0))
    out, traces = tmp_path / "out", tmp_path / "out" / "traces"
    assert run_campaign(campaign, out, jobs=0).failed == 0
    original = {p.name: p.read_bytes() for p in traces.glob("*.h5")}
    assert sorted(original) == sorted(CALM + ["faulty.h5"])

    status = json.loads((out / "status.json").read_text())
    for test in status["tests"].values():
        del test["sha256"]
    (out / "status.json").write_text(json.dumps(status))
    (traces / "calm.h5").write_bytes(original["calm.h5"][:5000])                # truncated
    (traces / "noisy.r002.h5").write_bytes(original["noisy.r001.h5"])          # another repetition
    with h5py.File(traces / "faulty.h5", "a") as f:                            # a NaN sample
        f["channels/displacement_1_z"][7] = np.nan
    kept = {name: (traces / name).stat().st_mtime_ns for name in ("noisy.r000.h5", "noisy.r001.h5")}

    resumed = run_campaign(campaign, out, jobs=0)
    assert resumed.failed == 0 and resumed.skipped == 0
    assert {name: (traces / name).stat().st_mtime_ns for name in kept} == kept
    assert {p.name: p.read_bytes() for p in traces.glob("*.h5")} == original
    booked = {n: d for t in json.loads((out / "status.json").read_text())["tests"].values()
              for n, d in t["sha256"].items()}
    assert booked == {name: hashlib.sha256(data).hexdigest() for name, data in original.items()}
