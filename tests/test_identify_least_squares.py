"""Chapter 3 time-domain least squares on synthetic traces (exact ZOH simulation)."""
from __future__ import annotations

import numpy as np
import pytest

from structbench.identifier.errors import IdentificationError
from structbench.identifier.least_squares import identify
from structbench.identifier.io.traces import read_trace, read_traces
from identify_synth import respond, write_trace
from structbench.models import load_model

DT, DURATION = 0.01, 4.0
SEEDS = range(20)


def nrms(estimate: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean(((estimate - truth) / truth) ** 2)))


def sensors(model, quantities=("displacement", "velocity", "acceleration")):
    return [(q, n, d) for q in quantities for n, d in model.dofs] + [("force", 7, "w")]


def ch3_response(model, dt: float = DT, duration: float = DURATION):
    """Dissertation set-up: 0.1 cos(t) N at node 7, from rest."""
    t = np.arange(round(duration / dt) + 1) * dt
    force = np.zeros((t.size, model.n_dof))
    force[:, model.dof_index(7, "w")] = 0.1 * np.cos(t)
    return respond(model, force, dt)


@pytest.fixture(scope="module")
def beam():
    return load_model("ch3-free-free-beam")


@pytest.fixture(scope="module")
def clean_trace(beam, tmp_path_factory):
    path = tmp_path_factory.mktemp("ch3") / "traces" / "clean.h5"
    return read_trace(write_trace(path, beam, ch3_response(beam), DT, sensors(beam)))


@pytest.fixture(scope="module")
def noisy_runs(beam, tmp_path_factory):
    """2 % noise on accelerations and force; displacements and velocities as
    accurate as integration of finely sampled accelerations makes them (exact)."""
    folder = tmp_path_factory.mktemp("ch3-noisy")
    response = ch3_response(beam)
    for seed in SEEDS:
        write_trace(folder / "traces" / f"r{seed:02d}.h5", beam, response, DT, sensors(beam),
                    noise={"acceleration": 0.02, "force": 0.02}, seed=seed, repetition=seed)
    traces = read_traces(folder)
    truth = beam.values[beam.kind_mask()]
    exact = beam.modes(10).omega
    out = {}
    for m in (4, 8):
        runs = [identify([t], beam, estimator="ols", samples=m, interval=0.5) for t in traces]
        out[m] = {"rms": np.array([nrms(r.values(), truth) for r in runs]),
                  "freq": np.array([np.abs(np.array(r.omega[2:10]) / exact[2:10] - 1) for r in runs]),
                  "runs": runs}
    return out


@pytest.mark.parametrize("m", [4, 8])
def test_noise_free_recovers_all_30_parameters(beam, clean_trace, m):
    result = identify([clean_trace], beam, estimator="ols", samples=m, interval=0.5)
    truth = beam.values[beam.kind_mask()]
    assert len(result.parameters) == 30
    assert result.labels()[:2] == ["mass[1]", "stiffness[1]"]
    assert np.max(np.abs(result.values() / truth - 1)) < 1e-6
    assert result.details["motion"] == ["measured"]
    assert result.details["sample_times"] == pytest.approx(0.5 * np.arange(1, m + 1))
    assert np.allclose(result.omega, beam.modes(10).omega, rtol=1e-6, atol=1e-9)


def test_integrated_displacements_are_exact_for_the_held_force(beam, tmp_path):
    """Velocities and displacements integrated from accelerations sampled at
    1 ms (zero-order-hold aware Simpson rule) are good to 1e-6 as well."""
    dt = 0.001
    trace = read_trace(write_trace(tmp_path / "fine.h5", beam, ch3_response(beam, dt), dt,
                                   sensors(beam, ("acceleration",))))
    result = identify([trace], beam, samples=8, interval=0.5)
    assert result.details["motion"] == ["zoh-simpson"]
    assert np.max(np.abs(result.values() / beam.values[beam.kind_mask()] - 1)) < 1e-6


def test_trapezoid_at_10_ms_shows_the_known_sensitivity(beam, clean_trace):
    truth = beam.values[beam.kind_mask()]
    trapezoid = identify([clean_trace], beam, estimator="ols", samples=4, integration="trapezoid")
    held = identify([clean_trace], beam, estimator="ols", samples=4, integration="zoh-simpson")
    assert nrms(trapezoid.values(), truth) == pytest.approx(0.29, abs=0.01)
    assert nrms(held.values(), truth) < 1e-4


