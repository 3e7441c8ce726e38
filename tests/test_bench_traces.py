"""Trace files: every field round-trips; no truth in a trace; the folder listing."""
from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from structbench.models.channels import Channel
from structbench.cli import main
from structbench import run_campaign
from structbench.harness.trace_writer import ChannelData, Trace, software, write_trace

DOCUMENTED_ROOT = {"format", "format_version", "campaign", "test", "repetition", "structure", "fmu_name",
                   "fmu_sha256", "software", "seed", "dt"}
ADDED_ROOT = {"group", "step"}
CHANNEL_ATTRS = {"quantity", "unit", "node", "direction", "location", "noise_ratio", "noise_mode"}
NOISE_ATTRS = {"sensor_ratio", "sensor_mode", "actuator_amplitude_ratio", "actuator_frequency_ratio", "seed"}


def synthetic_trace() -> Trace:
    rng = np.random.default_rng(0)
    n = 257
    channels = tuple(ChannelData(Channel(q, node, d), rng.standard_normal(n), (float(node), 0.5, -1.0), 0.02, "rms")
                     for q in ("acceleration", "velocity") for node in (3, 12) for d in ("w", "theta"))
    force = ChannelData(Channel("force", 3, "w"), rng.standard_normal(n), (3.0, 0.5, -1.0), 0.0, "rms")
    return Trace("camp", "sine-03", "sine", 7, "beam", "beam.fmu", "ab" * 32, 123456789, 0.01, 0.005,
                 np.arange(n) * 0.01, channels + (force,), (force,),
                 {"kind": "harmonic", "spec": json.dumps([{"kind": "harmonic", "omega": 1.5}]), "omega": 1.5,
                  "window_start": 2.0},
                 {"sensor_ratio": 0.02, "sensor_mode": "rms", "sensor_ratios": json.dumps({"acceleration": 0.02}),
                  "actuator_amplitude_ratio": 0.005, "actuator_frequency_ratio": 0.001, "seed": 123456789})


def test_every_field_round_trips(tmp_path):
    trace = synthetic_trace()
    path = tmp_path / "t.h5"
    write_trace(path, trace)
    assert [p.name for p in tmp_path.iterdir()] == ["t.h5"]  # no temporary file left
    with h5py.File(path, "r") as f:
        root = dict(f.attrs)
        assert root == trace.root_attrs()
        assert root["software"] == software() and root["format_version"] == 1
        assert isinstance(root["repetition"], np.integer) and isinstance(root["dt"], np.floating)
        assert f["time"].dtype == np.float64 and f["time"].attrs["unit"] == "s"
        np.testing.assert_array_equal(f["time"][()], trace.time)
        assert list(f["channels"]) == [c.channel.name for c in trace.channels]  # creation order kept
        for group, data in (("channels", trace.channels), ("excitation", trace.excitation)):
            for c in data:
                ds = f[group][c.channel.name]
                np.testing.assert_array_equal(ds[()], c.data)
                assert set(ds.attrs) == CHANNEL_ATTRS
                assert (ds.attrs["quantity"], ds.attrs["unit"], ds.attrs["node"], ds.attrs["direction"]) == (
                    c.channel.quantity, c.channel.unit, c.channel.node, c.channel.direction)
                np.testing.assert_array_equal(ds.attrs["location"], c.location)
                assert (ds.attrs["noise_ratio"], ds.attrs["noise_mode"]) == (c.noise_ratio, c.noise_mode)
        assert dict(f["excitation"].attrs) == trace.excitation_attrs
        assert dict(f["noise"].attrs) == trace.noise_attrs
        assert f["channels/velocity_12_theta"].attrs["unit"] == "rad/s"
        assert f["channels/acceleration_3_w"].attrs["unit"] == "m/s^2"


@pytest.fixture(scope="module")
def campaign_out(tmp_path_factory):
    root = tmp_path_factory.mktemp("traces")
    (root / "c.toml").write_text("""\
name = "listing"
structure = "ch5-simply-supported-beam"
[[tests]]
name = "kick"
dt = 0.05
duration = 5.0
repetitions = 2
noise = {sensor = 0.01}
excitation = [{kind = "impulse", node = 1, dir = "w", impulse = 1.0, method = "initial-velocity"}]
sensors = [{nodes = "all", quantities = ["displacement", "velocity"]}]
[[tests]]
name = "tap"
dt = 0.05
duration = 5.0
excitation = [{kind = "impulse", node = 4, dir = "w", impulse = 0.5}]
sensors = [{nodes = [4], dirs = ["w"], quantities = ["velocity", "force"]}]
""")
    run_campaign(root / "c.toml", root / "out", jobs=0, fmu_dir=root / "fmus")
    return root / "out"


def test_a_trace_holds_no_truth(campaign_out):
    truth = json.loads((campaign_out / "truth.json").read_text())
    assert {"parameters", "omega", "mode_shapes", "sensor_dofs"} <= set(truth)
    assert truth["sensor_dofs"] == [[n, "w"] for n in range(1, 11)]
    omegas = set(truth["omega"])
    for path in (campaign_out / "traces").glob("*.h5"):
        with h5py.File(path, "r") as f:
            assert set(f) == {"time", "channels", "excitation", "noise"}
            assert set(f.attrs) == DOCUMENTED_ROOT | ADDED_ROOT
            assert NOISE_ATTRS <= set(f["noise"].attrs)
            names = []
            f.visititems(lambda name, obj: names.extend([name, *obj.attrs]))
            assert not {n for n in names if any(w in n for w in ("truth", "true", "param", "shape", "lambda", "zeta"))}
            values = [v for obj in [f, *[f[n] for n in f]] for v in obj.attrs.values()
                      if isinstance(v, (float, np.floating))]
            assert not omegas & set(values)


def test_impulse_tests(campaign_out):
    with h5py.File(campaign_out / "traces" / "tap.h5", "r") as f:
        force = f["channels/force_4_w"][()]
        assert force[0] == pytest.approx(0.5 / 0.05) and not force[1:].any()
        assert f["excitation"].attrs["kind"] == "impulse"
    with h5py.File(campaign_out / "traces" / "kick.r000.h5", "r") as f:
        assert list(f["excitation"]) == []  # an exact impulse is an initial state, not a force
        assert json.loads(f["excitation"].attrs["spec"])[0]["method"] == "initial-velocity"


def test_traces_command_lists_the_folder(campaign_out, capsys):
    assert main(["traces", str(campaign_out)]) == 0
    text = capsys.readouterr().out
    assert "campaign listing on ch5-simply-supported-beam" in text
    assert "kick" in text and "2/2" in text and "tap" in text
    assert main(["traces", str(campaign_out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {t["test"]: t["files"] for t in data["tests"]} == {"kick": 2, "tap": 1}
