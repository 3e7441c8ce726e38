"""structbench plan: predicted standard errors against closed forms and Monte Carlo."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize as opt

import structbench as sb
from structbench.cli.main import main
from structbench.planning import free_decay as fd

CHAIN = """name = "chain-{n}"
unknown = ["mass", "stiffness"]
[[nodes]]
id = 0
x = 0.0
{nodes}
[[supports]]
node = 0
fix = ["x"]
{elements}
"""


def chain_model(path: Path, masses: list[float], springs: list[float]) -> Path:
    """A spring-mass chain fixed at node 0 (kg, N/m) as a TOML model."""
    nodes = "\n".join(f"[[nodes]]\nid = {i + 1}\nx = {i + 1.0}" for i in range(len(masses)))
    els = [f'[[elements]]\ntype = "mass"\nnodes = [{i + 1}]\ndir = "x"\nm = {m}' for i, m in enumerate(masses)]
    els += [f'[[elements]]\ntype = "spring"\nnodes = [{i}, {i + 1}]\ndir = "x"\nk = {k}' for i, k in enumerate(springs)]
    path.write_text(CHAIN.format(n=len(masses), nodes=nodes, elements="\n".join(els)))
    return path


def harmonic_campaign(path: Path, model: Path, dt: float, duration: float, omega: float,
                      repetitions: int = 1) -> Path:
    path.write_text(f"""name = "plan-test"
