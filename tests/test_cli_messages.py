"""What the commands say: modal scores in full (modes not found, invented,
damping errors, coverage), identify taking a TOML campaign's structure,
true headers of ``modes`` and ``traces``, model-file errors naming file,
line and field, and the format documents agreeing with the code."""
from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import structbench as sb
from identify_synth import harmonic_force, respond, write_trace
from structbench import api
from structbench.cli import main
from structbench.evaluation.modal_scores import modal_scores, modal_summary
from structbench.models import load_model

ROOT = Path(__file__).resolve().parents[1]
FRAME = ROOT / "docs" / "examples" / "shear-frame-3.toml"
SENSORS = [(q, n, "x") for q in ("displacement", "velocity", "acceleration") for n in (1, 2, 3)] + [("force", 3, "x")]


# ---- score: modal results ------------------------------------------------------

def _modal_scores() -> dict:
    """Two runs of a modal result on three true modes: mode 1 never found, a
    spurious mode at 1.5 rad/s, mode 3 with true damping 0 (no relative error)."""
    truth = {"omega": [1.0, 2.0, 3.0], "zeta": [0.01, 0.02, 0.0], "sensor_dofs": [[1, "w"], [2, "w"]],
             "mode_shapes": [[1.0, 1.0, 0.0], [1.0, -1.0, 1.0]]}
    run = {"method": "modal", "omega": [1.5, 2.002, 3.0], "damping": [0.1, 0.021, 0.001],
           "omega_std": [0.001, 0.0011, 0.01], "damping_std": [0.001, 0.0005, 0.01],
           "mode_shapes": [[0.3, 0.7], [1.0, -1.0], [0.0, 1.0]], "sensors": ["velocity_1_w", "velocity_2_w"]}
    runs = [modal_scores(run, truth) | {"repetition": r, "status": "ok"} for r in range(2)]
    return {"modal": {"method": "modal", "summary": {"runs": 2} | modal_summary(runs), "runs": runs}}


