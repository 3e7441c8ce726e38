"""Fault injection: a C FMU that returns fmi2Error or fmi2Fatal, segfaults,
hangs, outputs NaN or refuses to instantiate. Each fault fails only the
affected test, with the FMU's own message; the rest of the campaign runs,
``run`` exits 1 naming the failed test and a second run retries only it."""
from __future__ import annotations

import json
import os
import signal
import time

import pytest

from structbench.cli import main
from structbench.harness.child import Child, ChildDied, TimedOut
from faulty_fixtures import CALM, CAMPAIGN, FAIL_KINDS, build_faulty

EXPECTED = {
    "error": "fmi2DoStep failed (error) at t = 0.1 s: [error] stiffness matrix singular at step 10",
    "fatal": "fmi2DoStep failed (fatal) at t = 0.1 s: [fatal] solver memory corrupted at step 10",
    "segfault": "crashed with signal 11",
    "hang": "timed out after 4 s",
    "nan": "displacement_1_z is nan at t = 0.11 s",
}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    root = tmp_path_factory.mktemp("faulty")
    return {"faulty": build_faulty(root), "refusing": build_faulty(root, refuse=True)}


def campaign(tmp_path, fmu, kind: str, code: int):
    path = tmp_path / f"{kind}.toml"
    path.write_text(CAMPAIGN.format(kind=kind, fmu=fmu, code=code))
    return path


def run(capsys, path, out) -> tuple[int, str, dict]:
    code = main(["run", str(path), "--out", str(out), "--jobs", "2"])
    status = json.loads((out / "status.json").read_text())
    return code, capsys.readouterr().out, status


@pytest.mark.parametrize("kind", list(EXPECTED))
def test_a_failing_fmu_fails_only_its_test(kind, fmus, tmp_path, capsys):
    path, out = campaign(tmp_path, fmus["faulty"], kind, FAIL_KINDS[kind]), tmp_path / "out"
    code, printed, status = run(capsys, path, out)
    tests = status["tests"]
    assert code == 1
    assert {name: t["state"] for name, t in tests.items()} == {"calm": "done", "faulty": "failed", "noisy": "done"}
    assert EXPECTED[kind] in tests["faulty"]["error"]
    assert f"FAILED faulty: {tests['faulty']['error']}" in printed
    assert sorted(p.name for p in (out / "traces").iterdir()) == CALM  # nothing half-written
    written = {name: (out / "traces" / name).stat().st_mtime_ns for name in CALM}

    code, printed, status = run(capsys, path, out)  # retries the failed test only
    assert code == 1 and status["summary"] == {"done": 2, "failed": 1, "pending": 0, "skipped": 2}
    assert EXPECTED[kind] in status["tests"]["faulty"]["error"]
    assert {name: (out / "traces" / name).stat().st_mtime_ns for name in CALM} == written


def test_an_fmu_that_refuses_to_instantiate_fails_every_test(fmus, tmp_path, capsys):
    path, out = campaign(tmp_path, fmus["refusing"], "refuse", 0), tmp_path / "out"
    code, printed, status = run(capsys, path, out)
    assert code == 1 and status["summary"]["failed"] == 3
    for t in status["tests"].values():
        assert t["error"].endswith("instantiate (Failed to instantiate model) failed: "
                                   "[error] licence server unreachable, refusing to instantiate")
    assert printed.count("FAILED") == 3
    assert not list((out / "traces").iterdir())


def test_the_dask_workers_child_process_stops_a_hung_task_and_names_a_crash():
    """structbench.harness.child: results and exceptions come back; a task
    over its limit kills the child; a child that dies is reported by signal."""
    child = Child()
    assert child.call(os.getpid, (), 60.0) == child.process.pid != os.getpid()
    with pytest.raises(RuntimeError, match="ValueError: invalid literal for int"):
        child.call(int, ("x",), 60.0)
    with pytest.raises(TimedOut):
        child.call(time.sleep, (600,), 0.5)
    assert not child.alive
    child = Child()
    with pytest.raises(ChildDied, match="crashed with signal 11"):
        child.call(signal.raise_signal, (signal.SIGSEGV,), 60.0)
    assert not child.alive
