"""Least squares from any one response quantity per DOF (issue 22): the
prefiltered equations of motion (identifier/least_squares/prefilter.py),
against the truth used to simulate (exact zero-order-hold responses, never
read by the identifier)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from identify_synth import memory_trace, oscillator, respond
from structbench.identifier.errors import IdentificationError
from structbench.identifier.least_squares import identify
from structbench.models import load_model

SHEAR_FRAME = Path(__file__).resolve().parents[1] / "docs" / "examples" / "shear-frame-3.toml"
DT, N = 0.001, 3001
NOISE = {"displacement": 0.02, "velocity": 0.02, "acceleration": 0.02, "force": 0.02}


@pytest.fixture(scope="module")
def frame():
    return load_model(SHEAR_FRAME)


@pytest.fixture(scope="module")
def frame_response(frame):
    t = np.arange(N) * DT
    force = np.zeros((N, frame.n_dof))
    force[:, frame.dof_index(3, "x")] = 1000.0 * (np.cos(15 * t) + np.cos(40 * t))
    return respond(frame, force, DT)


def frame_sensors(frame, quantity_of):
    return [(quantity_of(j), n, d) for j, (n, d) in enumerate(frame.dofs)] + [("force", 3, "x")]


def relative_errors(result, model):
    return result.values() / model.values[model.kind_mask()] - 1


@pytest.mark.parametrize("quantity_of", [lambda j: "displacement", lambda j: "velocity",
                                         lambda j: ("displacement", "velocity", "acceleration")[j]],
                         ids=["displacement", "velocity", "mix"])
def test_noise_free_any_quantity_is_exact(frame, frame_response, quantity_of):
    trace = memory_trace(frame, frame_response, DT, frame_sensors(frame, quantity_of))
    result = identify([trace], frame)
    assert result.details["motion"] == ["prefiltered"]
    assert np.max(np.abs(relative_errors(result, frame))) < 2e-3


@pytest.mark.parametrize("quantity_of", [lambda j: "displacement", lambda j: "velocity",
                                         lambda j: ("acceleration", "velocity", "displacement")[j]],
                         ids=["displacement", "velocity", "mix"])
def test_noisy_any_quantity_within_its_standard_errors(frame, frame_response, quantity_of):
    """2 % noise on every channel: masses and stiffnesses within 1 %, the
    damping within 10 %, every parameter within 4 of its stated standard errors."""
    trace = memory_trace(frame, frame_response, DT, frame_sensors(frame, quantity_of), NOISE, seed=3)
    result = identify([trace], frame)
    err = relative_errors(result, frame)
    std = np.array([p.std_error for p in result.parameters]) / frame.values[frame.kind_mask()]
    damping = np.array([p.kind == "damping" for p in result.parameters])
    assert np.max(np.abs(err[~damping])) < 0.01 and np.max(np.abs(err[damping])) < 0.1
    assert np.max(np.abs(err / std)) < 4


def test_oscillator_coverage_short_profile():
    """1-DOF (1 kg, 1e4 N/m, 10 N s/m), displacement and force with 2 % noise,
    5 repetitions of a 4 s impulse per run, 20 runs: m, c, k within 1 % and
    the stated 95 % intervals cover the truth in 80-100 % of the runs
    (benchmarks/least_squares_quantities.py: 200 runs)."""
    model = oscillator()
    n = 4001
    force = np.zeros((n, 1))
    force[0, 0] = 100.0
    response = respond(model, force, DT)
    sensors = [("displacement", 1, "x"), ("force", 1, "x")]
    z, err = [], []
    for run in range(20):
        traces = [memory_trace(model, response, DT, sensors, NOISE, seed=900_000 + 10 * run + rep,
                               name=f"r{rep}.h5") for rep in range(5)]
        result = identify(traces, model)
        std = np.array([p.std_error for p in result.parameters])
        err.append(result.values() / model.values - 1)
        z.append((result.values() - model.values) / std)
    assert np.max(np.abs(err)) < 0.01
    coverage = np.mean(np.abs(np.array(z)) < 1.96, axis=0)
    assert np.all((coverage >= 0.8) & (coverage <= 1.0)), coverage


def test_a_dof_without_any_response_is_named(frame, frame_response):
    sensors = [("displacement", 1, "x"), ("velocity", 2, "x"), ("force", 3, "x")]
    trace = memory_trace(frame, frame_response, DT, sensors)
    with pytest.raises(IdentificationError, match=r"DOF \(3, 'x'\) has none; missing channel\(s\) acceleration_3_x "
                                                  r"\(or the displacement or velocity of the same DOF\); "
                                                  r"present: displacement_1_x, force_3_x, velocity_2_x"):
        identify([trace], frame)


BEAM_BIAS_COMPENSATED = [  # the acceleration path before issue 22 (commit 428664e), seed 22
    8.694464856689, 3.294947526412, 1.671789287915, 2.394103818157, 2.422026889471, 1.25176955185,
    5.005381092998, 1.32317684516, 6.593783091024, 3.81370616505, 5.308466582818, 4.145206235124,
    6.995662186219, 1.843635126059, 4.188699154203, 1.358457290007, 6.164419941283, 3.865998099218,
    1.577998141623, 3.565344138737, 1.087097243421, 5.421742254991, 2.34258495094, 3.305187190535,
    3.422669225091, 6.059485787009, 4.492446340163, 2.379146774405, 7.277207933908, 6.600888027279]
BEAM_OLS = [
    7.972039805366, 3.082110991854, 1.537041869167, 2.185010117244, 2.182319174037, 1.140718719187,
    4.569495992764, 1.244829446168, 6.147309173704, 3.324197834445, 5.1413152815, 4.120994619827,
    6.992169512657, 1.775218090167, 4.060400448013, 1.35760875058, 6.094613571643, 3.886293088028,
    1.502052970851, 3.428457448605, 1.080776388269, 5.12723404315, 2.300360919415, 3.324196462551,
    3.376154520485, 6.34269564556, 4.405954606075, 2.254555407111, 6.869384240148, 5.447349321122]


@pytest.mark.parametrize("options, expected", [({}, BEAM_BIAS_COMPENSATED),
                                               ({"estimator": "ols", "samples": 8, "interval": 0.5}, BEAM_OLS)],
                         ids=["bias-compensated", "ols"])
def test_acceleration_only_path_unchanged(options, expected):
    beam = load_model("ch3-free-free-beam")
    dt = 0.01
    t = np.arange(401) * dt
    force = np.zeros((t.size, beam.n_dof))
    force[:, beam.dof_index(7, "w")] = 0.1 * np.cos(t)
    sensors = [("acceleration", n, d) for n, d in beam.dofs] + [("force", 7, "w")]
    trace = memory_trace(beam, respond(beam, force, dt), dt, sensors, {"acceleration": 0.02, "force": 0.02},
                         seed=22)
    result = identify([trace], beam, **options)
    assert result.details["motion"] == ["zoh-simpson"]
    assert result.values() == pytest.approx(expected, rel=1e-9)
