"""FMUs built elsewhere (issue 22): a C mass-spring-damper exported with both
co-simulation (explicit Euler at the communication step) and model exchange.
Diverging output fails its test with no trace written; the step check warns
where the FMU's solver has not converged and not where it has; through model
exchange or substeps the identified omega and zeta are the FMU's own.

References are independent of the harness: forward Euler and the exact
zero-order-hold response computed here with numpy/scipy from the FMU's
parameters (m = 1 kg, k = 1e4 N/m, d = 10 N s/m)."""
from __future__ import annotations

import json
import re
import warnings

import h5py
import numpy as np
import pytest
import scipy.linalg as la

from structbench.cli import main
from structbench.harness.campaign import CampaignError, load_campaign
from structbench.harness.fmu_setup import prepare_fmu
from structbench.harness.noise import rms, with_sensor_noise
from structbench.harness.run import run_campaign
from structbench.harness.simulation import Record, SimulationError, make_trace
from structbench.identifier.io.traces import read_trace
from structbench.identifier.modal import identify as modal
from foreign_fixtures import D, K, M, OMEGA, Y0, ZETA, build_msd

CAMPAIGN = """\
name = "msd"
structure = "{fmu}"
{extra}
[mapping]
force = "f"
displacement = "y"
velocity = "v"

[locations]
1 = [0.0, 0.0, 0.0]

[[tests]]
name = "impulse"
dt = {dt}
duration = {duration}
noise = {{sensor = {noise}}}
excitation = [{{kind = "impulse", node = 1, dir = "x", impulse = 1.0}}]
sensors = [{{nodes = [1], dirs = ["x"], quantities = ["{quantity}", "force"]}}]
"""
AC = np.array([[0.0, 1.0], [-K / M, -D / M]])  # state (x, v): xdot = AC state + B f
B = np.array([0.0, 1.0 / M])


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    root = tmp_path_factory.mktemp("foreign")
    return {"both": build_msd(root), "velocity": build_msd(root, velocity=True),
            "cs": build_msd(root, interfaces=("co-simulation",))}


def write(tmp_path, fmu, extra="", dt=0.001, duration=4.0, noise=0.0, quantity="displacement", name="c"):
    path = tmp_path / f"{name}.toml"
    path.write_text(CAMPAIGN.format(fmu=fmu, extra=extra, dt=dt, duration=duration, noise=noise, quantity=quantity))
    return path


def pulse_response(step_matrix: np.ndarray, input_vector: np.ndarray, n: int, dt: float) -> np.ndarray:
    """States (n, 2) at t_k of the 1 N s pulse (1/dt N over the first sample)
    under the one-sample map state' = step_matrix state + input_vector f."""
    states = np.zeros((n, 2))
    states[1] = input_vector / dt
    for k in range(2, n):
        states[k] = step_matrix @ states[k - 1]
    return states


def euler(dt: float, substeps: int, n: int) -> np.ndarray:
    """Forward Euler with ``substeps`` steps per sample, the force held."""
    one = np.eye(2) + dt / substeps * AC
    power = np.linalg.matrix_power(one, substeps)
    gain = sum(np.linalg.matrix_power(one, j) for j in range(substeps)) @ (dt / substeps * B)
    return pulse_response(power, gain, n, dt)


def exact(dt: float, n: int) -> np.ndarray:
    """The exact zero-order-hold response (matrix exponential)."""
    big = la.expm(np.block([[AC, B[:, None]], [np.zeros((1, 3))]]) * dt)
    return pulse_response(big[:2, :2], big[:2, 2], n, dt)


def channel(out, name):
    with h5py.File(out / "traces" / "impulse.h5") as f:
        return f["channels"][name][()]


# ---- campaign keys ----------------------------------------------------------
@pytest.mark.parametrize("extra, message", [
    ('interface = "model-exchange"', "c.toml:3: interface: Msd-co.fmu offers no model-exchange (it offers co-simulation)"),
    ('[solver]\nrelative_tolerance = 1e-8', "c.toml:3: solver: [solver] is for interface"),
    ("substeps = 0", "c.toml:3: substeps: must be at least 1"),
])
def test_bad_interface_keys_name_the_line(tmp_path, fmus, extra, message):
    with pytest.raises(CampaignError, match=re.escape(message)):
        load_campaign(write(tmp_path, fmus["cs"], extra))


