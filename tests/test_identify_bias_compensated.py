"""Bias-compensated least squares over every sample: consistency with noise on
every channel and calibrated standard errors (Monte Carlo coverage), on the
3-storey shear frame of docs/examples simulated exactly (zero-order hold)."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from identify_synth import respond, write_trace
from structbench.identifier.least_squares import identify
from structbench.identifier.io.traces import read_trace
from structbench.models import load_model

SHEAR_FRAME = Path(__file__).resolve().parents[1] / "docs" / "examples" / "shear-frame-3.toml"
DT, N = 0.002, 4001
EVERY = {"acceleration": 0.02, "velocity": 0.02, "displacement": 0.02, "force": 0.02}
SEEDS = range(60)


@pytest.fixture(scope="module")
def frame():
    return load_model(SHEAR_FRAME)


@pytest.fixture(scope="module")
def response(frame):
    t = np.arange(N) * DT
    force = np.zeros((N, frame.n_dof))
    force[:, frame.dof_index(3, "x")] = 1000.0 * (np.cos(15 * t) + np.cos(40 * t))
    return respond(frame, force, DT)


def sensors(frame):
    return ([(q, n, d) for q in ("displacement", "velocity", "acceleration") for n, d in frame.dofs]
            + [("force", 3, "x")])


@pytest.fixture(scope="module")
def monte_carlo(frame, response, tmp_path_factory):
    """60 seeds of 2 % (rms) noise on every channel: bias-compensated (default)
    and plain least squares over every sample, standardized errors per run."""
    folder = tmp_path_factory.mktemp("frame-mc")
    truth = frame.values[frame.kind_mask()]
    out = {"bias-compensated": [], "ols": []}
    for seed in SEEDS:
        trace = read_trace(write_trace(folder / f"r{seed:02d}.h5", frame, response, DT, sensors(frame),
                                       noise=EVERY, seed=seed, repetition=seed))
        for estimator, runs in out.items():
            r = identify([trace], frame, estimator=estimator, weighting="none" if estimator == "ols" else "noise")
            std = np.array([p.std_error for p in r.parameters])
            runs.append(((r.values() - truth) / truth, (r.values() - truth) / std))
    kinds = np.array([p.kind for p in frame.parameters])[frame.kind_mask()]
    return kinds, {k: (np.array([e for e, _ in v]), np.array([z for _, z in v])) for k, v in out.items()}


def test_noise_free_every_sample_is_exact(frame, response, tmp_path):
    trace = read_trace(write_trace(tmp_path / "clean.h5", frame, response, DT, sensors(frame)))
    result = identify([trace], frame)
    assert result.details["estimator"] == "bias-compensated" and result.details["samples"] == N
    assert np.max(np.abs(result.values() / frame.values[frame.kind_mask()] - 1)) < 1e-6


def test_every_channel_noisy_bias_removed(monte_carlo):
    """Plain least squares over every sample is biased (errors in variables);
    the compensated estimate is centred on the truth: its median error over
    the seeds is within 3 standard errors of the mean; the plain one is off
    by more than 10 of its own."""
    _, runs = monte_carlo
    compensated, plain = runs["bias-compensated"][0], runs["ols"][0]
    sem = compensated.std(axis=0) / np.sqrt(len(SEEDS))
    assert np.all(np.abs(compensated.mean(axis=0)) < 3 * sem)
    plain_sem = plain.std(axis=0) / np.sqrt(len(SEEDS))
    assert np.max(np.abs(plain.mean(axis=0)) / plain_sem) > 10


def test_standard_errors_are_calibrated(monte_carlo):
    kinds, runs = monte_carlo
    z = runs["bias-compensated"][1]
    for kind in ("mass", "damping", "stiffness"):
        coverage = np.mean(np.abs(z[:, kinds == kind]) < 1.96)
        assert 0.90 <= coverage <= 0.98, (kind, coverage)


def test_undeclared_noise_is_estimated_and_said(frame, response, tmp_path):
    path = write_trace(tmp_path / "undeclared.h5", frame, response, DT, sensors(frame),
                       noise={"acceleration": 0.02, "force": 0.02}, seed=5)
    with h5py.File(path, "r+") as f:
        for ds in f["channels"].values():
            del ds.attrs["noise_ratio"]
    declared = identify([read_trace(write_trace(tmp_path / "declared.h5", frame, response, DT, sensors(frame),
                                                noise={"acceleration": 0.02, "force": 0.02}, seed=5))], frame)
    estimated = identify([read_trace(path)], frame)
    assert "estimated from the data" in estimated.details["noise"]
    assert declared.details["noise"] == "declared by the traces"
    truth = frame.values[frame.kind_mask()]
    assert np.max(np.abs(estimated.values() / truth - 1)) < 3 * np.max(np.abs(declared.values() / truth - 1)) + 1e-3


def test_nan_in_a_channel_is_named(frame, response, tmp_path):
    path = write_trace(tmp_path / "nan.h5", frame, response, DT, sensors(frame))
    with h5py.File(path, "r+") as f:
        data = f["channels/acceleration_2_x"][()]
        data[10] = np.nan
        f["channels/acceleration_2_x"][...] = data
    from structbench.identifier.errors import IdentificationError
    with pytest.raises(IdentificationError, match="acceleration_2_x is nan at sample 10"):
        identify([read_trace(path)], frame)