structure = "{model.name}"
seed = 5
[[tests]]
name = "sine"
dt = {dt}
duration = {duration}
repetitions = {repetitions}
noise = {{sensor = {{acceleration = 0.02, force = 0.02}}}}
[[tests.excitation]]
kind = "harmonic"
node = 1
dir = "x"
amplitude = 1.0
omega = {omega}
[[tests.sensors]]
nodes = "all"
quantities = ["acceleration", "velocity", "displacement"]
[[tests.sensors]]
nodes = [1]
dirs = ["x"]
quantities = ["force"]
""")
    return path


def test_least_squares_one_dof_closed_form(tmp_path: Path) -> None:
    """One mass on a spring: F = [sum a^2, sum a u; sum a u, sum u^2] / (m^2 sa^2 + sf^2)."""
    m, k, f0, w, dt, T = 2.0, 50.0, 1.0, 3.0, 0.01, 10.0
    model = chain_model(tmp_path / "one.toml", [m], [k])
    doc = sb.plan(harmonic_campaign(tmp_path / "c.toml", model, dt, T, w), "least-squares")
    t = np.arange(round(T / dt) + 1) * dt
    wn = np.sqrt(k / m)
    u = f0 / (k - m * w**2) * (np.cos(w * t) - np.cos(wn * t))  # from rest, continuous force
    a = f0 / (k - m * w**2) * (-w**2 * np.cos(w * t) + wn**2 * np.cos(wn * t))
    f = f0 * np.cos(w * t)
    var_e = m**2 * (0.02 * np.sqrt(np.mean(a**2)))**2 + (0.02 * np.sqrt(np.mean(f**2)))**2
    F = np.array([[a @ a, a @ u], [a @ u, u @ u]]) / var_e
    expected = np.sqrt(np.diag(np.linalg.inv(F)))
    got = {p["label"]: p["predicted_std"] for p in doc["parameters"]}
    assert list(got) == ["mass[1]", "stiffness[2]"]
    np.testing.assert_allclose([got["mass[1]"], got["stiffness[2]"]], expected, rtol=0.03)


def test_least_squares_verify_three_dof(tmp_path: Path) -> None:
    """Predicted against 40 Monte Carlo runs through the FMU and the identifier."""
    model = chain_model(tmp_path / "three.toml", [1.0, 1.5, 0.8], [40.0, 30.0, 25.0])
    campaign = harmonic_campaign(tmp_path / "c.toml", model, 0.005, 4.0, 2.0)
    doc = sb.plan(campaign, "least-squares", verify=40, seed=11, jobs=1)
    ver = doc["verify"]
    assert ver["runs"] == 40 and len(ver["parameters"]) == 6
    ratios = np.array([p["ratio"] for p in ver["parameters"]])
    assert 0.8 < np.median(ratios) < 1.25, ratios  # sample std of 40 runs: +-11 % (1 s.e.) per quantity
    assert np.all((ratios > 0.6) & (ratios < 1.5)), ratios


def test_modal_bound_undamped_sinusoid_closed_form() -> None:
    """A long, nearly undamped real sinusoid: var(omega) = 24 sigma^2 / (A^2 N^3 dt^2) (Kay 1993, eq. 3.41:
    12 / (eta N (N^2 - 1)) rad^2/sample^2, eta = A^2 / (2 sigma^2)), the decay rate alpha the same, so
    std(zeta) = std(alpha) / omega."""
    w, dt, n, amp, ratio = 2.0, 0.05, 4000, 1.0, 0.1
    d = fd.Decay(np.array([w]), np.array([1e-9]), np.array([0.0]), np.array([amp]), np.ones((1, 1)), dt, n)
    beta = fd.amplitudes(d, np.array([0]), np.array([0]))
    gram, Q = fd.bases(d)
    sigma = fd.channel_sigma(beta, np.array([ratio]), gram)
    cov = fd.omega_zeta_covariance(d, fd.channel_information(beta, sigma, Q).sum(axis=0))[0]
    expected = np.sqrt(24.0 / n**3) * sigma[0] / (amp * dt)
    np.testing.assert_allclose(sigma[0], ratio * amp / np.sqrt(2), rtol=1e-3)
    np.testing.assert_allclose(np.sqrt(cov[0, 0]), expected, rtol=0.01)
    np.testing.assert_allclose(np.sqrt(cov[1, 1]), expected / w, rtol=0.01)


def test_modal_bound_two_damped_modes_monte_carlo() -> None:
    """Two damped modes on two channels: the bound against 150 maximum-likelihood
    fits (nonlinear least squares, an efficient estimator) of seeded noisy records."""
    omega, zeta, dt, n = np.array([1.0, 2.7]), np.array([0.02, 0.03]), 0.1, 1500
    shapes = np.array([[1.0, 0.8], [0.6, -1.0]])
    d = fd.Decay(omega, zeta, np.zeros(2), np.array([1.0, 0.5]), shapes, dt, n)
    rows, orders = np.array([0, 1]), np.array([0, 0])
    beta = fd.amplitudes(d, rows, orders)
    gram, Q = fd.bases(d)
    sigma = fd.channel_sigma(beta, np.full(2, 0.05), gram)
    cov = fd.omega_zeta_covariance(d, fd.channel_information(beta, sigma, Q).sum(axis=0))
    t = np.arange(n) * dt

    def signal(x: np.ndarray) -> np.ndarray:
        w, z, amps = x[:2], x[2:4], x[4:].reshape(2, 2, 2)  # (channel, mode, cos/sin)
        env = np.exp(-np.outer(t, z * w))
        wd = w * np.sqrt(1 - z**2)
        c, s = env * np.cos(np.outer(t, wd)), env * np.sin(np.outer(t, wd))
        return np.stack([c @ amps[ch, :, 0] + s @ amps[ch, :, 1] for ch in range(2)])

    truth = np.concatenate([omega, zeta, beta.ravel()])
    clean = signal(truth)
    rng = np.random.default_rng(20261126)
    fits = []
    for _ in range(150):
        y = clean + sigma[:, None] * rng.standard_normal(clean.shape)
        res = opt.least_squares(lambda x: ((signal(x) - y) / sigma[:, None]).ravel(), truth, method="lm")
        fits.append(res.x[:4])
    achieved = np.std(np.array(fits), axis=0, ddof=1)
    predicted = np.concatenate([np.sqrt(cov[:, 0, 0]), np.sqrt(cov[:, 1, 1])])
    np.testing.assert_allclose(achieved, predicted, rtol=0.2)  # 150 runs: +-6 % (1 s.e.)


def test_modal_verify_free_decay_three_dof(tmp_path: Path) -> None:
    """Predicted against 40 Monte Carlo runs of a free decay through the FMU
    and the modal method: its maximum-likelihood refinement of the SSI poles
    (identifier/modal/refine.py) reaches the bound (SSI-cov alone: 1.3-2.3
    times it here, median 1.6)."""
    model = chain_model(tmp_path / "three.toml", [1.0, 1.5, 0.8], [40.0, 30.0, 25.0])
    model.write_text(model.read_text().replace("[[nodes]]", "rayleigh = [0.04, 0.002]\n[[nodes]]", 1))
    (tmp_path / "c.toml").write_text(f"""name = "plan-decay"
