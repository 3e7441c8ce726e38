"""Sensor and actuator noise: requested ratio, reproducible from the seed."""
from __future__ import annotations

import json
import zlib

import h5py
import numpy as np
import pytest

from structbench.harness.excitation import ramp_envelope
from structbench.harness.noise import derived_seed
from structbench import run_campaign
from bench_fixtures import assert_same_traces

CAMPAIGN = """\
name = "noise"
structure = "ch4-cantilever-case1"
seed = {seed}

[defaults]
dt = 0.01
duration = 40.0
sensors = [{{nodes = "all", quantities = ["displacement", "acceleration"]}},
           {{nodes = [7], dirs = ["w"], quantities = ["force"]}}]
excitation = [{{kind = "harmonic", node = 7, dir = "w", amplitude = 1.0, omega = 2.0, ramp = 2.0}}]

[[tests]]
name = "clean"

[[tests]]
name = "rms"
repetitions = 3
noise = {{sensor = 0.05}}

[[tests]]
name = "proportional"
noise = {{sensor = 0.05, mode = "proportional"}}

[[tests]]
name = "actuator"
repetitions = 2
noise = {{actuator_amplitude = 0.02, actuator_frequency = 0.01}}

[[tests]]
name = "drive"
repetitions = 2
excitation = [{{kind = "random", node = 7, dir = "w", rms = 1.0, band = [0.0, 20.0], seed = 11}}]

[[tests]]
name = "ambient"
repetitions = 2
excitation = [{{kind = "random", node = 7, dir = "w", rms = 1.0, band = [0.0, 20.0], seed = 11, realisation = "per-repetition"}}]
"""
RATIO = 0.05
N = 4001


def run(tmp_path_factory, seed: int, jobs: int = 0):
    root = tmp_path_factory.mktemp(f"noise{seed}")
    path = root / "noise.toml"
    path.write_text(CAMPAIGN.format(seed=seed))
    status = run_campaign(path, root / "out", jobs=jobs, fmu_dir=tmp_path_factory.getbasetemp() / "fmus")
    assert status.failed == 0
    return root / "out"


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    return run(tmp_path_factory, seed=5)


def channels(path) -> tuple[dict[str, np.ndarray], dict]:
    with h5py.File(path, "r") as f:
        return {k: v[()] for k, v in f["channels"].items()}, dict(f.attrs)


def test_rms_noise_has_the_requested_ratio_and_comes_from_the_seed(out):
    clean, _ = channels(out / "traces" / "clean.h5")
    tolerance = 4 / np.sqrt(2 * N)  # relative sampling error of a standard deviation, 4 sigma
    for r in range(3):
        noisy, attrs = channels(out / "traces" / f"rms.r{r:03d}.h5")
        for name, x in clean.items():
            noise = noisy[name] - x
            rms = np.sqrt(np.mean(x**2))
            assert np.std(noise) / rms == pytest.approx(RATIO, rel=tolerance), name
            z = np.random.default_rng([int(attrs["seed"]), 1, zlib.crc32(name.encode())]).standard_normal(N)
            np.testing.assert_allclose(noise, RATIO * rms * z, rtol=0, atol=1e-12 * np.abs(x).max())


def test_proportional_noise_is_a_gain_error(out):
    clean, _ = channels(out / "traces" / "clean.h5")
    noisy, _ = channels(out / "traces" / "proportional.h5")
    for name, x in clean.items():
        keep = np.abs(x) > 1e-9 * np.abs(x).max()
        gain = (noisy[name][keep] - x[keep]) / np.abs(x[keep])
        assert np.std(gain) == pytest.approx(RATIO, rel=4 / np.sqrt(2 * keep.sum())), name
        assert noisy[name][0] == x[0] == 0.0  # at rest at t = 0: no signal, no noise


def test_repetitions_differ_and_attributes_declare_the_noise(out):
    a, attrs_a = channels(out / "traces" / "rms.r000.h5")
    b, attrs_b = channels(out / "traces" / "rms.r001.h5")
    assert attrs_a["seed"] != attrs_b["seed"]
    assert all(not np.array_equal(a[k], b[k]) for k in a)
    with h5py.File(out / "traces" / "rms.r000.h5", "r") as f:
        assert f["channels/displacement_7_w"].attrs["noise_ratio"] == RATIO
        assert f["channels/displacement_7_w"].attrs["noise_mode"] == "rms"
        assert f["noise"].attrs["sensor_ratio"] == RATIO and f["noise"].attrs["seed"] == attrs_a["seed"]


