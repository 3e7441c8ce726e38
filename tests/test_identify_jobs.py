"""``identify --jobs``: runs identified by worker processes give the same
results, in run order, with progress per run and one-line errors."""
from __future__ import annotations

import json
import os

import h5py
import numpy as np
import pytest

from structbench import api
from structbench.cli import main
from structbench.dispatch import parallel
from structbench.models import load_model
from identify_synth import harmonic_force, respond, write_trace

REPETITIONS = 4


@pytest.fixture(scope="module")
def beam_campaign(tmp_path_factory):
    """The chapter 3 beam under 0.1 cos(t) N at node 7, 2 s at 5 ms, every DOF's
    acceleration, velocity and displacement logged; 2 % noise on the
    accelerations and the force, another seed per repetition."""
    beam = load_model("ch3-free-free-beam")
    folder = tmp_path_factory.mktemp("ch3")
    t = np.arange(401) * 0.005
    response = respond(beam, harmonic_force(beam, 7, "w", 0.1, 1.0, t), 0.005)
    sensors = [(q, n, d) for q in ("acceleration", "velocity", "displacement") for n, d in beam.dofs]
    for r in range(REPETITIONS):
        write_trace(folder / "traces" / f"harmonic-r{r}.h5", beam, response, 0.005, sensors + [("force", 7, "w")],
                    noise={"acceleration": 0.02, "force": 0.02}, seed=r, test="harmonic", repetition=r)
    return folder


def with_pid(monkeypatch):
    """Each run's result records the process that identified it (details.pid)."""
    original = parallel.identify_run

    def identify_run(*args):
        result = original(*args)
        result.details["pid"] = os.getpid()
        return result

    monkeypatch.setattr(parallel, "identify_run", identify_run)


def test_workers_give_the_results_of_one_process(beam_campaign, monkeypatch):
    with_pid(monkeypatch)
    documents, progress = {}, {}
    for jobs in (1, 2):
        progress[jobs] = []
        documents[jobs] = api.identify(beam_campaign, "least-squares", tag=f"jobs{jobs}", jobs=jobs,
                                       progress=lambda done, total, seen=progress[jobs]: seen.append((done, total)))
    pids = {jobs: {run["details"].pop("pid") for run in documents[jobs]["runs"]} for jobs in (1, 2)}
    assert pids[1] == {os.getpid()} and os.getpid() not in pids[2]
    assert [run["repetition"] for run in documents[2]["runs"]] == list(range(REPETITIONS))
    assert json.dumps(documents[1]["runs"]) == json.dumps(documents[2]["runs"])  # every number, every digit
    assert progress[1] == progress[2] == [(k, REPETITIONS) for k in range(1, REPETITIONS + 1)]
    truth = load_model("ch3-free-free-beam")
    values = np.array([p["value"] for p in documents[2]["runs"][0]["parameters"]])
    assert values == pytest.approx(truth.values[truth.kind_mask()], rel=0.05)


def test_a_bad_trace_read_by_a_worker_is_one_line(beam_campaign, tmp_path, capsys):
    for path in (beam_campaign / "traces").glob("*.h5"):
        (tmp_path / "traces").mkdir(exist_ok=True)
        (tmp_path / "traces" / path.name).write_bytes(path.read_bytes())
    with h5py.File(tmp_path / "traces" / "harmonic-r2.h5", "a") as f:
        f["channels/acceleration_7_w"][5] = np.nan
    assert main(["identify", str(tmp_path), "--method", "least-squares", "--jobs", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "harmonic-r2.h5: /channels/acceleration_7_w is nan at sample 5" in err[0]
    assert not (tmp_path / "results").exists()


def test_a_worker_that_dies_is_one_line(beam_campaign, monkeypatch, capsys):
    parent = os.getpid()
    original = parallel.identify_run
    monkeypatch.setattr(parallel, "identify_run",
                        lambda *args: original(*args) if os.getpid() == parent else os._exit(9))
    assert main(["identify", str(beam_campaign), "--method", "least-squares", "--jobs", "2", "--tag", "dead"]) == 2
    assert capsys.readouterr().err.strip() == ("structbench identify: error: --jobs: a worker process died "
                                               "(out of memory?); try fewer jobs")
    assert not (beam_campaign / "results" / "least-squares-dead.json").exists()


@pytest.mark.parametrize("jobs", ["0", "-2"])
def test_jobs_below_one_exit_2(beam_campaign, capsys, jobs):
    assert main(["identify", str(beam_campaign), "--method", "least-squares", "--jobs", jobs]) == 2
    assert "--jobs: must be a whole number of at least 1" in capsys.readouterr().err