structure = "{model.name}"
seed = 5
[[tests]]
name = "tap"
dt = 0.02
duration = 150.0
noise = {{sensor = 0.02}}
[[tests.excitation]]
kind = "impulse"
node = 1
dir = "x"
impulse = 1.0
method = "initial-velocity"
[[tests.sensors]]
nodes = "all"
quantities = ["displacement"]
""")
    doc = sb.plan(tmp_path / "c.toml", "modal", verify=40, seed=3, jobs=1)
    ver = doc["verify"]
    assert [m["runs"] for m in ver["modes"]] == [40, 40, 40]
    ratios = np.array([m[k] for m in ver["modes"] for k in ("omega_ratio", "zeta_ratio")])
    assert 0.8 < np.median(ratios) < 1.25, ratios  # sample std of 40 runs: +-11 % (1 s.e.) per quantity
    assert np.all((ratios > 0.6) & (ratios < 1.5)), ratios


def test_cli_json_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    model = chain_model(tmp_path / "two.toml", [1.0, 2.0], [30.0, 20.0])
    campaign = harmonic_campaign(tmp_path / "c.toml", model, 0.01, 4.0, 2.0)
    assert main(["plan", str(campaign), "--method", "least-squares", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["format"] == "structbench-plan" and doc["test"] == "sine" and doc["modes"] == []
    assert [p["label"] for p in doc["parameters"]] == ["mass[1]", "mass[2]", "stiffness[3]", "stiffness[4]"]
    assert all(p["predicted_std"] > 0 for p in doc["parameters"])
    assert main(["plan", str(campaign), "--method", "least-squares"]) == 0
    assert "predicted std" in capsys.readouterr().out
    assert main(["plan", str(campaign), "--method", "modal"]) == 2  # a harmonic test is no free decay
    assert "free decay" in capsys.readouterr().err


def test_layout_beats_random_layouts(tmp_path: Path) -> None:
    """10 of 24 candidate DOFs of a damped beam: the chosen layout's log det
    and predicted omega errors against 200 seeded random layouts; the written
    campaign loads and measures exactly the chosen channels."""
    from structbench.planning import layouts
    lines = ['name = "beam12"', "rayleigh = [0.004, 0.004]"]
    lines += [f"[[nodes]]\nid = {i + 1}\nx = {i * 10 / 12!r}" for i in range(13)]
    lines += [f'[[elements]]\ntype = "beam"\nnodes = [{i + 1}, {i + 2}]\nm = 1.0\nk = {(12 / 10) ** 3!r}'
              for i in range(12)]
    lines += ['[[supports]]\nnode = 1\nfix = ["w"]', '[[supports]]\nnode = 13\nfix = ["w"]']
    (tmp_path / "beam12.toml").write_text("\n".join(lines) + "\n")
    (tmp_path / "c.toml").write_text("""structure = "beam12.toml"
[[tests]]
name = "knock"
dt = 0.05
duration = 300.0
noise = {sensor = 0.02}
[[tests.excitation]]
kind = "impulse"
node = 3
dir = "w"
impulse = 1.0
method = "initial-velocity"
[[tests.sensors]]
nodes = [2, 5]
dirs = ["w"]
quantities = ["displacement"]
""")
    (tmp_path / "cand.csv").write_text("node,dir,quantity\n" + "".join(
        f"{n},{d},displacement\n" for n in range(1, 14) for d in ("w", "theta") if not (d == "w" and n in (1, 13))))
    doc = sb.plan(tmp_path / "c.toml", "modal", candidates=tmp_path / "cand.csv", sensors=10,
                  layout_out=tmp_path / "layout.toml")
    lay = doc["layout"]
    assert lay["candidates"] == 24 and len(lay["sensors"]) == 10
    campaign = sb.load_campaign(tmp_path / "layout.toml")
    assert sorted(c.name for c in campaign.tests[0].channels) == sorted(
        f"{q}_{n}_{d}" for n, d, q in lay["sensors"])
    model = sb.load_campaign(tmp_path / "c.toml")
    cands = layouts.read_candidates(tmp_path / "cand.csv", model.model)
    info, psi, d = layouts.candidate_information(model.model, model.tests[0], cands)
    eps = layouts.RIDGE * float(np.max(np.diag(info.sum(axis=0))))
    rng = np.random.default_rng(24)
    random = [layouts.evaluate(info, d, rng.choice(len(cands), 10, replace=False).tolist(), eps)
              for _ in range(200)]
    best = lay["layouts"]["d-optimal"]
    assert best["log_det"] >= max(r["log_det"] for r in random)
    assert best["median_rel_omega_std"] < 0.8 * np.median([r["median_rel_omega_std"] for r in random])
    chosen = lay["layouts"][lay["chosen"]]  # the default criterion: the frequencies' predicted RMS error
    assert lay["criterion"] == "frequencies" and chosen["rms_rel_omega_std"] <= best["rms_rel_omega_std"]
    assert chosen["rms_rel_omega_std"] < 0.8 * np.median([r["rms_rel_omega_std"] for r in random])
    efi = layouts.effective_independence(psi, np.arange(len(cands)), 10)  # Kammer's own criterion, det(Psi^T Psi)
    kammer = [np.linalg.slogdet(psi[i].T @ psi[i])[1] for i in
              [efi] + [rng.choice(len(cands), 10, replace=False) for _ in range(200)]]
    assert kammer[0] > np.percentile(kammer[1:], 95)
    assert [m["omega"] for m in doc["modes"]][:3] == pytest.approx(lay["modes_planned"][:3], rel=1e-12)


def test_least_squares_errors_in_variables_monte_carlo(tmp_path: Path) -> None:
    """A frame with a light appendage under a random force: the noisy accelerations
    in the regressors add about 50 % to the variance (second order,
    ``F^-1 M2 F^-1``); the prediction against 80 seeded Monte Carlo runs of the
    identifier's estimator on noisy copies of the responses."""
    from structbench.identifier.least_squares import Motion, solve_compensated
    from structbench.planning.fisher import motion
    from structbench.planning.response import simulate_test
    model = chain_model(tmp_path / "frame.toml", [3.0, 2.5, 2.5, 2.0, 0.4], [900.0, 800.0, 700.0, 600.0, 60.0])
    text = harmonic_campaign(tmp_path / "c.toml", model, 0.005, 20.0, 1.0).read_text()
    text = text.replace('kind = "harmonic"\nnode = 1', 'kind = "random"\nnode = 2').replace(
        "amplitude = 1.0\nomega = 1.0", "rms = 5.0\nband = [0.0, 60.0]\nseed = 3").replace("nodes = [1]", "nodes = [2]")
    (tmp_path / "c.toml").write_text(text)
    doc = sb.plan(tmp_path / "c.toml", "least-squares")
    predicted = np.array([p["predicted_std"] for p in doc["parameters"]])
    campaign = sb.load_campaign(tmp_path / "c.toml")
    clean = motion(campaign.model, simulate_test(campaign.model, campaign.tests[0]))
    rng = np.random.default_rng(99)
    values = []
    for _ in range(80):
        noisy = {q: getattr(clean, q) + clean.sigma[q] * rng.standard_normal(clean.force.shape)
                 for q in ("acceleration", "force")}
        values.append(solve_compensated(campaign.model, Motion(clean.times, clean.displacement, clean.velocity,
                                                               noisy["acceleration"], noisy["force"],
                                                               clean.sigma)).values)
    ratio = np.std(values, axis=0, ddof=1) / predicted
    assert 0.85 < np.median(ratio) < 1.12, ratio  # 0.96 here; first order alone (M2 = 0): 1.19