def test_same_seed_same_traces_other_seed_other_noise(out, tmp_path_factory):
    again = run(tmp_path_factory, seed=5, jobs=2)
    assert_same_traces(out, again)
    other = run(tmp_path_factory, seed=6)
    clean_a, _ = channels(out / "traces" / "clean.h5")
    clean_b, _ = channels(other / "traces" / "clean.h5")
    assert all(np.array_equal(clean_a[k], clean_b[k]) for k in clean_a)
    noisy_a, _ = channels(out / "traces" / "rms.r000.h5")
    noisy_b, _ = channels(other / "traces" / "rms.r000.h5")
    assert all(not np.array_equal(noisy_a[k], noisy_b[k]) for k in noisy_a)


def test_actuator_noise_changes_what_the_structure_feels(out):
    t = np.arange(N) * 0.01
    clean, _ = channels(out / "traces" / "clean.h5")
    responses = []
    for r in range(2):
        path = out / "traces" / f"actuator.r{r:03d}.h5"
        felt, attrs = channels(path)
        za, zf = np.random.default_rng([int(attrs["seed"]), 0]).standard_normal((1, 2))[0]
        expected = (1 + 0.02 * za) * ramp_envelope(t, 2.0) * np.cos(2.0 * (1 + 0.01 * zf) * t)
        np.testing.assert_allclose(felt["force_7_w"], expected, rtol=0, atol=1e-12)
        with h5py.File(path, "r") as f:  # as commanded: nominal
            np.testing.assert_array_equal(f["excitation/force_7_w"][()], clean["force_7_w"])
        assert not np.array_equal(felt["displacement_7_w"], clean["displacement_7_w"])
        responses.append(felt["displacement_7_w"])
    assert not np.array_equal(*responses)


def band_limited(seed: int) -> np.ndarray:
    """The documented random force: white noise from default_rng(seed) on the
    grid, cut to [0, 20] rad/s by FFT, scaled to RMS 1 N."""
    spectrum = np.fft.rfft(np.random.default_rng(seed).standard_normal(N))
    spectrum[2 * np.pi * np.fft.rfftfreq(N, 0.01) > 20.0] = 0.0
    x = np.fft.irfft(spectrum, N)
    return x / np.sqrt(np.mean(x**2))


def test_random_force_replayed_or_drawn_anew_per_repetition(out):
    felt = {(name, r): channels(out / "traces" / f"{name}.r{r:03d}.h5")[0]["force_7_w"]
            for name in ("drive", "ambient") for r in range(2)}
    np.testing.assert_allclose(felt["drive", 0], band_limited(11), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(felt["drive", 0], felt["drive", 1])
    for r in range(2):
        own = derived_seed(11, "repetition", r)
        np.testing.assert_allclose(felt["ambient", r], band_limited(own), rtol=0, atol=1e-12)
        with h5py.File(out / "traces" / f"ambient.r{r:03d}.h5", "r") as f:
            assert json.loads(f["excitation"].attrs["spec"])[0]["seed"] == own
            np.testing.assert_array_equal(f["excitation/force_7_w"][()], felt["ambient", r])
    assert np.corrcoef(felt["ambient", 0], felt["ambient", 1])[0, 1] < 0.1


def test_sensor_noise_repetitions_share_one_simulation(tmp_path, tmp_path_factory, monkeypatch):
    import structbench.harness.simulation

    calls: list[str] = []
    real = structbench.harness.simulation.simulate

    def counting(rig, bench_, test, items):
        calls.append(test.name)
        return real(rig, bench_, test, items)

    monkeypatch.setattr(structbench.harness.simulation, "simulate", counting)
    path = tmp_path / "noise.toml"
    path.write_text(CAMPAIGN.format(seed=5).replace("duration = 40.0", "duration = 1.0"))
    run_campaign(path, tmp_path / "out", jobs=0, fmu_dir=tmp_path_factory.getbasetemp() / "fmus")
    assert sorted(calls) == ["actuator", "actuator", "ambient", "ambient", "clean", "drive", "proportional", "rms"]
