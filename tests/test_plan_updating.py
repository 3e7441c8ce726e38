"""structbench plan --method updating: the Cramer-Rao bound of updated element
parameters against maximum-likelihood fits, a closed form and the rank of
what modes can tell apart."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as la
import scipy.optimize as opt

import structbench as sb
from structbench.harness.campaign import load_campaign
from structbench.models import load_model
from structbench.planning.updating import updating_bounds

from test_plan import chain_model

DECAY = """name = "knock"
structure = "{model}"
seed = 3
[[tests]]
name = "knock"
dt = {dt}
duration = {duration}
noise = {{sensor = {noise}}}
[[tests.excitation]]
kind = "impulse"
node = {node}
dir = "x"
impulse = 1.0
method = "initial-velocity"
[[tests.sensors]]
nodes = "all"
dirs = ["x"]
quantities = ["{quantity}"]
"""


def decay_campaign(tmp_path: Path, model: Path, dt: float, duration: float, noise: float, node: int = 2,
                   quantity: str = "displacement") -> Path:
    path = tmp_path / "knock.toml"
    path.write_text(DECAY.format(model=model.name, dt=dt, duration=duration, noise=noise, node=node,
                                 quantity=quantity))
    return path


def with_unknown(path: Path, unknown: str) -> Path:
    text = path.read_text().replace('unknown = ["mass", "stiffness"]', f"unknown = {unknown}")
    path.write_text(text)
    return path


def test_one_dof_stiffness_closed_form(tmp_path: Path) -> None:
    """One mass on a spring, its stiffness updated from the free decay: k = m omega^2,
    so std(k) / k = 2 std(omega) / omega, the modal bound of the same record."""
    model = with_unknown(chain_model(tmp_path / "one.toml", [2.0], [800.0]), '["stiffness"]')
    campaign = decay_campaign(tmp_path, model, 0.01, 20.0, 0.05, node=1)
    spec = load_campaign(campaign).tests[0]
    bound = updating_bounds(load_model(model), spec)
    modal = sb.plan(campaign, "modal")["modes"][0]
    (k,) = bound["parameters"]
    assert bound["rank"] == 1 and k["label"] == "stiffness[2]"
    assert k["predicted_std"] / 800.0 == pytest.approx(2 * modal["predicted_omega_std"] / modal["omega"], rel=1e-3)


def test_mass_and_stiffness_scale_is_undetermined(tmp_path: Path) -> None:
    """Masses and stiffnesses all unknown: scaling all of them together changes
    neither frequencies nor shapes, so one combination (equal weights) is
    undetermined and every parameter loaded on it has no bound."""
    model = chain_model(tmp_path / "two.toml", [1.0, 2.0], [300.0, 200.0])
    spec = load_campaign(decay_campaign(tmp_path, model, 0.01, 30.0, 0.02)).tests[0]
    bound = updating_bounds(load_model(model), spec)
    assert bound["rank"] == 3 and len(bound["undetermined"]) == 1
    weights = np.array([abs(c["weight"]) for c in bound["undetermined"][0]])
    np.testing.assert_allclose(weights, 0.5, atol=1e-6)
    assert all(p["predicted_std"] is None for p in bound["parameters"])


def _chain_signal(alpha: np.ndarray, s: np.ndarray, amp: np.ndarray, k0: np.ndarray, m: np.ndarray,
                  t: np.ndarray) -> np.ndarray:
    """Displacements (2, n) of the two-mass chain's free decay: its modes from
    ``eigh`` at stiffnesses ``k0 (1 + alpha)``, decay rates ``s``, modal
    amplitudes ``amp`` (2 modes, cos/sin)."""
    k = k0 * (1 + alpha)
    K = np.array([[k[0] + k[1], -k[1]], [-k[1], k[1]]])
    lam, phi = la.eigh(K, np.diag(m))
    phi = phi * np.sign(phi[1])
    wd = np.sqrt(lam - s**2)
    env = np.exp(-np.outer(t, s))
    q = env * (np.cos(np.outer(t, wd)) * amp[:, 0] + np.sin(np.outer(t, wd)) * amp[:, 1])
    return phi @ q.T


def test_two_dof_bound_against_maximum_likelihood_fits(tmp_path: Path) -> None:
    """Two stiffnesses of a two-mass chain from its free decay at two
    displacement sensors: the bound against the spread of 150 maximum-likelihood
    fits (nonlinear least squares over stiffnesses, decay rates and modal
    amplitudes, efficient) of seeded noisy records built from ``eigh``."""
    m, k0, dt, duration, ratio = np.array([1.0, 2.0]), np.array([300.0, 200.0]), 0.01, 12.0, 0.05
    model = with_unknown(chain_model(tmp_path / "two.toml", list(m), list(k0)), '["stiffness"]')
    spec = load_campaign(decay_campaign(tmp_path, model, dt, duration, ratio)).tests[0]
    bound = updating_bounds(load_model(model), spec)
    predicted = np.array([p["predicted_std"] for p in bound["parameters"]]) / k0
    assert bound["rank"] == 2 and np.all(predicted > 0)
    t = np.arange(spec.n_samples) * dt
    K = np.array([[k0.sum(), -k0[1]], [-k0[1], k0[1]]])
    lam, phi = la.eigh(K, np.diag(m))
    phi = phi * np.sign(phi[1])
    qd0 = phi.T @ np.array([0.0, 1.0])  # 1 N s at mass 2
    amp = np.stack([np.zeros(2), qd0 / np.sqrt(lam)], axis=1)
    s = np.zeros(2)
    clean = _chain_signal(np.zeros(2), s, amp, k0, m, t)
    sigma = ratio * np.sqrt(np.mean(clean**2, axis=1))
    truth = np.concatenate([np.zeros(2), s, amp.ravel()])

    def residual(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return ((_chain_signal(x[:2], x[2:4], x[4:].reshape(2, 2), k0, m, t) - y) / sigma[:, None]).ravel()

    rng = np.random.default_rng(20261126)
    fits = [opt.least_squares(residual, truth, args=(clean + sigma[:, None] * rng.standard_normal(clean.shape),),
                              method="lm").x[:2] for _ in range(150)]
    achieved = np.std(np.array(fits), axis=0, ddof=1)
    np.testing.assert_allclose(achieved, predicted, rtol=0.2)  # 150 runs: +-6 % (1 s.e.)


def test_plan_cli_updating(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from structbench.cli.main import main
    model = with_unknown(chain_model(tmp_path / "three.toml", [1.0, 1.0, 1.0], [400.0, 300.0, 200.0]),
                         '["stiffness"]')
    campaign = decay_campaign(tmp_path, model, 0.01, 30.0, 0.02, node=3, quantity="acceleration")
    assert main(["plan", str(campaign), "--method", "updating"]) == 0
    out = capsys.readouterr().out
    assert "stiffness[4]" in out and "predicted std" in out
    doc = sb.plan(campaign, "updating")
    assert [p["label"] for p in doc["parameters"]] == ["stiffness[4]", "stiffness[5]", "stiffness[6]"]
    assert len(doc["modes_used"]) == 3 and doc["rank"] == 3


def test_verify_updating_is_not_below_the_bound(tmp_path: Path) -> None:
    """--verify through the FMU: modal then updating per repetition; no
    estimator beats the Cramer-Rao bound, so the achieved spread (12
    repetitions: +-21 %) is at least half of it, and every repetition is
    updated from its own modes (a spread, not zero)."""
    model = with_unknown(chain_model(tmp_path / "three.toml", [1.0, 1.0, 1.0], [400.0, 300.0, 200.0]),
                         '["stiffness"]')
    damped = 'unknown = ["stiffness"]\nrayleigh = [0.0, 0.002]'
    model.write_text(model.read_text().replace('unknown = ["stiffness"]', damped))
    campaign = decay_campaign(tmp_path, model, 0.01, 30.0, 0.02, node=3)
    doc = sb.plan(campaign, "updating", verify=12, seed=4, jobs=1)
    rows = doc["verify"]["parameters"]
    assert [r["runs"] for r in rows] == [12, 12, 12]
    assert all(r["ratio"] is not None and r["ratio"] > 0.5 for r in rows)
