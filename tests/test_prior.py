"""Issue 23: identifiers start from an honest prior, never the truth.
The campaign's [prior] rule against an independent draw, a prior model file,
a results file as the prior (values and standard errors), the topology the
other methods get, the exit-2 message without a prior, the -postulated
variants, [damage], and the CLI method table listing updating."""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from structbench.dispatch.methods import method
from structbench.dispatch.runs import resolve_prior
from structbench.harness.campaign import CampaignError, load_campaign
from structbench.harness.prior import prior_document
from structbench.identifier.errors import IdentificationError
from structbench.models import load_model

ROOT = Path(__file__).resolve().parents[1]
FRAME = ROOT / "docs" / "examples" / "shear-frame-3.toml"
CAMPAIGN = """name = "c"
structure = "{structure}"
{extra}
[[tests]]
name = "free"
dt = 0.01
duration = 1.0
sensors = [{{nodes = [3], dirs = ["x"], quantities = ["displacement"]}}]
[[tests.excitation]]
kind = "initial"
node = 3
dir = "x"
displacement = 0.01
"""


def campaign(tmp_path: Path, extra: str, structure: str = "frame.toml"):
    (tmp_path / "frame.toml").write_text(FRAME.read_text())
    path = tmp_path / "c.toml"
    path.write_text(CAMPAIGN.format(structure=structure, extra=extra))
    return load_campaign(path)


def traces(structure: str) -> list:
    return [SimpleNamespace(structure=structure)]


def test_scale_rule_draws_log_uniform_factors_from_its_seed(tmp_path):
    c = campaign(tmp_path, "[prior]\nscale = [0.5, 2.0]\nseed = 4\n")
    doc = prior_document(c.prior, c.true_model)
    truth = load_model(FRAME)
    mask = truth.kind_mask()
    expected = truth.values[mask] * np.exp(np.random.default_rng(4).uniform(np.log(0.5), np.log(2.0), mask.sum()))
    assert [p["label"] for p in doc["parameters"]] == [p.label for p, m in zip(truth.parameters, mask) if m]
    np.testing.assert_allclose([p["value"] for p in doc["parameters"]], expected, rtol=1e-12)
    ratio = np.array([p["value"] for p in doc["parameters"]]) / truth.values[mask]
    assert 0.5 <= ratio.min() and ratio.max() <= 2.0 and np.all(np.abs(ratio - 1) > 1e-3)


def test_prior_table_errors_name_the_line(tmp_path):
    with pytest.raises(CampaignError, match=r"c.toml:4: prior.scale: expected \[low, high\]"):
        campaign(tmp_path, "[prior]\nscale = [2.0, 0.5]\n")
    with pytest.raises(CampaignError, match="either model"):
        campaign(tmp_path, "[prior]\nseed = 3\n")


def test_prior_model_file_gives_its_values(tmp_path):
    (tmp_path / "p.toml").write_text(FRAME.read_text().replace("k = 4.0e6", "k = 5.5e6"))
    c = campaign(tmp_path, "[prior]\nmodel = \"p.toml\"\n")
    values = {p["label"]: p["value"] for p in prior_document(c.prior, c.true_model)["parameters"]}
    assert values["stiffness[4]"] == 5.5e6 and values["mass[1]"] == 2000.0