def test_noisy_medians_meet_the_dissertation(noisy_runs):
    med4, med8 = np.median(noisy_runs[4]["rms"]), np.median(noisy_runs[8]["rms"])
    assert med4 <= 0.043 and med8 <= 0.027
    assert med8 < med4


@pytest.mark.parametrize("m", [4, 8])
def test_noisy_identified_frequencies_within_one_percent(noisy_runs, m):
    assert np.all(np.median(noisy_runs[m]["freq"], axis=0) < 0.01)


def test_standard_errors_describe_the_scatter(beam, noisy_runs):
    truth = beam.values[beam.kind_mask()]
    z = np.array([(r.values() - truth) / [p.std_error for p in r.parameters] for r in noisy_runs[8]["runs"]])
    assert 0.3 < np.median(np.abs(z)) < 2.0


def test_damped_beam_noise_free(tmp_path):
    model = load_model("ch3-damped-beam")
    trace = read_trace(write_trace(tmp_path / "damped.h5", model, ch3_response(model), DT, sensors(model)))
    result = identify([trace], model, samples=8)
    truth = model.values[model.kind_mask()]
    assert len(truth) == 45 and {p.kind for p in result.parameters} == {"mass", "damping", "stiffness"}
    assert np.max(np.abs(result.values() / truth - 1)) < 1e-6


def test_rigid_body_motion_alone_names_the_stiffnesses(beam, tmp_path):
    """A mass-proportional load moves the free-free beam as a rigid body."""
    t = np.arange(401) * DT
    translation = np.array([1.0 if d == "w" else 0.0 for _, d in beam.dofs])
    force = np.outer(0.1 * np.cos(t), beam.mass() @ translation)
    trace = read_trace(write_trace(tmp_path / "rigid.h5", beam, respond(beam, force, DT), DT,
                                   sensors(beam)[:-1]))
    with pytest.raises(IdentificationError, match=r"stiffness\[1\].*stiffness\[15\]") as err:
        identify([trace], beam)
    assert "mass[" not in str(err.value)


def test_missing_channel_is_named(beam, tmp_path):
    """The dissertation's set-up needs every acceleration; the default takes
    any one response quantity per DOF and names a DOF that has none."""
    trace = read_trace(write_trace(tmp_path / "gap.h5", beam, ch3_response(beam), DT, sensors(beam),
                                   drop=("acceleration_5_theta",)))
    with pytest.raises(IdentificationError, match="acceleration_5_theta"):
        identify([trace], beam, estimator="ols", samples=8)
    bare = read_trace(write_trace(tmp_path / "bare.h5", beam, ch3_response(beam), DT, sensors(beam),
                                  drop=tuple(f"{q}_5_theta" for q in ("acceleration", "velocity", "displacement"))))
    with pytest.raises(IdentificationError, match=r"DOF \(5, 'theta'\) has none"):
        identify([bare], beam)


def test_model_whose_dofs_do_not_match(clean_trace):
    with pytest.raises(IdentificationError, match="not a free DOF"):
        identify([clean_trace], load_model("ch4-cantilever-case1"))


def test_fewer_equations_than_unknowns(tmp_path):
    model = load_model("ch3-damped-beam")
    trace = read_trace(write_trace(tmp_path / "d.h5", model, ch3_response(model), DT, sensors(model)))
    with pytest.raises(IdentificationError, match=r"fewer equations \(32\) than unknowns \(45\)"):
        identify([trace], model, samples=1)


def test_sample_time_beyond_the_record(beam, clean_trace):
    with pytest.raises(IdentificationError, match="beyond the record"):
        identify([clean_trace], beam, samples=9, interval=0.5)


def test_dependent_columns_are_named():
    """Velocities proportional to displacements make each damping column a
    multiple of its stiffness column (same element pattern)."""
    from structbench.identifier.least_squares import Motion, solve

    model = load_model("ch3-damped-beam")
    rng = np.random.default_rng(1)
    u = rng.standard_normal((4, model.n_dof))
    a = rng.standard_normal((4, model.n_dof))
    v = 2.0 * u
    f = (model.mass() @ a.T + model.damping() @ v.T + model.stiffness() @ u.T).T
    with pytest.raises(IdentificationError, match=r"damping\[1\].*stiffness\[1\]") as err:
        solve(model, Motion(np.arange(4.0), u, v, a, f))
    assert "mass[" not in str(err.value)
