"""Repeated kill -9 of a parallel campaign (2 workers) at random moments,
each followed by a resume, with a booked trace damaged in between: the
traces end up bit-identical to an uninterrupted run (the 20-cycle version
is benchmarks/kill_resume.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from kill_cycles import kill_cycle, prepare


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    return prepare(tmp_path_factory.mktemp("kill"))


def test_kill_resume_cycles_end_identical(bench, tmp_path):
    rng = np.random.default_rng(13)
    damaged = 0
    for i in range(4):  # three cycles at random moments; a fourth killed at the first booking if none had one
        if i >= 3 and damaged:
            break
        out = tmp_path / f"cycle{i}"
        cycle = kill_cycle(bench, out, rng, damage=True, booked_first=i >= 3)
        assert cycle.resumed_code == 0 and cycle.identical, cycle
        summary = json.loads((out / "status.json").read_text())["summary"]
        assert summary["done"] == 24 and summary["failed"] == 0
        damaged += cycle.damaged is not None
    assert damaged >= 1  # at least one resume had a damaged trace to find


def test_a_damaged_trace_is_simulated_again(bench, tmp_path):
    """Directly: a booked trace with a flipped byte is deleted and redone on resume."""
    import shutil
    import subprocess

    from kill_cycles import command, same_files

    out = tmp_path / "out"
    shutil.copytree(bench.reference, out)
    victim = out / "traces" / "t03.h5"
    data = bytearray(victim.read_bytes())
    data[100] ^= 0x01
    victim.write_bytes(bytes(data))
    assert subprocess.run(command(bench.campaign, out), capture_output=True).returncode == 0
    status = json.loads((out / "status.json").read_text())
    assert status["summary"]["skipped"] == 23  # t03 was not taken as done
    assert same_files(bench.reference / "traces", out / "traces")
