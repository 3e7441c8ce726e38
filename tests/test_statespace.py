"""Exact zero-order-hold discretisation against an independent integrator."""
import numpy as np
from scipy.integrate import solve_ivp

from structbench.models.library import beam
from structbench.models.library import ch5_simply_supported_beam


def test_zoh_matches_solve_ivp_on_a_damped_beam():
    model = beam("damped", [1.0, 2.0, 1.5], [3.0, 1.0, 2.0], 3.0, supports={1: "clamped"},
                 damping=[0.1, 0.05, 0.2])
    ss = model.state_space()
    dt, n = 0.1, 60
    rng = np.random.default_rng(7)
    force = rng.normal(size=(n, model.n_dof))
    out = ss.simulate(force, dt)
    x = np.zeros(ss.n_state)
    for k in range(n):
        sol = solve_ivp(lambda t, y: ss.A @ y + ss.B @ force[k], (0, dt), x, method="DOP853",
                        rtol=1e-13, atol=1e-15)
        x = sol.y[:, -1]
        if k + 1 < n:
            ref = x[: model.n_dof]
            err = np.linalg.norm(out["displacement"][k + 1] - ref) / np.linalg.norm(ref)
            assert err < 1e-8
    np.testing.assert_allclose(out["state"], x, rtol=1e-8, atol=1e-12)


def test_acceleration_satisfies_the_equation_of_motion():
    model = beam("b", [1.0, 2.0], [3.0, 1.0], 2.0, supports={1: "clamped"}, damping=[0.1, 0.2])
    rng = np.random.default_rng(3)
    force = rng.normal(size=(20, model.n_dof))
    out = model.state_space().simulate(force, 0.05)
    m, c, k = (a.toarray() for a in (model.mass(), model.damping(), model.stiffness()))
    residual = out["acceleration"] @ m.T + out["velocity"] @ c.T + out["displacement"] @ k.T - force
    np.testing.assert_allclose(residual, 0, atol=1e-12)


def test_modal_model_simulation_matches_its_closed_form():
    beam_model = ch5_simply_supported_beam()
    ss = beam_model.state_space()
    r = beam_model.n_modes
    qd0 = beam_model.shapes[0]  # 1 N s impulse at point 1 (x = 10/11 m)
    x0 = np.concatenate([np.zeros(r), qd0])
    dt, n = 0.05, 400
    out = ss.simulate(np.zeros((n, beam_model.n_dof)), dt, x0)
    u, v = beam_model.free_response(np.arange(n) * dt, np.zeros(r), qd0)
    np.testing.assert_allclose(out["displacement"], u, atol=1e-12)
    np.testing.assert_allclose(out["velocity"], v, atol=1e-12)
