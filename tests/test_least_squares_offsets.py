"""Least squares with constant sensor offsets (issue 22): the prefiltered
equations estimate one offset per response channel and record
(identifier/least_squares/offsets.py), against the truth used to simulate
(exact zero-order-hold responses plus the offsets, then the sensor noise,
as the harness does to an FMU's output)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from foreign_fixtures import D, K, M, Y0, build_msd, msd_campaign
from identify_synth import memory_trace, oscillator, respond
from structbench.harness.run import run_campaign
from structbench.identifier.io.traces import read_trace
from structbench.identifier.least_squares import identify
from structbench.models import load_model

ROOT = Path(__file__).resolve().parents[1]
SHEAR_FRAME = ROOT / "docs" / "examples" / "shear-frame-3.toml"
DT = 0.001
NOISE = {"displacement": 0.02, "velocity": 0.02, "force": 0.02}


def with_offsets(response: dict[str, np.ndarray], offsets: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``response`` with ``offsets[quantity]`` (n_dof,) added to that quantity."""
    return response | {q: response[q] + np.asarray(c)[None, :] for q, c in offsets.items()}


def z_scores(result, model):
    std = np.array([p.std_error for p in result.parameters])
    return (result.values() - model.values[model.kind_mask()]) / std


def test_oscillator_impulse_with_a_1mm_displacement_offset():
    """1-DOF (1 kg, 1e4 N/m, 10 N s/m), five 4 s records of a 0.1 N s impulse,
    2 % noise on displacement and force, +1 mm on the displacement: m, c, k
    within 1 % and 3 standard errors (without the offsets estimated: 100 %
    off), the offsets to 1 um."""
    model = oscillator()
    force = np.zeros((4001, 1))
    force[0, 0] = 100.0
    response = with_offsets(respond(model, force, DT), {"displacement": [1e-3]})
    sensors = [("displacement", 1, "x"), ("force", 1, "x")]
    traces = [memory_trace(model, response, DT, sensors, NOISE, seed=31 + rep, name=f"r{rep}.h5") for rep in range(5)]
    result = identify(traces, model)
    assert np.max(np.abs(result.values() / model.values - 1)) < 0.01
    assert np.max(np.abs(z_scores(result, model))) < 3
    found = [v["displacement_1_x"] for v in result.details["offsets"].values()]
    assert found == pytest.approx([1e-3] * 5, abs=1e-6)


@pytest.fixture(scope="module")
def frame():
    return load_model(SHEAR_FRAME)


@pytest.mark.parametrize("quantities", [("displacement",) * 3, ("displacement", "velocity", "displacement")],
                         ids=["displacement", "mix"])
def test_shear_frame_with_offsets_on_every_channel(frame, quantities):
    """3-DOF shear frame, two harmonics at the top, 2 % noise; offsets of
    +1, -2, +0.5 mm on the displacements (and 1 mm/s on a velocity; the noise,
    2 % of the RMS with the offsets, is up to twice that without): masses and
    stiffnesses within 2 %, dampings within 10 %, all within 4 standard
    errors (without the offsets estimated: up to 200 % off), the offsets to 2 %."""
    t = np.arange(3001) * DT
    force = np.zeros((t.size, frame.n_dof))
    force[:, frame.dof_index(3, "x")] = 1000.0 * (np.cos(15 * t) + np.cos(40 * t))
    values = {"displacement": [1e-3, -2e-3, 5e-4], "velocity": [1e-3, 1e-3, 1e-3]}
    response = with_offsets(respond(frame, force, DT), values)
    sensors = [(q, n, d) for q, (n, d) in zip(quantities, frame.dofs)] + [("force", 3, "x")]
    shifts = {f"{q}_{n}_{d}": values[q][j] for j, (q, (n, d)) in enumerate(zip(quantities, frame.dofs))}
    trace = memory_trace(frame, response, DT, sensors, NOISE, seed=3)
    result = identify([trace], frame)
    err = result.values() / frame.values[frame.kind_mask()] - 1
    damping = np.array([p.kind == "damping" for p in result.parameters])
    assert np.max(np.abs(err[~damping])) < 0.02 and np.max(np.abs(err[damping])) < 0.1
    assert np.max(np.abs(z_scores(result, frame))) < 4
    assert result.details["offsets"]["r.h5"] == pytest.approx(shifts, rel=0.02)


def test_foreign_fmu_position_offset(tmp_path):
    """The FMU of tests/foreign_fmu (position y = x + 1 mm), model exchange, a
    1 N s impulse, 2 % noise, 3 repetitions: m, c, k within 1 % and 4
    standard errors (without the offsets estimated: m -92 %), the offset to 1 %."""
    campaign = msd_campaign(tmp_path, build_msd(tmp_path), 7, """\
[[tests]]
name = "impulse"
dt = 0.001
duration = 4.0
repetitions = 3
noise = {sensor = {displacement = 0.02, force = 0.02}}
excitation = [{kind = "impulse", node = 1, dir = "x", impulse = 1.0}]
sensors = [{nodes = [1], dirs = ["x"], quantities = ["displacement", "force"]}]
""")
    out = tmp_path / "out"
    status = run_campaign(campaign, out, jobs=0, check_step="off")
    assert not status.failed
    traces = [read_trace(p) for p in sorted((out / "traces").glob("*.h5"))]
    model = load_model(ROOT / "tests" / "foreign_fmu" / "msd.toml")
    result = identify(traces, model)
    truth = {"mass[1]": M, "damping[3]": D, "stiffness[2]": K}
    for p in result.parameters:
        assert abs(p.value / truth[p.label] - 1) < 0.01 and abs(p.value - truth[p.label]) < 4 * p.std_error, p
    for offsets in result.details["offsets"].values():
        assert offsets["displacement_1_x"] == pytest.approx(Y0, rel=0.01)