def test_model_exchange_and_substeps_keys_are_refused_together(tmp_path, fmus):
    with pytest.raises(CampaignError, match="substeps: substeps are for co-simulation"):
        load_campaign(write(tmp_path, fmus["both"], 'interface = "model-exchange"\nsubsteps = 4'))


# ---- divergence and non-finite samples ---------------------------------------
def test_divergence_at_2ms_fails_the_test_and_writes_no_trace(tmp_path, fmus):
    """omega h = 0.2 > 2 zeta: Euler grows by |1 + lambda h| = 1.00995 per step."""
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow, no RuntimeWarning anywhere
        status = run_campaign(write(tmp_path, fmus["both"], dt=0.002, noise=0.02), out, jobs=0, check_step="off")
    error = status.tests["impulse"].error
    assert status.tests["impulse"].state == "failed" and "displacement_1_x diverges" in error
    assert "substeps" in error and "model-exchange" in error
    t_bad, value = re.search(r"times at t = ([0-9.e+-]+) s \(([0-9.e+-]+)\)", error).groups()
    k = round(float(t_bad) / 0.002)
    reference = euler(0.002, 1, k + 1)[k, 0] + Y0
    assert float(value) == pytest.approx(reference, rel=2e-3)  # 3 significant digits in the message
    assert abs(reference - Y0) > 100 * 1.0 / (M * OMEGA)  # 100 x the exact response's peak (0.01 m)
    assert not list((out / "traces").glob("*"))


def test_huge_signals_get_noise_without_overflow():
    x = np.array([1e300, -1e300, 5e299])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert rms(x) == pytest.approx(np.sqrt((2 + 0.25) / 3) * 1e300, rel=1e-12)
        noisy = with_sensor_noise(x, 0.02, "rms", np.random.default_rng(1))
    assert np.isfinite(noisy).all()


def test_a_record_with_a_non_finite_sample_makes_no_trace(tmp_path, fmus):
    campaign = load_campaign(write(tmp_path, fmus["both"]))
    bench, test = prepare_fmu(campaign, tmp_path), campaign.tests[0]
    n = test.n_samples
    bad = np.zeros(n)
    bad[7] = np.inf
    record = Record(np.arange(n) * test.dt, {"displacement_1_x": bad, "force_1_x": np.zeros(n)},
                    {"force_1_x": np.zeros(n)})
    with pytest.raises(SimulationError, match=r"impulse.h5: displacement_1_x is inf at t = 0.007 s"):
        make_trace(bench, test, 0, record)


# ---- the step check ---------------------------------------------------------------
def test_step_check_warns_at_1ms_with_the_difference(tmp_path, fmus, capsys):
    """omega h = 0.1 = 2 zeta: Euler's anti-damping cancels the damping."""
    out = tmp_path / "out"
    status = run_campaign(write(tmp_path, fmus["both"]), out, jobs=0)
    assert status.tests["impulse"].state == "done"  # neutral, not diverging: it runs
    [warning] = json.loads((out / "status.json").read_text())["warnings"]
    coarse, fine = euler(0.001, 1, 4001)[:, 0], euler(0.001, 2, 4001)[:, 0]
    assert warning["test"] == "impulse" and warning["channel"] == "displacement_1_x"
    assert warning["difference"] == pytest.approx(np.sqrt(np.mean((coarse - fine) ** 2)), rel=1e-6)
    assert warning["tolerance"] == pytest.approx(0.01 * np.std(coarse + Y0), rel=1e-6)
    assert "substeps = " in warning["message"] and "model-exchange" in warning["message"]
    assert np.allclose(channel(out, "displacement_1_x"), coarse + Y0, rtol=0, atol=1e-12)
    code = main(["run", str(write(tmp_path, fmus["both"], name="d")), "--check-step", "--jobs", "0"])
    printed = capsys.readouterr().out
    assert code == 1 and "WARNING step check: test impulse, displacement_1_x" in printed