def test_json_priors_set_values_on_the_structure(tmp_path):
    (tmp_path / "frame.toml").write_text(FRAME.read_text())
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "campaign.toml").write_text('structure = "frame.toml"\n')
    run = {"repetition": 0, "parameters": [{"label": "stiffness[4]", "value": 1.0e6, "std_error": 1e4}]}
    results = {"format": "structbench-result", "runs": [run, json.loads(json.dumps(run))]}
    results["runs"][1]["parameters"][0] |= {"value": 3.0e6, "std_error": 3e4}
    (tmp_path / "base.json").write_text(json.dumps(results))
    model, origin = resolve_prior(None, traces("shear-frame-3"), method("updating"), folder,
                                  str(tmp_path / "base.json"))
    labels = [p.label for p in model.parameters]
    assert model.values[labels.index("stiffness[4]")] == pytest.approx(2.0e6)  # median of the two runs
    assert origin["std_errors"] == {"stiffness[4]": pytest.approx(2e4)}
    assert model.values[labels.index("mass[1]")] == 1.0  # not given: not the truth's 2000 kg
    (folder / "prior.json").write_text(json.dumps({"format": "structbench-prior", "source": "[prior] x",
                                                   "parameters": [{"label": "mass[1]", "value": 1234.0}]}))
    model, origin = resolve_prior(None, traces("shear-frame-3"), method("perturbation"), folder)
    assert model.values[labels.index("mass[1]")] == 1234.0 and "[prior] x" in origin["source"]


def test_without_a_prior_the_truth_is_never_handed_over(tmp_path):
    (tmp_path / "frame.toml").write_text(FRAME.read_text())
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "campaign.toml").write_text('structure = "frame.toml"\n')
    for name in ("updating", "perturbation"):
        with pytest.raises(IdentificationError, match=r"--prior MODEL.toml.*prior= in sb.identify.*\[prior\] table"):
            resolve_prior(None, traces("shear-frame-3"), method(name), folder)
    model, origin = resolve_prior(None, traces("shear-frame-3"), method("least-squares"), folder)
    truth = load_model(FRAME)
    mask = truth.kind_mask()
    assert np.all(model.values[mask] == 1.0) and origin["source"].startswith("topology")
    np.testing.assert_array_equal(model.stiffness(np.ones(mask.size)).toarray(),
                                  truth.stiffness(np.ones(mask.size)).toarray())
    model, _ = resolve_prior(None, traces("ch4-cantilever-case1"), method("updating"))
    np.testing.assert_array_equal(model.values, load_model("ch4-cantilever-case1-postulated").values)


def test_cli_exits_2_without_a_prior(tmp_path, capsys):
    import sys
    sys.path.insert(0, str(Path(__file__).parent))
    from identify_synth import respond, write_trace

    from structbench.cli.main import main
    truth = load_model(FRAME)
    force = np.zeros((100, truth.n_dof))
    force[:, 2] = np.random.default_rng(0).standard_normal(100)
    (tmp_path / "frame.toml").write_text(FRAME.read_text())
    folder = tmp_path / "camp"
    write_trace(folder / "traces" / "random-r0.h5", truth, respond(truth, force, 0.01), 0.01,
                [("displacement", n, "x") for n in (1, 2, 3)], test="random", excitation_attrs={"kind": "random"})
    (folder / "campaign.toml").write_text('structure = "frame.toml"\n')
    assert main(["identify", str(folder), "--method", "updating", "--jobs", "1"]) == 2
    assert "--prior MODEL.toml" in capsys.readouterr().err


def test_damage_scales_the_true_stiffness(tmp_path):
    c = campaign(tmp_path, "[damage]\nelements = [5]\nstiffness_factor = 0.8\n")
    truth = load_model(FRAME)
    labels = [p.label for p in truth.parameters]
    ratio = c.true_model.values / truth.values
    assert ratio[labels.index("stiffness[5]")] == pytest.approx(0.8)
    assert np.count_nonzero(np.abs(ratio - 1) > 1e-12) == 1
    with pytest.raises(CampaignError, match="damage.elements"):
        campaign(tmp_path, "[damage]\nelements = [99]\nstiffness_factor = 0.8\n")


def test_cli_method_table_lists_updating_as_the_registry_does():
    import structbench as sb
    from structbench.cli.identify import BUILTIN

    assert set(BUILTIN) == {"least-squares", "perturbation", "rayleigh", "modal", "updating"}
    assert BUILTIN["updating"][0] == sb.methods()["updating"].help
    assert BUILTIN["updating"][1] == dict(sb.methods()["updating"].defaults)
