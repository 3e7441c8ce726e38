"""FMUs driven by fmpy (FmuSession) against the exact solutions from models/."""
from __future__ import annotations

import numpy as np
from fmu_fixtures import SHEAR_FRAME

from structbench.harness.fmu_session import FmuSession
from structbench.models import load_model


def responses(model) -> list[str]:
    return [f"{q}_{node}_{d}" for q in "uva" for node, d in model.dofs]


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_ch3_beam_matches_the_exact_discrete_solution(fmus):
    model = load_model("ch3-free-free-beam")
    dt, n = 0.01, 3000
    force = 0.1 * np.cos(np.arange(n) * dt)[:, None]
    with FmuSession(fmus["ch3-free-free-beam"]) as fmu:
        got = fmu.run(["F_7_w"], responses(model), force, dt)
    full = np.zeros((n, model.n_dof))
    full[:, model.dof_index(7, "w")] = force[:, 0]
    ref = model.state_space().simulate(full, dt)
    for k, q in enumerate(("displacement", "velocity", "acceleration")):
        assert relative(got[:, k * model.n_dof:(k + 1) * model.n_dof], ref[q]) < 1e-10, q


def test_ch5_beam_impulse_matches_the_modal_closed_form(fmus):
    beam = load_model("ch5-simply-supported-beam")
    qd0 = beam.shape_function(np.array([10 / 11]))[0]  # 1 N s at x = 10/11 m
    dt, n = 0.02, 2000
    with FmuSession(fmus["ch5-simply-supported-beam"]) as fmu:
        fmu.set_parameters({f"qd0_{r}": v for r, v in enumerate(qd0, start=1)})
        got = fmu.run([], responses(beam)[:2 * beam.n_dof], np.zeros((n, 0)), dt)
    u, v = beam.free_response(np.arange(n) * dt, np.zeros(beam.n_modes), qd0)
    assert relative(got[:, :beam.n_dof], u) < 1e-10
    assert relative(got[:, beam.n_dof:], v) < 1e-10


def test_membrane_conserves_momentum(fmus):
    model = load_model("ch5-membrane")
    velocities = [f"v_{node}_{d}" for node, d in model.dofs]
    with FmuSession(fmus["ch5-membrane"]) as fmu:
        fmu.set_parameters({"v0_5_w": 1.0})
        v = fmu.run([], velocities, np.zeros((5000, 0)), 0.01)
    momentum = v @ model.mass().toarray().sum(axis=0)
    assert abs(v[0, model.dof_index(5, "w")] - 1.0) < 1e-15
    assert np.abs(momentum - momentum[0]).max() < 1e-10 * abs(momentum[0])
    assert np.abs(v - v[0]).max() > 0.1  # it does move


def test_samples_satisfy_the_equation_of_motion_after_a_parameter_change(fmus):
    frame = load_model(SHEAR_FRAME)
    changed = frame.with_values(frame.values * np.linspace(0.8, 1.2, len(frame.parameters)))
    names = {f"{p.name}_{p.element + 1}": v for p, v in zip(changed.parameters, changed.values)}
    inputs = [f"F_{node}_{d}" for node, d in frame.dofs]
    force = np.random.default_rng(1).normal(scale=1e4, size=(400, frame.n_dof))
    with FmuSession(fmus[SHEAR_FRAME]) as fmu:
        fmu.set_parameters(names)
        y = fmu.run(inputs, responses(frame), force, 0.005)
    u, v, a = np.split(y, 3, axis=1)
    m, c, k = (x.toarray() for x in (changed.mass(), changed.damping(), changed.stiffness()))
    residual = a @ m.T + v @ c.T + u @ k.T - force
    assert np.abs(residual).max() < 1e-9 * np.abs(force).max()
    ref = changed.state_space().simulate(force, 0.005)
    assert relative(u, ref["displacement"]) < 1e-10


def test_a_run_continues_until_reset(fmus):
    model = load_model("ch4-cantilever-case1")
    dt = 0.01
    force = np.sin(np.arange(600) * dt)[:, None]
    outputs = responses(model)
    with FmuSession(fmus["ch4-cantilever-case1"]) as fmu:
        whole = fmu.run(["F_7_w"], outputs, force, dt)
        fmu.reset()
        first = fmu.run(["F_7_w"], outputs, force[:250], dt)
        second = fmu.run(["F_7_w"], outputs, force[250:], dt, start_time=250 * dt)
    np.testing.assert_array_equal(np.vstack([first, second]), whole)


def test_instances_and_fmus_run_side_by_side(fmus):
    """Two instances of one FMU and a different FMU, stepped interleaved."""
    dt, n = 0.01, 200
    beam, canti = load_model("ch3-free-free-beam"), load_model("ch4-cantilever-case2")
    f1, f2 = np.ones((n, 1)), -np.ones((n, 1))
    with (FmuSession(fmus["ch3-free-free-beam"], "a") as a, FmuSession(fmus["ch3-free-free-beam"], "b") as b,
          FmuSession(fmus["ch4-cantilever-case2"], "c") as c):
        b.set_parameters({"k_1": 9.0})
        out = {s: [] for s in "abc"}
        for k in range(0, n, 50):
            out["a"].append(a.run(["F_1_w"], ["u_16_w"], f1[k:k + 50], dt, start_time=k * dt))
            out["b"].append(b.run(["F_1_w"], ["u_16_w"], f1[k:k + 50], dt, start_time=k * dt))
            out["c"].append(c.run(["F_7_w"], ["u_7_w"], f2[k:k + 50], dt, start_time=k * dt))
    full = np.zeros((n, beam.n_dof))
    full[:, beam.dof_index(1, "w")] = 1.0
    ref_a = beam.state_space().simulate(full, dt)["displacement"][:, beam.dof_index(16, "w")]
    stiffer = beam.with_values(np.where([p.label == "stiffness[1]" for p in beam.parameters], 9.0, beam.values))
    ref_b = stiffer.state_space().simulate(full, dt)["displacement"][:, beam.dof_index(16, "w")]
    full_c = np.zeros((n, canti.n_dof))
    full_c[:, canti.dof_index(7, "w")] = -1.0
    ref_c = canti.state_space().simulate(full_c, dt)["displacement"][:, canti.dof_index(7, "w")]
    for key, ref in (("a", ref_a), ("b", ref_b), ("c", ref_c)):
        assert relative(np.vstack(out[key])[:, 0], ref) < 1e-10, key
    assert relative(ref_a, ref_b) > 1e-3