def test_files_a_plan_writes_keep_the_campaigns_relative_paths(tmp_path: Path) -> None:
    """A test driven by a recorded force (CSV beside the campaign) with a
    ``[prior]`` model file: ``--verify`` (its campaign written into another
    folder) runs, and the layout-style file written elsewhere loads with the
    same signal, structure and prior."""
    from structbench.planning.campaign_files import test_campaign
    project = tmp_path / "project"
    (project / "records").mkdir(parents=True)
    chain_model(project / "two.toml", [1.0, 2.0], [30.0, 20.0])
    chain_model(project / "design.toml", [1.1, 2.1], [33.0, 18.0])
    t = np.arange(401) * 0.01
    force = np.cos(2.0 * t) + 0.5 * np.sin(7.0 * t)
    (project / "records" / "drive.csv").write_text(
        "time [s],F [kN]\n" + "".join(f"{a:.6g},{b / 1e3:.9g}\n" for a, b in zip(t, force)))
    text = harmonic_campaign(project / "c.toml", project / "two.toml", 0.01, 4.0, 2.0).read_text()
    text = text.replace('kind = "harmonic"', 'kind = "recorded"\nfile = "records/drive.csv"')
    text = text.replace("amplitude = 1.0\nomega = 2.0\n", "").replace("seed = 5\n", 'seed = 5\n[prior]\nmodel = "design.toml"\n')
    (project / "c.toml").write_text(text)
    doc = sb.plan(project / "c.toml", "least-squares", verify=3, seed=2, jobs=1)
    assert doc["verify"]["runs"] == 3 and all(p["achieved_std"] > 0 for p in doc["verify"]["parameters"])
    elsewhere = tmp_path / "elsewhere" / "c.toml"
    elsewhere.parent.mkdir()
    elsewhere.write_text(test_campaign(project / "c.toml", "sine", repetitions=2))
    moved, original = sb.load_campaign(elsewhere), sb.load_campaign(project / "c.toml")
    (item,) = moved.tests[0].excitation
    np.testing.assert_array_equal(item.force(t, 0.01), original.tests[0].excitation[0].force(t, 0.01))
    assert item.force(t[:3], 0.01) == pytest.approx(force[:3], rel=1e-8)
    assert moved.model.values.tolist() == original.model.values.tolist()
    assert Path(tomllib.loads(elsewhere.read_text())["prior"]["model"]) == (project / "design.toml").resolve()
