"""``structbench import`` on files structbench did not write: UFF 58 written by
pyuff's own writer (ASCII and binary, several units), a hand-written ASCII
UFF 58 file following the published field layout, CSV and SEP005 files; and a
malformed file of each kind, each failing with one line naming the file (and
the UFF dataset and record), exit status 2 and no folder left behind."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import pyuff

from structbench.cli import main
from structbench.identifier.io.traces import read_trace

G, INCH, LBF = 9.80665, 0.0254, 4.4482216152605


def _pyuff_file(path: Path, binary: int, spacing: int = 1, func_type: int = 1) -> dict[str, np.ndarray]:
    """Three channels written by pyuff: acceleration in g (node 3, +Z),
    velocity in mm/s (node 2, -Z) and force in lbf (node 1, +Z); 1 ms sampling."""
    rng = np.random.default_rng(7)
    x = np.arange(500) * 1e-3
    data = {"acc": rng.standard_normal(500), "vel": rng.standard_normal(500), "force": rng.standard_normal(500)}
    sets = []
    for key, node, direction, kind, unit in (("acc", 3, 3, 12, "g"), ("vel", 2, -3, 11, "mm/s"),
                                             ("force", 1, 3, 13, "lbf")):
        sets.append(pyuff.prepare_58(binary=binary, func_type=func_type, rsp_node=node, rsp_dir=direction,
                                     ref_node=1, ref_dir=3, data=data[key], x=x, id1=f"sensor {key}",
                                     rsp_ent_name="lab", ref_ent_name="lab", abscissa_spacing=spacing,
                                     abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
                                     ordinate_spec_data_type=kind, ordinate_axis_units_lab=unit,
                                     orddenom_spec_data_type=0))
    # "add" to a new file: pyuff 2.5's "overwrite" reopens a binary file with "wb"
    # after writing the first header, so the first dataset is lost
    pyuff.UFF(str(path)).write_sets(sets, "add")
    return data | {"x": x}


def _map(tmp_path: Path) -> Path:
    path = tmp_path / "map.toml"
    path.write_text('structure = "lab-frame"\n[directions]\nz = "w"\n')
    return path


@pytest.mark.parametrize("binary", [0, 1])
def test_pyuff_files_import_in_si_with_node_direction_and_unit_from_the_records(tmp_path, binary):
    source = tmp_path / "run1.uff"
    data = _pyuff_file(source, binary)
    assert main(["import", str(source), "--out", str(tmp_path / "lab"), "--map", str(_map(tmp_path)),
                 "--name", "lab-2026"]) == 0
    trace = read_trace(tmp_path / "lab" / "traces" / "run1.h5")
    assert trace.attrs["campaign"] == "lab-2026" and trace.structure == "lab-frame" and trace.test == "run1"
    assert list(trace.channels) == ["acceleration_3_w", "velocity_2_w", "force_1_w"]
    expected = {"acceleration_3_w": data["acc"] * G, "velocity_2_w": -data["vel"] * 1e-3,
                "force_1_w": data["force"] * LBF}
    # pyuff's own reader is the independent reference for the values in the file
    by_node = {s["rsp_node"]: s["data"] for s in pyuff.UFF(str(source)).read_sets()}
    reread = {"acceleration_3_w": by_node[3] * G, "velocity_2_w": -by_node[2] * 1e-3, "force_1_w": by_node[1] * LBF}
    for name, channel in trace.channels.items():
        np.testing.assert_array_equal(channel.data, reread[name])
        np.testing.assert_allclose(channel.data, expected[name], rtol=0 if binary else 1e-10)
    assert trace.channels["acceleration_3_w"].unit == "m/s^2" and trace.channels["force_1_w"].unit == "N"
    attrs = trace.channels["velocity_2_w"]
    assert (attrs.quantity, attrs.node, attrs.direction) == ("velocity", 2, "w")
    assert trace.dt == 1e-3 and np.array_equal(trace.time, data["x"])


def test_conversion_is_written_into_the_trace(tmp_path):
    import h5py
    source = tmp_path / "run1.uff"
    _pyuff_file(source, 1)
    main(["import", str(source), "--out", str(tmp_path / "lab"), "--map", str(_map(tmp_path))])
    with h5py.File(tmp_path / "lab" / "traces" / "run1.h5") as f:
        velocity = dict(f["channels/velocity_2_w"].attrs)
        assert velocity["source_unit"] == "mm/s" and velocity["sign"] == -1.0
        assert velocity["si_factor"] == pytest.approx(-1e-3, rel=1e-15)
        assert velocity["source"] == "run1.uff dataset 2"
        assert f["channels/acceleration_3_w"].attrs["si_factor"] == G


def test_pyuff_uneven_binary_keeps_the_abscissa_exactly(tmp_path):
    """pyuff writes uneven binary data as (x, y) doubles with a header byte
    count for y alone; the abscissa comes back bit for bit."""
    source = tmp_path / "uneven.uff"
    data = _pyuff_file(source, 1, spacing=0)
    main(["import", str(source), "--out", str(tmp_path / "lab"), "--map", str(_map(tmp_path))])
    trace = read_trace(tmp_path / "lab" / "traces" / "uneven.h5")
    assert np.array_equal(trace.time, data["x"])
    np.testing.assert_array_equal(trace.channels["force_1_w"].data, data["force"] * LBF)


def _hand_written() -> str:
    """Dataset 164 (units; skipped) then two datasets 58 written field by
    field from the published layout (records 1-12)."""
    ruler = {  # record 6: 2(I5,I10),2(1X,10A1,I10,I4)
        "acc": "    1" + "         0" + "    0" + "         0" + " " + "NONE      " + "        12" + "   3"
               + " " + "NONE      " + "        12" + "   3",
        "vel": "    1" + "         0" + "    0" + "         0" + " " + "NONE      " + "         5" + "  -3"
               + " " + "NONE      " + "        12" + "   3",
    }
    # record 7: 3I10,3E13.5 -- ordinate type, values, spacing (1 even), minimum, increment, z
    r7_single = "         2" + "         8" + "         1" + "  0.00000E+00" + "  1.25000E-03" + "  0.00000E+00"
    r7_double = "         4" + "         8" + "         1" + "  0.00000E+00" + "  1.25000E-03" + "  0.00000E+00"
    # records 8-11: I10,3I5,2(1X,20A1)
    time_axis = "        17" + "    0" * 3 + " " + "Time".ljust(20) + " " + "s".ljust(20)
    unused = "         0" + "    0" * 3 + " " + "NONE".ljust(20) + " " + "NONE".ljust(20)
    acc_axis = "        12" + "    0" * 3 + " " + "Acceleration".ljust(20) + " " + "g".ljust(20)
    vel_axis = "        11" + "    0" * 3 + " " + "Velocity".ljust(20) + " " + "in/s".ljust(20)
    ids = ["NONE"] * 4
    lines = ["    -1", "   164", "         1  SI - mks (Newton)    2",
             "    1.00000000000000000D+00    1.00000000000000000D+00    1.00000000000000000D+00",
             "    2.73150000000000000D+02", "    -1",
             "    -1", "    58", "accelerometer A1", *ids, ruler["acc"], r7_single, time_axis, acc_axis, unused, unused,
             # record 12, 6E13.5
             "  1.00000E+00 -2.50000E-01  5.00000E-01  0.00000E+00 -1.00000E+00  2.00000E-03",
             "  7.50000E-01 -1.25000E-01", "    -1",
             "    -1", "    58", "velocity V1", *ids, ruler["vel"], r7_double, time_axis, vel_axis, unused, unused,
             # record 12, 4E20.12
             "  1.000000000000E+00 -2.000000000000E+00  3.000000000000E+00 -4.000000000000E+00",
             "  5.000000000000E-01 -6.000000000000E-01  7.000000000000E-01  1.234567890123E-02", "    -1"]
    return "\n".join(lines) + "\n"


ACC = np.array([1.0, -0.25, 0.5, 0.0, -1.0, 2e-3, 0.75, -0.125])
VEL = np.array([1.0, -2.0, 3.0, -4.0, 0.5, -0.6, 0.7, 1.234567890123e-2])


def test_hand_written_ascii_file_from_the_published_layout(tmp_path):
    source = tmp_path / "hand.unv"
    source.write_text(_hand_written())
    assert main(["import", str(source), "--out", str(tmp_path / "lab"), "--map", str(_map(tmp_path))]) == 0
    trace = read_trace(tmp_path / "lab" / "traces" / "hand.h5")
    np.testing.assert_array_equal(trace.time, np.arange(8) * 1.25e-3)
    np.testing.assert_array_equal(trace.channels["acceleration_12_w"].data, ACC * G)
    np.testing.assert_array_equal(trace.channels["velocity_5_w"].data, -VEL * INCH)  # -Z sensor
    assert trace.dt == 1.25e-3


def _fails(capsys, files: list[Path], out: Path, *words: str, map_file: Path | None = None) -> None:
    args = ["import", *map(str, files), "--out", str(out)] + (["--map", str(map_file)] if map_file else [])
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("structbench import: error:"), err
    for word in words:
        assert word in err, (word, err)
    assert not out.exists() and not list(out.parent.glob(f".{out.name}.import-*"))


def test_malformed_uff_files(tmp_path, capsys):
    good = _hand_written()
    cases = {
        "truncated.uff": (good[:good.rindex("  5.000000000000E-01")], ("dataset 3", "record 12")),
        "frf.uff": (good.replace("    1         0    0         0 NONE               5", "    4         0    0"
                                 "         0 NONE               5"), ("dataset 3", "record 6", "function type 4")),
        "no-time.uff": (good.replace("  0.00000E+00  1.25000E-03  0.00000E+00", "  0.00000E+00  0.00000E+00"
                                     "  0.00000E+00", 1), ("dataset 2", "record 7", "no time axis")),
        "frequency-axis.uff": (good.replace("        17    0", "        18    0", 1), ("dataset 2", "record 8")),
        "units-only.uff": ("\n".join(good.splitlines()[:6]) + "\n", ("no dataset 58", "164")),
    }
    for name, (text, words) in cases.items():
        path = tmp_path / name
        path.write_text(text)
        _fails(capsys, [path], tmp_path / f"out-{path.stem}", name, *words, map_file=_map(tmp_path))


def test_truncated_binary_uff(tmp_path, capsys):
    source = tmp_path / "cut.uff"
    _pyuff_file(source, 1)
    raw = source.read_bytes()
    source.write_bytes(raw[:int(len(raw) * 0.8)])
    _fails(capsys, [source], tmp_path / "out", "cut.uff dataset 3 record 12", "truncated")


def test_malformed_csv_and_sep005(tmp_path, capsys):
    files = {
        "truncated.csv": ("time [s],acceleration_3_w [g]\n0.0,1.0\n0.001,2.0\n0.002\n", ("truncated.csv",)),
        "no-time.csv": ("acceleration_3_w [g],force_3_w [N]\n1.0,2.0\n3.0,4.0\n", ("no-time.csv", "time axis")),
        "wrong-type.txt": ("whatever\n", ("wrong-type.txt", "unknown file type")),
        "truncated.json": ('[{"name": "acceleration_3_w", "data": [1.0, 2.', ("truncated.json", "not JSON")),
        "no-time.json": (json.dumps([{"name": "acceleration_3_w", "data": [1.0, 2.0], "unit_str": "g"}]),
                         ("no-time.json channel 1", "no time axis")),
        "wrong-type.json": (json.dumps({"name": "a"}), ("wrong-type.json", "list of channel")),
        "metre-time.csv": ("time [m],acc [g]\n0,1\n1,2\n", ("metre-time.csv column 1", "no time axis")),
        "furlong.csv": ("time [s],acc [furlong/s^2]\n0.0,1.0\n0.1,2.0\n", ("furlong.csv column 2", "furlong")),
    }
    smap = tmp_path / "map.toml"
    smap.write_text('[[channels]]\nname = "acc"\nnode = 1\ndirection = "x"\n')
    for name, (text, words) in files.items():
        path = tmp_path / name
        path.write_text(text)
        _fails(capsys, [path], tmp_path / f"out-{path.stem}-{path.suffix[1:]}", *words, map_file=smap)


def test_csv_and_sep005_from_outside_with_a_map(tmp_path):
    """A CSV of a lab logger (own column names, ms and g) and a SEP005 list."""
    (tmp_path / "logger.csv").write_text("time [ms],A1 [g],F1 [lbf]\n0,1.0,10\n2,-0.5,-20\n4,0.25,30\n")
    (tmp_path / "sep.json").write_text(json.dumps([
        {"name": "A1", "data": [1.0, -0.5, 0.25], "unit_str": "m/s^2", "fs": 500.0, "quantity": "a"}]))
    smap = tmp_path / "map.toml"
    smap.write_text('[[channels]]\nname = "A1"\nnode = 4\ndirection = "x"\nnoise_ratio = 0.01\n'
                    '[[channels]]\nname = "F1"\nnode = 4\ndirection = "x"\n'
                    '[[tests]]\nfile = "logger.csv"\ntest = "sweep"\nexcitation = {omega = 12.5}\n')
    assert main(["import", str(tmp_path / "logger.csv"), str(tmp_path / "sep.json"), "--out", str(tmp_path / "lab"),
                 "--map", str(smap)]) == 0
    csv = read_trace(tmp_path / "lab" / "traces" / "logger.h5")
    assert csv.test == "sweep" and csv.omega == 12.5 and csv.dt == pytest.approx(2e-3, rel=1e-15)
    np.testing.assert_array_equal(csv.channels["acceleration_4_x"].data, np.array([1.0, -0.5, 0.25]) * G)
    np.testing.assert_array_equal(csv.channels["force_4_x"].data, np.array([10, -20, 30]) * LBF)
    assert csv.channels["acceleration_4_x"].noise_ratio == 0.01
    sep = read_trace(tmp_path / "lab" / "traces" / "sep.h5")
    np.testing.assert_array_equal(sep.time, np.arange(3) / 500.0)
    np.testing.assert_array_equal(sep.channels["acceleration_4_x"].data, [1.0, -0.5, 0.25])


def test_score_without_truth_says_so(tmp_path, capsys):
    source = tmp_path / "hand.unv"
    source.write_text(_hand_written())
    main(["import", str(source), "--out", str(tmp_path / "lab"), "--map", str(_map(tmp_path))])
    capsys.readouterr()
    assert main(["score", str(tmp_path / "lab")]) == 2
    assert "no truth.json" in capsys.readouterr().err
