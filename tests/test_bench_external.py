"""A campaign on a foreign FMU through a variable mapping; failing tests."""
from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import scipy.linalg as la

from structbench.harness.campaign import CampaignError, load_campaign
from structbench.cli import main
from bench_fixtures import build_two_mass

CAMPAIGN = """\
name = "two-mass"
structure = "TwoMass.fmu"

[parameters]
"Structure.k2" = 60.0

[mapping]
force = "Structure.Node{node}.F{dir}"
displacement = "Structure.Node{node}.U{dir}"
velocity = "Structure.Node{node}.V{dir}"

[mapping.table]
acceleration_2_z = "Structure.Node2.Az"

[locations]
1 = [0.0, 0.0, 1.0]
2 = [0.0, 0.0, 2.0]

[truth]
parameters = {m1 = 1.0, m2 = 2.0, k1 = 100.0, k2 = 60.0}

[defaults]
dt = 0.01
step = 0.005
duration = 2.0
sensors = [{nodes = "all", dirs = ["z"], quantities = ["displacement", "velocity"]},
           {nodes = [2], dirs = ["z"], quantities = ["acceleration", "force"]}]

[[tests]]
name = "sine"
excitation = [{kind = "harmonic", node = 2, dir = "z", amplitude = 1.0, omega = 5.0}]

[[tests]]
name = "breaks"   # 10 kN pulse: the FMU's outputs turn NaN
excitation = [{kind = "impulse", node = 2, dir = "z", impulse = 100.0}]

[[tests]]
name = "overload"   # 10 MN: the FMU raises
excitation = [{kind = "random", node = 2, dir = "z", rms = 1e7, band = [0.0, 100.0]}]

[[tests]]
name = "crash"   # 777 N: the FMU kills its worker process
excitation = [{kind = "harmonic", node = 2, dir = "z", amplitude = 777.0, omega = 0.0}]

[[tests]]
name = "noise"
noise = {sensor = 0.01}
excitation = [{kind = "random", node = 1, dir = "z", rms = 1.0, band = [1.0, 30.0], seed = 4},
              {kind = "harmonic", node = 2, dir = "z", amplitude = 0.5, omega = 3.0}]
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("external")
    build_two_mass(root)
    (root / "two-mass.toml").write_text(CAMPAIGN)
    return root


@pytest.fixture(scope="module")
def run(folder):
    status = main(["run", str(folder / "two-mass.toml"), "--out", str(folder / "out"), "--jobs", "2"])
    return status, folder / "out"


def reference(t: np.ndarray, force: np.ndarray, step: float, k2: float) -> np.ndarray:
    """Exact zero-order-hold response (displacements, (n, 2)) of the chain."""
    m = np.diag([1.0, 2.0])
    k = np.array([[100.0 + k2, -k2], [-k2, k2]])
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-la.solve(m, k), np.zeros((2, 2))]])
    b = np.vstack([np.zeros((2, 2)), la.inv(m)])
    e = la.expm(np.block([[a, b], [np.zeros((2, 6))]]) * step)
    ad, bd = e[:4, :4], e[:4, 4:]
    x, out = np.zeros(4), np.empty((t.size, 2))
    for i, f in enumerate(force):
        out[i] = x[:2]
        x = ad @ x + bd @ f
    return out


def test_mapped_channels_follow_the_physics(run):
    status, out = run
    with h5py.File(out / "traces" / "sine.h5", "r") as f:
        assert set(f["channels"]) == {"displacement_1_z", "displacement_2_z", "velocity_1_z", "velocity_2_z",
                                      "acceleration_2_z", "force_2_z"}
        assert f.attrs["fmu_name"] == "TwoMass.fmu" and f.attrs["structure"] == "TwoMass"
        np.testing.assert_array_equal(f["channels/displacement_2_z"].attrs["location"], [0.0, 0.0, 2.0])
        u = np.column_stack([f["channels/displacement_1_z"][()], f["channels/displacement_2_z"][()]])
        t = f["time"][()]
    fine = np.arange(401) * 0.005
    force = np.column_stack([np.zeros_like(fine), np.cos(5.0 * fine)])
    exact = reference(fine, force, 0.005, 60.0)[::2]
    assert np.abs(u - exact).max() < 1e-2 * np.abs(exact).max()  # the FMU's own integrator
    default_k2 = reference(fine, force, 0.005, 50.0)[::2]
    assert np.abs(u - default_k2).max() > 5e-2 * np.abs(exact).max()  # the campaign's k2 was set
    assert t[-1] == pytest.approx(2.0)


def test_failures_are_recorded_and_the_rest_runs(run):
    status, out = run
    assert status == 1  # exit status: some tests failed
    tests = json.loads((out / "status.json").read_text())["tests"]
    assert {name: t["state"] for name, t in tests.items()} == {
        "sine": "done", "breaks": "failed", "overload": "failed", "crash": "failed", "noise": "done"}
    assert "nan" in tests["breaks"]["error"]
    assert "actuator overload" in tests["overload"]["error"]
    assert tests["crash"]["error"] == "the worker process exited with status 3"  # os._exit(3) in the FMU
    assert sorted(p.name for p in (out / "traces").glob("*.h5")) == ["noise.h5", "sine.h5"]
    truth = json.loads((out / "truth.json").read_text())
    assert truth["parameters"]["k2"] == 60.0 and truth["source"] == "campaign"


def test_an_unmatched_mapping_fails_listing_the_closest_variables(folder):
    bad = CAMPAIGN.replace('dirs = ["z"], quantities = ["displacement"', 'dirs = ["w"], quantities = ["displacement"')
    (folder / "bad.toml").write_text(bad)
    with pytest.raises(CampaignError) as err:
        load_campaign(folder / "bad.toml")
    message = str(err.value)
    assert message.startswith("bad.toml:26: defaults.sensors[1]: displacement at (1, 'w'): no variable "
                              "'Structure.Node1.Uw' in TwoMass.fmu; closest: Structure.Node1.Uz")


def test_unknown_parameter_of_an_external_fmu(folder):
    (folder / "bad2.toml").write_text(CAMPAIGN.replace('"Structure.k2" = 60.0', '"Structure.kk2" = 60.0'))
    with pytest.raises(CampaignError, match=r'bad2.toml:5: parameters."Structure.kk2": .*closest: Structure.k2'):
        load_campaign(folder / "bad2.toml")
