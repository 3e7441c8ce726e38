"""structbench score: each least-squares parameter's achieved spread beside its Cramer-Rao bound."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import structbench as sb
from structbench.cli.main import main

from test_plan import chain_model, harmonic_campaign


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 3-DOF chain under a harmonic force, 30 noise repetitions, identified
    twice: the default estimator (every sample) and OLS on 8 samples."""
    tmp = tmp_path_factory.mktemp("efficiency")
    model = chain_model(tmp / "three.toml", [1.0, 1.5, 0.8], [40.0, 30.0, 25.0])
    campaign = harmonic_campaign(tmp / "c.toml", model, 0.005, 4.0, 2.0, repetitions=30)
    out = tmp / "out"
    sb.run_campaign(campaign, out, jobs=1)
    sb.identify(out, "least-squares", jobs=1)
    sb.identify(out, "least-squares", tag="ols8", estimator="ols", samples=8, interval=0.5, jobs=1)
    return out


def test_default_estimator_reaches_the_bound(folder: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["score", str(folder), "--json"]) == 0
    scores = json.loads(capsys.readouterr().out)
    eff = scores["least-squares"]["summary"]["efficiency"]
    assert eff["runs"] == 30 and eff["same_settings"] is True and eff["tests"] == ["sine"]
    assert len(eff["parameters"]) == 6
    for p in eff["parameters"]:
        assert set(p) >= {"label", "achieved_std", "bound_std", "efficiency"}
        assert p["efficiency"] == pytest.approx(p["bound_std"] / p["achieved_std"])
    values = np.array([p["efficiency"] for p in eff["parameters"]])
    assert 0.7 < eff["median"] < 1.3, values  # sample std of 30 runs: +-13 % (1 s.e.) per parameter
    assert eff["median"] == pytest.approx(np.median(values))
    ols = scores["least-squares-ols8"]["summary"]["efficiency"]
    assert ols["same_settings"] is False and "ols" in ols["bound"] and "8 samples" in ols["bound"]
    assert len(ols["parameters"]) == 6 and np.isfinite(ols["median"])
    assert main(["score", str(folder)]) == 0
    text = capsys.readouterr().out
    assert "Cramer-Rao" in text and "efficiency" in text


def test_too_few_runs_has_no_efficiency() -> None:
    from structbench.evaluation.efficiency import efficiency
    runs = [{"repetition": i, "tests": ["sine"], "parameters": [{"label": "mass[1]", "value": 1.0}]}
            for i in range(4)]
    assert efficiency(Path("."), {"method": "least-squares"}, runs) is None
    assert efficiency(Path("."), {"method": "modal"}, runs + runs) is None


def test_updating_spread_beside_its_bound(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Updating from the modes of 8 knocks: score shows each stiffness's
    spread beside the bound of `plan --method updating` (the same numbers),
    and no estimator beats a Cramer-Rao bound (efficiency < 2 with 8 runs)."""
    from test_plan_updating import decay_campaign, with_unknown
    model = with_unknown(chain_model(tmp_path / "three.toml", [1.0, 1.0, 1.0], [400.0, 300.0, 200.0]),
                         '["stiffness"]')
    damped = 'unknown = ["stiffness"]\nrayleigh = [0.0, 0.002]'
    model.write_text(model.read_text().replace('unknown = ["stiffness"]', damped))
    campaign = decay_campaign(tmp_path, model, 0.01, 30.0, 0.02, node=3)
    campaign.write_text(campaign.read_text().replace('name = "knock"\ndt', 'name = "knock"\nrepetitions = 8\ndt'))
    out = tmp_path / "out"
    sb.run_campaign(campaign, out, jobs=1)
    sb.identify(out, "modal", jobs=1)
    sb.identify(out, "updating", prior=model, jobs=1, regularisation="none")  # the prior is the truth here:
    # Tikhonov toward it would pull the spread under the bound of unbiased estimators
    assert main(["score", str(out), "--json"]) == 0
    eff = json.loads(capsys.readouterr().out)["updating"]["summary"]["efficiency"]
    planned = {p["label"]: p["predicted_std"] for p in sb.plan(campaign, "updating")["parameters"]}
    assert eff["runs"] == 8 and "updating" in eff["bound"]
    assert {p["label"]: p["bound_std"] for p in eff["parameters"]} == pytest.approx(planned, rel=1e-9)
    assert all(0 < p["efficiency"] < 2 for p in eff["parameters"])


def test_updating_undetermined_parameters_have_no_bound(tmp_path: Path) -> None:
    """Masses and stiffnesses all unknown: their common scale is undetermined
    by modes, so no parameter has a bound; the efficiency rows say null (valid
    JSON), not NaN."""
    from structbench.evaluation.efficiency import efficiency
    from structbench.harness.campaign import load_campaign
    from test_plan_updating import decay_campaign
    model = chain_model(tmp_path / "two.toml", [1.0, 2.0], [300.0, 200.0])
    campaign = load_campaign(decay_campaign(tmp_path, model, 0.01, 30.0, 0.02))
    rng = np.random.default_rng(1)
    runs = [{"repetition": i, "tests": ["knock"], "parameters": [
        {"label": lab, "value": v * (1 + 0.01 * rng.standard_normal())}
        for lab, v in (("mass[1]", 1.0), ("mass[2]", 2.0), ("stiffness[3]", 300.0), ("stiffness[4]", 200.0))]}
        for i in range(6)]
    eff = efficiency(tmp_path, {"method": "updating"}, runs, lambda: campaign)
    assert [p["bound_std"] for p in eff["parameters"]] == [None] * 4
    assert eff["median"] is None
    json.dumps(eff, allow_nan=False)
