"""UFF dataset 55 (modes) in and out: a file written by hand from the
published layout (normal modes, real shapes) and one written by pyuff
(complex eigenvalues, complex shapes) import as a modal results file that
``read_results`` validates and ``score`` compares with a truth; ``export
--format uff55`` writes modal results that pyuff reads and that import
gives back to the digits of E13.5."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import pyuff

import structbench as sb
from structbench.cli import main
from structbench.identifier.io.results import read_results


def _i(*values: int) -> str:
    return "".join(f"{v:10d}" for v in values)


def _e(*values: float) -> str:
    return "".join(f"{v:13.5E}" for v in values)


FREQ = [1.5, 4.25]           # Hz
ZETA = [0.02, 0.005]
SHAPES = {1: [(0.0, 0.0, 0.5), (0.0, 0.0, -1.0)], 2: [(0.0, 0.0, 1.0), (0.0, 0.0, 0.25)],
          3: [(0.0, 0.0, 0.75), (0.0, 0.0, 0.5)]}


def normal_modes_file(path: Path) -> None:
    """Two normal modes (analysis type 2), 3 DOF per node, real, displacement:
    record 6 ``6I10``, record 7 ``8I10``, record 8 ``6E13.5``, records 9/10
    ``I10`` / ``6E13.5`` per node."""
    lines = []
    for k, (f, z) in enumerate(zip(FREQ, ZETA)):
        lines += ["    -1", "    55", "test modes", "NONE", "NONE", "NONE", "NONE",
                  _i(1, 2, 2, 8, 2, 3), _i(2, 4, 1, k + 1), _e(f, 1.0, z, 0.0)]
        for node, values in SHAPES.items():
            lines += [_i(node), _e(*values[k])]
        lines.append("    -1")
    path.write_text("\n".join(lines) + "\n")


def test_hand_written_normal_modes_import_as_modal_results(tmp_path, capsys):
    source = tmp_path / "modes.unv"
    normal_modes_file(source)
    (tmp_path / "map.toml").write_text('structure = "lab-beam"\n[directions]\nz = "w"\n')
    assert main(["import", str(source), "--out", str(tmp_path / "lab"), "--map", str(tmp_path / "map.toml")]) == 0
    assert "modal results" in capsys.readouterr().out
    header, runs = read_results(tmp_path / "lab" / "results" / "uff55-modes.json")
    assert header["method"] == "uff55" and header["structure"] == "lab-beam"
    run = runs[0]
    np.testing.assert_allclose(run.omega, 2 * np.pi * np.array(FREQ))
    np.testing.assert_allclose(run.damping, ZETA)
    assert run.sensors == ["displacement_1_w", "displacement_2_w", "displacement_3_w"]
    first = np.array([SHAPES[n][0][2] for n in (1, 2, 3)])
    np.testing.assert_allclose(run.mode_shapes[0], first / first[np.argmax(np.abs(first))])
    second = np.array([SHAPES[n][1][2] for n in (1, 2, 3)])
    np.testing.assert_allclose(run.mode_shapes[1], second / second[np.argmax(np.abs(second))])
    np.testing.assert_allclose(np.linalg.norm(np.array(run.mode_shapes_complex[0]), axis=None), 1.0)
    assert run.mpc == [1.0, 1.0] and all(math.isnan(v) for v in run.omega_std)


def test_imported_modes_are_scored_against_a_campaign_truth(tmp_path, capsys):
    """Without time data the import may go into an existing campaign folder."""
    campaign = tmp_path / "campaign"
    campaign.mkdir()
    truth = {"omega": [2 * np.pi * 1.49, 2 * np.pi * 4.3], "zeta": [0.021, 0.005],
             "sensor_dofs": [[1, "w"], [2, "w"], [3, "w"]],
             "mode_shapes": [[0.5, -1.0], [1.0, 0.25], [0.75, 0.5]]}
    (campaign / "truth.json").write_text(json.dumps(truth))
    source = tmp_path / "modes.unv"
    normal_modes_file(source)
    (tmp_path / "map.toml").write_text('[directions]\nz = "w"\n')
    sb.import_data([source], campaign, tmp_path / "map.toml")
    scores = sb.score(campaign)["uff55-modes"]
    run = scores["runs"][0]
    assert scores["method"] == "uff55"
    np.testing.assert_allclose(run["freq_error_pct"], [100 * (1.5 / 1.49 - 1), 100 * (4.25 / 4.3 - 1)])
    np.testing.assert_allclose(run["mac"], [1.0, 1.0])
    with pytest.raises(sb.UserError, match="exists"):  # a second import does not overwrite
        sb.import_data([source], campaign, tmp_path / "map.toml")


def _complex_file(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Two complex modes (analysis type 3) at 4 nodes, x y z, written by pyuff."""
    rng = np.random.default_rng(5)
    poles = np.array([-0.3 + 12.0j, -0.8 + 40.0j])
    shapes = rng.standard_normal((2, 4, 3)) + 0.1j * rng.standard_normal((2, 4, 3))
    sets = [pyuff.prepare_55(id1="complex modes", model_type=1, analysis_type=3, data_ch=2, spec_data_type=12,
                             data_type=5, n_data_per_node=3, r1=shapes[k, :, 0], r2=shapes[k, :, 1],
                             r3=shapes[k, :, 2], node_nums=np.array([1, 2, 3, 4]), load_case=1, mode_n=k + 1,
                             eig=poles[k], modal_a=0j, modal_b=0j) for k in range(2)]
    pyuff.UFF(str(path)).write_sets(sets, "add")
    return poles, shapes