def test_velocity_output_is_checked_too(tmp_path, fmus):
    status = run_campaign(write(tmp_path, fmus["velocity"], quantity="velocity"), None, jobs=0, check_step="only")
    [warning] = status.warnings
    coarse, fine = euler(0.001, 1, 4001)[:, 1], euler(0.001, 2, 4001)[:, 1]
    assert warning["channel"] == "velocity_1_x"
    assert warning["difference"] == pytest.approx(np.sqrt(np.mean((coarse - fine) ** 2)), rel=1e-6)


@pytest.mark.parametrize("extra, noise", [("substeps = 20", 0.02), ('interface = "model-exchange"', 0.0)])
def test_no_warning_once_converged(tmp_path, fmus, extra, noise):
    status = run_campaign(write(tmp_path, fmus["both"], extra, duration=2.0, noise=noise), None, jobs=0,
                          check_step="only")
    assert status.warnings == []


# ---- identification through model exchange or substeps ------------------------------
@pytest.mark.parametrize("fmu, extra, quantity, noise", [
    ("both", 'interface = "model-exchange"', "displacement", 0.0),
    ("velocity", 'interface = "model-exchange"', "velocity", 0.0),
    ("both", "substeps = 100", "displacement", 0.02),
])
def test_modal_recovers_the_fmus_omega_and_zeta(tmp_path, fmus, fmu, extra, quantity, noise):
    out = tmp_path / "out"
    status = run_campaign(write(tmp_path, fmus[fmu], extra, duration=2.0, noise=noise, quantity=quantity), out,
                          jobs=0, check_step="off")
    assert status.tests["impulse"].state == "done"
    result = modal([read_trace(out / "traces" / "impulse.h5")])
    [omega], [zeta] = result.omega, result.damping
    assert omega == pytest.approx(OMEGA, rel=1e-3)
    assert zeta == pytest.approx(ZETA, rel=0.05)


def test_model_exchange_matches_the_exact_response(tmp_path, fmus):
    out = tmp_path / "out"
    run_campaign(write(tmp_path, fmus["both"], 'interface = "model-exchange"', duration=1.0), out, jobs=0,
                 check_step="off")
    y = channel(out, "displacement_1_x")
    assert np.abs(y - Y0 - exact(0.001, y.size)[:, 0]).max() < 1e-6 * 1.0 / (M * OMEGA)
    with h5py.File(out / "traces" / "impulse.h5") as f:
        assert (f.attrs["fmu_interface"], f.attrs["relative_tolerance"]) == ("model-exchange", 1e-10)


# ---- the growth rule on its own ------------------------------------------------------
def test_polynomial_growth_passes_and_exponential_growth_fails():
    """t^4 from rest under a constant force (about 2^4 over the latter half)
    is a stable structure's; exp(5 t) over 4 s (exp(10) over the latter half) is not."""
    from structbench.harness.output_check import check_output

    t = np.arange(4001) * 1e-3
    force = np.ones((t.size, 1))
    check_output({"displacement_1_x": 1e-3 + t**4}, force, 1e-3)
    # blocks of 0.2 s; block m = 1 + (j - 1) // 2 peaks at exp(5 (0.2 (m + 1) - 0.001)) - 1, so block
    # j = 14 (m = 7) is the first over 1e3 times; its first sample beyond: log1p(1e3 expm1(5 x 1.599)) / 5
    t_bad = np.ceil(np.log1p(1e3 * np.expm1(5 * 1.599)) / 5 / 1e-3) * 1e-3
    with pytest.raises(SimulationError, match=rf"displacement_1_x diverges: .* at t = {t_bad:.9g} s"):
        check_output({"displacement_1_x": 1e-3 + np.expm1(5 * t)}, force, 1e-3)


def test_the_session_refuses_an_interface_the_fmu_lacks(fmus):
    from structbench.harness.fmu_session import FmuSession
    from structbench.models.errors import UserError

    with pytest.raises(UserError, match="offers no model-exchange"):
        FmuSession(fmus["cs"], interface="model-exchange")
