"""A campaign on a Dask cluster gives bit-identical traces to the local run;
its workers stop a hung FMU at the test's time limit and contain a crash."""
from __future__ import annotations

import json

import pytest

from structbench import run_campaign
from bench_fixtures import assert_same_traces
from faulty_fixtures import CALM, CAMPAIGN as FAULTY, FAIL_KINDS, build_faulty

distributed = pytest.importorskip("distributed")

CAMPAIGN = """\
name = "dask"
structure = "ch3-free-free-beam"
seed = 21

[defaults]
dt = 0.01
duration = 10.0
sensors = [{nodes = "all", quantities = ["acceleration"]}, {nodes = [7], dirs = ["w"], quantities = ["force"]}]

[[tests]]
name = "sweep"
[[tests.excitation]]
kind = "stepped-sine"
node = 7
dir = "w"
amplitude = 0.1
omegas = [0.5, 1.0, 1.5, 2.0]
ramp = 2.0

[[tests]]
name = "mc"
repetitions = 8
noise = {sensor = {acceleration = 0.02, force = 0.02}}
excitation = [{kind = "harmonic", node = 7, dir = "w", amplitude = 0.1, omega = 1.0}]

[[tests]]
name = "actuator"
repetitions = 3
noise = {sensor = 0.02, actuator_amplitude = 0.01, actuator_frequency = 0.01}
excitation = [{kind = "random", node = 3, dir = "w", rms = 0.1, band = [0.1, 5.0]},
              {kind = "harmonic", node = 7, dir = "w", amplitude = 0.1, omega = 1.0}]
"""


def test_dask_cluster_gives_bit_identical_traces(tmp_path):
    campaign = tmp_path / "dask.toml"
    campaign.write_text(CAMPAIGN)
    fmus = tmp_path / "fmus"
    local = run_campaign(campaign, tmp_path / "local", jobs=2, fmu_dir=fmus)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        remote = run_campaign(campaign, tmp_path / "dask", scheduler=cluster.scheduler_address, fmu_dir=fmus)
    assert local.failed == remote.failed == 0
    assert len(list((tmp_path / "dask" / "traces").glob("*.h5"))) == 4 + 8 + 3
    assert_same_traces(tmp_path / "local", tmp_path / "dask")
    for path in (tmp_path / "local" / "traces").glob("*.h5"):  # the very same bytes
        assert path.read_bytes() == (tmp_path / "dask" / "traces" / path.name).read_bytes()


def test_a_hung_fmu_on_dask_times_out_and_the_other_tests_complete(tmp_path):
    """Faulty.fmu hangs at step 10 of test "faulty"; the time limit is 4 s.
    One worker thread runs the tasks one after the other, so the tasks after
    the hung one complete only if it is stopped."""
    path = tmp_path / "faulty.toml"
    path.write_text(FAULTY.format(kind="hang", fmu=build_faulty(tmp_path), code=FAIL_KINDS["hang"]))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        status = run_campaign(path, tmp_path / "out", scheduler=cluster.scheduler_address)
    tests = json.loads((tmp_path / "out" / "status.json").read_text())["tests"]
    assert {name: t["state"] for name, t in tests.items()} == {"calm": "done", "faulty": "failed", "noisy": "done"}
    assert tests["faulty"]["error"] == "timed out after 4 s" and status.failed == 1
    assert sorted(p.name for p in (tmp_path / "out" / "traces").iterdir()) == CALM