def test_score_text_shows_the_modal_scores_in_full(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(api, "score", lambda folder: _modal_scores())
    assert main(["score", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "nan" not in out
    assert "2 of 3 true modes found" in out and "missed: mode(s) 1" in out
    assert "invented (spurious) modes per run: median 1" in out
    assert "frequencies 100 % of 4, damping ratios 50 % of 4" in out  # coverage of the stated errors
    rows = {line.split()[0]: line.split() for line in out.splitlines()[4:]}
    assert rows["1"][2:] == ["0", "%", "not", "found"]  # found in 0 % of the runs
    assert rows["2"][2:] == ["100", "%", "+0.100", "+5.00", "100", "%", "0", "%", "1.000"]  # found, errors, cover, MAC
    assert rows["3"][5] == "-"  # true damping 0: no relative damping error


# ---- identify: the structure of a campaign built from a TOML model -------------

def _toml_campaign(tmp_path: Path, structure: str) -> Path:
    """A campaign folder as ``structbench run`` leaves it for a campaign file
    in ``tmp_path`` naming the model file ``structure`` (relative to it)."""
    (tmp_path / "models").mkdir()
    shutil.copy(FRAME, tmp_path / "models" / "frame.toml")
    out = tmp_path / "out"
    model = load_model(FRAME)
    t = np.arange(401) * 0.01
    response = respond(model, harmonic_force(model, 3, "x", 1000.0, 5.0, t), 0.01)
    write_trace(out / "traces" / "h0.h5", model, response, 0.01, SENSORS, test="h0", excitation_attrs={"omega": 5.0})
    (out / "campaign.toml").write_text(f'name = "frame"\nstructure = "{structure}"\n')
    return out


def test_identify_takes_the_toml_structure_of_the_campaign(tmp_path, monkeypatch, capsys):
    out = _toml_campaign(tmp_path, "models/frame.toml")
    monkeypatch.chdir(out)  # not where the campaign file was: found beside the folder
    assert main(["identify", str(out), "--method", "least-squares", "--jobs", "1"]) == 0
    document = json.loads((out / "results" / "least-squares.json").read_text())
    assert document["model"] == "shear-frame-3"
    values = {p["label"]: p["value"] for p in document["runs"][0]["parameters"]}
    assert values["mass[1]"] == pytest.approx(2000.0, rel=1e-6) and values["stiffness[6]"] == pytest.approx(3e6, rel=1e-6)


def test_identify_names_the_campaign_model_it_cannot_find(tmp_path, capsys):
    out = _toml_campaign(tmp_path, "models/moved.toml")
    assert main(["identify", str(out), "--method", "least-squares", "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert "'shear-frame-3' is not a known model" in err and "'models/moved.toml'" in err and "--model" in err


# ---- modes and traces headers ----------------------------------------------------

def test_modes_header_of_a_modal_model(capsys):
    assert main(["modes", "ch5-simply-supported-beam", "--count", "20"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("ch5-simply-supported-beam (modal model, 15 modes; forces and sensors at 10 DOF): "
                               "modes 1-15")
    assert len(lines) == 16
    assert main(["modes", "ch3-free-free-beam", "--count", "3"]) == 0
    assert "(finite-element model, 32 DOF, 32 modes): modes 1-3" in capsys.readouterr().out


def test_traces_of_an_imported_folder_say_what_it_is(tmp_path, capsys):
    out = _toml_campaign(tmp_path, "models/frame.toml")
    sb.export_traces(out, "csv", tmp_path / "lab")
    sb.import_data([tmp_path / "lab" / "h0.csv"], tmp_path / "imported", tmp_path / "lab" / "sensor-map.toml")
    assert main(["traces", str(tmp_path / "imported")]) == 0
    text = capsys.readouterr().out
    assert "?" not in text
    assert text.startswith("imported lab data (structbench import) from 1 file(s): h0.csv; campaign synthetic, "
                           "structure shear-frame-3; truth.json absent\n")
    assert re.search(r"^h0 +imported +1/1 ", text, re.M)
    assert sb.list_traces(tmp_path / "imported")["sources"] == ["h0.csv"]
    assert main(["traces", str(out)]) == 0
    assert capsys.readouterr().out.startswith("campaign synthetic on shear-frame-3")


# ---- model files: file, line and field ---------------------------------------------

MODEL = '''name = "pair"
description = """
k = 1.0
[[elements]]
"""
[[nodes]]
id = 1
[[nodes]]
id = 2
x = 1.0
[[elements]]
type = "spring"
nodes = [1, 2]
dir = "x"
k = 1.0
[[elements]]
type = "mass"
nodes = [2]
dir = "x"
{mass}
'''


@pytest.mark.parametrize("mass, where", [
    ("m = -2.0", "bad.toml:20: elements[2].m: mass parameter must be positive, got -2.0"),
    ("m = 2.0\ncolour = 1", "bad.toml:21: elements[2].colour: unknown key(s) ['colour']"),
    ("", "bad.toml:16: elements[2].m: missing parameter m (kg)"),  # a missing key: its table's line
    ("m = 2.0\n[[nodes]\n", "bad.toml:21: malformed TOML: "),
])
def test_model_file_errors_name_file_line_and_field(tmp_path, capsys, mass, where):
    path = tmp_path / "bad.toml"
    path.write_text(MODEL.format(mass=mass))
    assert main(["modes", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"structbench modes: error: {where}"), err


def test_model_errors_keep_their_field(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(MODEL.format(mass="m = -2.0"))
    with pytest.raises(sb.UserError) as err:
        load_model(path)
    assert err.value.field == "elements[2].m" and err.value.where == "bad.toml:20"


# ---- the format documents ------------------------------------------------------------

def test_model_format_snippet_is_a_valid_model(tmp_path):
    text = (ROOT / "docs" / "model-format.md").read_text()
    snippet = re.search(r"```toml\n(.*?)```", text, re.S)[1]
    (tmp_path / "doc.toml").write_text(snippet)
    model = load_model(tmp_path / "doc.toml")
    assert model.name == "cantilever-2" and model.n_dof == 4  # nodes 2 and 3: w, theta
    assert 'units = "SI"' in snippet and "h: the element's length" in snippet


def test_campaign_format_lists_every_campaign():
    text = (ROOT / "docs" / "campaign-format.md").read_text()
    missing = [p.name for p in sorted((ROOT / "campaigns").glob("*.toml")) if f"`{p.name}`" not in text]
    assert not missing