def test_pyuff_complex_modes(tmp_path):
    source = tmp_path / "cmodes.uff"
    poles, shapes = _complex_file(source)
    written = sb.import_data([source], tmp_path / "lab")
    _, runs = read_results(written[0])
    run = runs[0]
    np.testing.assert_allclose(run.omega, np.abs(poles), rtol=1e-5)
    np.testing.assert_allclose(run.damping, -poles.real / np.abs(poles), rtol=1e-4)
    assert run.sensors[:3] == ["acceleration_1_x", "acceleration_1_y", "acceleration_1_z"]
    for k in range(2):
        got = np.array(run.mode_shapes_complex[k]) @ np.array([1, 1j])
        want = shapes[k].ravel() / np.linalg.norm(shapes[k])
        np.testing.assert_allclose(got, want, atol=2e-5)
    assert 0 < run.mpc[0] <= 1


def test_export_uff55_round_trip_through_pyuff(tmp_path, capsys):
    source = tmp_path / "cmodes.uff"
    _complex_file(source)
    sb.import_data([source], tmp_path / "lab")
    _, before = read_results(tmp_path / "lab" / "results" / "uff55-cmodes.json")
    out = tmp_path / "export" / "modes.unv"
    out.parent.mkdir()
    assert main(["export", str(tmp_path / "lab"), "--format", "uff55", "--out", str(out)]) == 0
    sets = pyuff.UFF(str(out)).read_sets()
    assert [s["type"] for s in sets] == [55, 55] and [s["mode_n"] for s in sets] == [1, 2]
    np.testing.assert_allclose([abs(s["eig"]) for s in sets], before[0].omega, rtol=1e-5)
    reread = np.concatenate([sets[0]["r1"][:, None], sets[0]["r2"][:, None], sets[0]["r3"][:, None]], axis=1).ravel()
    np.testing.assert_allclose(reread, np.array(before[0].mode_shapes_complex[0]) @ np.array([1, 1j]), atol=1e-5)
    sb.import_data([out], tmp_path / "again")
    _, after = read_results(tmp_path / "again" / "results" / "uff55-modes.json")
    np.testing.assert_allclose(after[0].omega, before[0].omega, rtol=1e-5)
    np.testing.assert_allclose(after[0].damping, before[0].damping, rtol=1e-4)
    np.testing.assert_allclose(after[0].mode_shapes, before[0].mode_shapes, atol=1e-4)
    assert after[0].sensors == before[0].sensors


def test_export_keeps_model_direction_names(tmp_path):
    """Real shapes on w and theta: 6 values per node, analysis type 2, and
    the ID line's hint gives the names back."""
    campaign = tmp_path / "c"
    (campaign / "results").mkdir(parents=True)
    run = {"method": "rayleigh", "structure": "ch3-free-free-beam", "repetition": 0, "tests": ["t"],
           "omega": [3.0, 9.0], "eigenvalues": [9.0, 81.0], "mode_shapes": [[1.0, 0.5, -0.25], [0.2, 1.0, 0.4]],
           "sensors": ["displacement_2_w", "displacement_2_theta", "displacement_5_w"]}
    doc = {"format": "structbench-result", "format_version": 1, "method": "rayleigh", "campaign": "c",
           "structure": "ch3-free-free-beam", "model": "ch3-free-free-beam", "software": "x", "options": {},
           "runs": [run]}
    (campaign / "results" / "rayleigh.json").write_text(json.dumps(doc))
    path = sb.export_modes(campaign, tmp_path / "beam.unv")
    text = path.read_text().splitlines()
    assert text[7] == _i(1, 2, 3, 8, 2, 6) and "structbench directions 3=w 5=theta" in text[4]
    sb.import_data([path], tmp_path / "back")
    _, runs = read_results(tmp_path / "back" / "results" / "uff55-beam.json")
    assert runs[0].sensors == ["displacement_2_theta", "displacement_2_w", "displacement_5_w"]
    np.testing.assert_allclose(runs[0].omega, [3.0, 9.0], rtol=1e-5)
    np.testing.assert_allclose(runs[0].mode_shapes[1], [1.0, 0.2, 0.4], atol=1e-5)


@pytest.mark.parametrize("record6, words", [(_i(1, 5, 2, 8, 2, 3), ["record 6 field 2", "analysis type 5"]),
                                            (_i(1, 2, 2, 8, 2, 4), ["record 6", "4 values per node"])])
def test_unsupported_dataset_55_names_the_field(tmp_path, capsys, record6, words):
    source = tmp_path / "bad.unv"
    source.write_text("\n".join(["    -1", "    55", "x", "NONE", "NONE", "NONE", "NONE", record6,
                                 _i(2, 4, 1, 1), _e(1.0, 1.0, 0.0, 0.0), _i(1), _e(0, 0, 1), "    -1"]) + "\n")
    assert main(["import", str(source), "--out", str(tmp_path / "lab")]) == 2
    err = capsys.readouterr().err
    assert "bad.unv dataset 1 (55)" in err
    for word in words:
        assert word in err, (word, err)
