"""Geometry in: UFF nodes (15, 2411), trace lines (82), elements (2412),
coordinate systems (18, 2420) and units (164), from a file written by hand
field by field from the published layouts and from files pyuff writes;
node coordinates given in local (Cartesian, cylindrical) systems come out
global, in metres, in ``geometry.json`` beside the traces (a geometry-only
file imports as geometry alone). A model's geometry is the same document
made from its node coordinates."""
from __future__ import annotations

import json

import numpy as np
import pytest
import pyuff

import structbench as sb
from structbench.cli import main
from structbench.identifier.io.traces import read_trace
from structbench.labdata.geometry import read_geometry

from test_labdata_map_overrides import dataset58


def _i(*values: int) -> str:
    return "".join(f"{v:10d}" for v in values)


def _e(*values: float) -> str:
    return "".join(f"{v:13.5E}" for v in values)


def _d(*values: float) -> str:
    return "".join(f"{v:25.16E}".replace("E", "D") for v in values)


def geometry_lines() -> list[str]:
    """Millimetres (164); system 1 (18): origin (1000, 0, 0), +x along global
    y; system 3 (2420): Cartesian, axes (z, x, y), origin (0, 0, 500);
    system 4 (2420): cylindrical at the origin; nodes 1, 2 (15; node 2 in
    system 1, displacements too) and 3, 4 (2411, in systems 3 and 4); a
    trace line 1-2, 3-4 (82, a 0 between) and a beam and a triangle (2412)."""
    return [
        "    -1", "   164", f"{2:10d}{'mm (milli newton)':<20s}{2:10d}",
        "  1.00000000000000000D+03  1.00000000000000000D+00  1.00000000000000000D+00",
        "  2.73150000000000000D+02", "    -1",
        # 18: 5I10 / 20A2 / 1P6E13.5 / 1P3E13.5
        "    -1", "    18", _i(1, 0, 0, 8, 1), f"{'turned':<40s}",
        _e(1000.0, 0.0, 0.0, 1000.0, 500.0, 0.0), _e(1000.0, 0.0, 700.0), "    -1",
        # 2420: I10 / 40A2, then per system 3I10 / 40A2 / 4 x 1P3D25.16
        "    -1", "  2420", _i(1), "part", _i(3, 0, 8), "swapped",
        _d(0, 0, 1), _d(1, 0, 0), _d(0, 1, 0), _d(0, 0, 500),
        _i(4, 1, 8), "cylinder", _d(1, 0, 0), _d(0, 1, 0), _d(0, 0, 1), _d(0, 0, 0), "    -1",
        # 15: 4I10,1P3E13.5
        "    -1", "    15", _i(1, 0, 0, 8) + _e(0.0, 0.0, 0.0), _i(2, 1, 1, 8) + _e(100.0, 200.0, 300.0), "    -1",
        # 2411: 4I10 / 1P3D25.16
        "    -1", "  2411", _i(3, 3, 0, 8), _d(10.0, 20.0, 30.0), _i(4, 4, 0, 8), _d(1000.0, 90.0, 250.0), "    -1",
        # 82: 3I10 / 80A1 / 8I10
        "    -1", "    82", _i(1, 5, 8), "frame", _i(1, 2, 0, 3, 4), "    -1",
        # 2412: 6I10, beams 3I10, 8I10
        "    -1", "  2412", _i(1, 21, 1, 1, 8, 2), _i(0, 1, 1), _i(1, 3), _i(2, 91, 1, 1, 8, 3), _i(2, 3, 4), "    -1"]


EXPECTED = {1: (0.0, 0.0, 0.0), 2: (0.8, 0.1, 0.3), 3: (0.02, 0.03, 0.51), 4: (0.0, 1.0, 0.25)}


def _check(doc: dict) -> None:
    assert doc["format"] == "structbench-geometry" and doc["units"] == {"length": "m"}
    nodes = {n["id"]: n for n in doc["nodes"]}
    for node, xyz in EXPECTED.items():
        np.testing.assert_allclose(nodes[node]["xyz"], xyz, atol=1e-12)
    assert nodes[2]["displacement_system"] == 1 and "displacement_system" not in nodes[1]


