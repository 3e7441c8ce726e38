"""The damped campaign end to end (``campaigns/ch5-damped.toml``, two
impulse repetitions and the four ambient-force realisations its random
gates are set for): the ch5 beam with modal damping through its FMU and the
harness, 2 % noise on every sensor, identified output-only by ``structbench
identify --method modal`` from an impulse and from an unmeasured random
force, scored against ``truth.json`` and gated by the campaign's ``[check]``."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from structbench.cli import main
from e2e_fixtures import CAMPAIGNS, derive, identify, run

BEAM_EXACT = (np.arange(1, 16) * np.pi / 10.0) ** 2


@pytest.fixture(scope="module")
def damped(tmp_path_factory, fmus) -> Path:
    root = tmp_path_factory.mktemp("ch5-damped")
    campaign = derive("ch5-damped", root, {"impulse": {"repetitions": 2}, "random": {}})
    return run(campaign, root / "out", fmus["ch5-simply-supported-beam"].parent)


def test_truth_carries_the_campaign_damping_ratios(damped):
    truth = json.loads((damped / "truth.json").read_text())
    zeta = tomllib.loads((CAMPAIGNS / "ch5-damped.toml").read_text())["parameters"]
    assert truth["zeta"] == pytest.approx([zeta[f"zeta_{r}"] for r in range(1, 16)])
    assert truth["omega"] == pytest.approx(BEAM_EXACT, rel=1e-12)


def test_impulse_and_random_identified_and_gated(damped, capsys):
    impulse = identify(damped, "modal", "--group", "impulse", "--quantity", "velocity", "--tag=impulse")
    random = identify(damped, "modal", "--group", "random", "--quantity", "velocity", "--tag=random")
    s = impulse["summary"]
    visible = [r for r in range(15) if r != 10]
    assert np.abs(np.array(s["freq_error_pct_median"])[visible]).max() < 0.1
    assert np.abs(np.array(s["damping_error_pct_median"])[:10]).max() < 10.0
    assert np.isnan(s["freq_error_pct_median"][10])  # mode 11: a node at every sensor, not invented
    assert random["summary"]["found_fraction"][:10] == [1.0] * 10
    assert (damped / "results" / "modal-random-stabilisation-01.png").is_file()
    capsys.readouterr()
    assert main(["check", str(damped)]) == 0
    assert "FAIL" not in capsys.readouterr().out
