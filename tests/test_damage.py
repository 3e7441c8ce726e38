"""Issue 23.3: damage localisation from a baseline prior. The stepwise
search (updating --option localise=true) on modal data of a 25-element
cantilever with element 12 at 80 % stiffness, the damage scores against
hand-computed numbers, and `structbench score` of a folder with [damage]."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from structbench.evaluation.damage_scores import damage_run
from structbench.identifier.updating import ModalData, update
from structbench.models import load_model

ROOT = Path(__file__).resolve().parents[1]
BEAM = ROOT / "campaigns" / "cantilever-25.toml"
DOFS = [(n, "w") for n in (5, 10, 15, 20, 25)]


def damaged(model, element: int = 12, factor: float = 0.8):
    labels = [p.label for p in model.parameters]
    p = model.values.copy()
    p[labels.index(f"stiffness[{element}]")] *= factor
    return model.with_values(p)


def modal_data(model, k: int, rel_omega: float, shape_std: float, rng=None) -> ModalData:
    found = model.modes(k)
    shapes = found.shapes[[model.dof_index(*d) for d in DOFS]]
    shapes = shapes / np.abs(shapes).max(axis=0)
    lam = found.lam.copy()
    if rng is not None:
        lam = lam * (1 + 2 * rel_omega * rng.standard_normal(k))
        shapes = shapes + shape_std * rng.standard_normal(shapes.shape)
    return ModalData(lam, 2 * rel_omega * lam, shapes, np.full(shapes.shape, shape_std), DOFS, "synthetic")


def test_stepwise_search_finds_the_one_damaged_element_exactly_without_noise():
    beam = load_model(BEAM)
    result = update(beam, modal_data(damaged(beam), 6, 5e-4, 0.01), localise=True)
    assert result.details["localisation"]["selected"] == ["stiffness[12]"]
    changes = {p.label: p.value / p.initial - 1 for p in result.parameters}
    assert changes["stiffness[12]"] == pytest.approx(-0.2, abs=1e-6)
    assert all(abs(v) < 1e-12 for k, v in changes.items() if k != "stiffness[12]")
    assert all(p.std_error is None for p in result.parameters if p.label != "stiffness[12]")


def test_stepwise_search_under_noise():
    """0.05 % frequency and 1 % shape noise, baseline = the healthy model:
    the stepwise search names element 12 first, within 3 points, with an
    error under 3 % (a full 25-parameter update spreads the loss)."""
    beam = load_model(BEAM)
    for seed in range(2):
        data = modal_data(damaged(beam), 6, 5e-4, 0.01, np.random.default_rng(500 + seed))
        result = update(beam, data, localise=True)
        assert result.details["localisation"]["selected"][0] == "stiffness[12]"
        p = {q.label: q for q in result.parameters}["stiffness[12]"]
        assert p.value / p.initial - 1 == pytest.approx(-0.2, abs=0.03)
        assert 0 < p.std_error / p.initial < 0.03


def test_damage_scores_of_a_run_against_hand_computed_numbers():
    run = {"parameters": [{"label": "stiffness[1]", "value": 0.97, "initial": 1.0, "std_error": 0.01},
                          {"label": "stiffness[2]", "value": 8.0, "initial": 10.0, "std_error": 0.3},
                          {"label": "stiffness[3]", "value": 5.0, "initial": 5.0, "std_error": None}]}
    out = damage_run(run, {"stiffness[1]": 0.01, "stiffness[2]": 0.4}, {"stiffness[2]": -0.25})
    np.testing.assert_allclose(out["change"][:2], [-0.03, -0.2])
    np.testing.assert_allclose(out["change_std"][:2], [np.sqrt(2) * 0.01, 0.05])
    np.testing.assert_allclose(out["z"][:2], [-0.03 / (np.sqrt(2) * 0.01), -4.0])
    assert out["flagged"] == ["stiffness[2]"] and out["found"] and out["false"] == []
    assert out["size_error_pp"]["stiffness[2]"] == pytest.approx(5.0)
    run["details"] = {"localisation": {}}  # stepwise errors hold the baseline's: the prior's are not added
    assert damage_run(run, {"stiffness[1]": 0.01}, None)["z"][0] == pytest.approx(-3.0)


def test_score_reports_detection_for_a_folder_with_damage(tmp_path):
    import structbench as sb

    (tmp_path / "campaign.toml").write_text('structure = "x.toml"\n[damage]\nelements = [2]\nstiffness_factor = 0.8\n')
    truth = {"format": "structbench-truth", "format_version": 1, "campaign": "c", "structure": "s",
             "source": "model", "model": "finite-element", "unknown": ["stiffness"],
             "parameters": [{"name": f"k_{i}", "label": f"stiffness[{i}]", "kind": "stiffness", "unit": "N/m",
                             "element": i, "value": v} for i, v in ((1, 1.0), (2, 8.0))],
             "omega": [1.0], "zeta": [0.0], "lambda": [1.0], "dofs": [[1, "w"]], "sensor_dofs": [[1, "w"]],
             "mode_shapes": [[1.0]], "mode_shapes_all": [[1.0]]}
    (tmp_path / "truth.json").write_text(json.dumps(truth))
    run = {"method": "updating", "structure": "s", "repetition": 0, "tests": ["t"], "status": "converged",
           "message": "", "iterations": 3, "history": [[1.0, 10.0], [1.01, 8.1]], "misfit_history": [1.0, 0.1],
           "parameters": [{"label": "stiffness[1]", "kind": "stiffness", "unit": "N/m", "value": 1.01,
                           "std_error": 0.01, "initial": 1.0},
                          {"label": "stiffness[2]", "kind": "stiffness", "unit": "N/m", "value": 8.1,
                           "std_error": 0.2, "initial": 10.0}],
           "omega": [1.0], "eigenvalues": [1.0], "details": {}}
    doc = {"format": "structbench-result", "format_version": 1, "method": "updating", "campaign": "c",
           "structure": "s", "model": "s", "software": "x", "options": {}, "runs": [run],
           "prior": {"source": "base.json", "std_errors": {"stiffness[1]": 0.0, "stiffness[2]": 0.0}}}
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "updating.json").write_text(json.dumps(doc))
    damage = sb.score(tmp_path)["updating"]["damage"]
    assert damage["runs"][0]["flagged"] == ["stiffness[2]"]
    assert damage["summary"]["found"] == 1 and damage["summary"]["false_flag_count"] == {}
    assert damage["summary"]["size_error_pp_median"]["stiffness[2]"] == pytest.approx(1.0)