def test_hand_written_geometry_only_file_imports_as_geometry_alone(tmp_path, capsys):
    source = tmp_path / "frame.unv"
    source.write_text("\n".join(geometry_lines()) + "\n")
    assert main(["import", str(source), "--out", str(tmp_path / "lab")]) == 0
    assert "geometry" in capsys.readouterr().out
    assert sorted(p.name for p in (tmp_path / "lab").iterdir()) == ["geometry.json"]
    doc = json.loads((tmp_path / "lab" / "geometry.json").read_text())
    _check(doc)
    assert doc["lines"] == [{"id": 1, "name": "frame", "nodes": [1, 2]}, {"id": 1, "name": "frame", "nodes": [3, 4]}]
    assert doc["elements"] == [{"id": 1, "type": 21, "nodes": [1, 3]}, {"id": 2, "type": 91, "nodes": [2, 3, 4]}]
    systems = {c["id"]: c for c in doc["coordinate_systems"]}
    np.testing.assert_allclose(systems[1]["axes"], [[0, 1, 0], [-1, 0, 0], [0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(systems[1]["origin"], [1.0, 0, 0])
    assert systems[4]["type"] == "cylindrical" and systems[3]["origin"] == [0, 0, 0.5]
    geometry = read_geometry(tmp_path / "lab" / "geometry.json")
    np.testing.assert_allclose(geometry.direction(2, "x"), [0, 1, 0], atol=1e-15)  # node 2's own system
    np.testing.assert_allclose(geometry.direction(1, "w"), [0, 0, 1])
    assert geometry.direction(1, "theta") is None
    geometry.displacement_systems[4] = 4  # cylindrical: x radial, y tangential at node 4 (r 1 m, theta 90 deg)
    np.testing.assert_allclose(geometry.direction(4, "x"), [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(geometry.direction(4, "y"), [-1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(geometry.direction(4, "z"), [0, 0, 1], atol=1e-15)


def test_geometry_beside_the_traces(tmp_path, capsys):
    source = tmp_path / "run1.unv"
    lines = geometry_lines() + dataset58("acc1", 1, 3, 12, "g", [1.0, 2.0, 3.0]) \
        + dataset58("acc4", 4, 3, 12, "g", [4.0, 5.0, 6.0])
    source.write_text("\n".join(lines) + "\n")
    assert main(["import", str(source), "--out", str(tmp_path / "lab")]) == 0
    assert sorted(p.name for p in (tmp_path / "lab").iterdir()) == ["geometry.json", "traces"]
    _check(json.loads((tmp_path / "lab" / "geometry.json").read_text()))
    # the channels' locations come from the geometry's nodes (the map gives none)
    trace = read_trace(tmp_path / "lab" / "traces" / "run1.h5")
    np.testing.assert_allclose(trace.channels["acceleration_4_z"].location, EXPECTED[4], atol=1e-12)
    np.testing.assert_allclose(trace.channels["acceleration_1_z"].location, EXPECTED[1], atol=1e-12)


def test_length_unit_from_the_map_when_the_file_has_no_units_dataset(tmp_path):
    source = tmp_path / "nodes.unv"
    source.write_text("\n".join(["    -1", "    15", _i(1, 0, 0, 8) + _e(10.0, 20.0, 30.0), "    -1"]) + "\n")
    (tmp_path / "map.toml").write_text('length_unit = "in"\n')
    sb.import_data([source], tmp_path / "lab", tmp_path / "map.toml")
    doc = json.loads((tmp_path / "lab" / "geometry.json").read_text())
    np.testing.assert_allclose(doc["nodes"][0]["xyz"], np.array([10.0, 20.0, 30.0]) * 0.0254)


def _rotation(z_deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(z_deg)), np.sin(np.radians(z_deg))
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # rows: local axes in global


def test_pyuff_written_geometry(tmp_path):
    """Nodes (2411), a trace line (82), systems (18 and 2420) and units (164)
    written by pyuff; the expected global coordinates computed here from the
    systems' definitions."""
    rng = np.random.default_rng(3)
    local = rng.uniform(-500, 500, size=(6, 3))  # mm
    matrix = np.vstack([_rotation(30.0), [100.0, -200.0, 50.0]])  # 2420 system 5
    sets = [pyuff.prepare_164(units_code=2, units_description="mm", temp_mode=2, length=1000.0, force=1.0,
                              temp=1.0, temp_offset=273.15),
            pyuff.prepare_18(cs_num=[7], cs_type=[0], ref_cs_num=[0], color=[1], method=[1], cs_name=["tilted"],
                             ref_o=[[0.0, 0.0, 300.0]], x_point=[[0.0, 0.0, 400.0]], xz_point=[[-100.0, 0.0, 300.0]]),
            pyuff.prepare_2420(Part_UID=1, Part_Name="part", CS_sys_labels=[5], CS_types=[0], CS_colors=[8],
                               CS_names=["turned"], CS_matrices=[matrix]),
            pyuff.prepare_2411(node_nums=np.arange(1, 7), def_cs=np.array([0, 0, 5, 5, 7, 7]),
                               disp_cs=np.zeros(6, dtype=int), color=np.ones(6, dtype=int),
                               x=local[:, 0], y=local[:, 1], z=local[:, 2]),
            pyuff.prepare_82(trace_num=2, n_nodes=7, color=1, id="outline", nodes=np.array([1, 2, 3, 4, 0, 5, 6]))]
    source = tmp_path / "pyuff.uff"
    pyuff.UFF(str(source)).write_sets(sets, "add")
    sb.import_data([source], tmp_path / "lab")
    doc = json.loads((tmp_path / "lab" / "geometry.json").read_text())
    got = {n["id"]: np.array(n["xyz"]) for n in doc["nodes"]}
    # system 7: origin (0, 0, 0.3) m, +x along global +z, xz plane through -x: local z = global -x
    axes7 = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    expected = {1: local[0] / 1e3, 2: local[1] / 1e3,
                3: (matrix[3] + local[2] @ matrix[:3]) / 1e3, 4: (matrix[3] + local[3] @ matrix[:3]) / 1e3,
                5: np.array([0, 0, 0.3]) + local[4] / 1e3 @ axes7, 6: np.array([0, 0, 0.3]) + local[5] / 1e3 @ axes7}
    for node, xyz in expected.items():
        np.testing.assert_allclose(got[node], xyz, atol=1e-9, err_msg=f"node {node}")
    assert doc["lines"] == [{"id": 2, "name": "outline", "nodes": [1, 2, 3, 4]},
                            {"id": 2, "name": "outline", "nodes": [5, 6]}]


@pytest.mark.parametrize("lines, words", [
    (["    -1", "    15", _i(1, 9, 0, 8) + _e(0, 0, 0), "    -1"], ["dataset 1", "coordinate system 9"]),
    (["    -1", "  2411", _i(1, 0, 0, 8), "  1.0  2.0  x", "    -1"], ["dataset 1 (2411) record 2", "coordinates"]),
    (["    -1", "    82", _i(1, 3, 8), "line", _i(1, 2, 3), "    -1",
      "    -1", "    15", _i(1, 0, 0, 8) + _e(0, 0, 0), "    -1"], ["trace line 1", "[2, 3]"]),
    (["    -1", "    18", _i(1, 0, 0, 8, 1), "c", _e(0, 0, 0, 1, 0, 0), _e(2, 0, 0), "    -1"],
     ["coordinate system 1", "collinear"]),
])
def test_malformed_geometry_names_file_dataset_and_record(tmp_path, capsys, lines, words):
    source = tmp_path / "bad.unv"
    source.write_text("\n".join(lines) + "\n")
    assert main(["import", str(source), "--out", str(tmp_path / "lab")]) == 2
    err = capsys.readouterr().err
    assert "bad.unv" in err
    for word in words:
        assert word in err, (word, err)
    assert not (tmp_path / "lab").exists()


def test_model_geometry_from_node_coordinates(tmp_path):
    doc = sb.model_geometry("ch5-membrane", tmp_path / "geometry.json")
    assert doc == json.loads((tmp_path / "geometry.json").read_text())
    assert len(doc["nodes"]) == 16 and doc["nodes"][5]["xyz"] == [1.0, 1.0, 0.0]
    assert len(doc["elements"]) == 18 and doc["elements"][0] == {"id": 1, "type": "tri3", "nodes": [1, 2, 6]}
    beam = sb.model_geometry("ch3-free-free-beam")
    assert [n["xyz"] for n in beam["nodes"]][:2] == [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
    modal = sb.model_geometry("ch5-simply-supported-beam")
    assert modal["lines"][0]["nodes"] == list(range(1, 11)) and not modal["elements"]
    read_geometry(tmp_path / "geometry.json")  # the reader accepts what the model gives


def test_node_records_of_blank_separated_values(tmp_path):
    """A dataset 15 whose lines do not keep the columns (some exporters write
    free format) is read by its seven values."""
    source = tmp_path / "free.unv"
    source.write_text("    -1\n    15\n1 0 0 8 0.5 1.5 -2.0\n2 0 0 8 1 2 3D0\n    -1\n")
    sb.import_data([source], tmp_path / "lab")
    doc = json.loads((tmp_path / "lab" / "geometry.json").read_text())
    assert [n["xyz"] for n in doc["nodes"]] == [[0.5, 1.5, -2.0], [1.0, 2.0, 3.0]]
