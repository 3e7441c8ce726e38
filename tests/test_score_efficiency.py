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
