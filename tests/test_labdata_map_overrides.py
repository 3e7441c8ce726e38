"""The sensor map overrides what a file says about a channel (node,
direction, quantity, unit, sign), matched by name or by file and dataset;
every override is printed by ``structbench import`` and kept in the trace's
attributes. Two channels with the same label (a UFF 58 file written by hand
from the published layout, its fourth dataset mislabelled node 1 +Z at
acquisition) give one error listing the datasets and printing the map entry
(TOML) that repairs them: pasted into a map, the import goes through."""
from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from structbench.cli import main
from structbench.identifier.io.traces import read_trace

G = 9.80665


def dataset58(name: str, node: int, direction: int, kind: int, unit: str, values: list[float]) -> list[str]:
    """One ASCII dataset 58, field by field from the published layout:
    record 6 ``2(I5,I10),2(1X,10A1,I10,I4)``, record 7 ``3I10,3E13.5``,
    records 8-11 ``I10,3I5,2(1X,20A1)``, record 12 ``6E13.5`` (real single)."""
    r6 = (f"{1:5d}{0:10d}{0:5d}{0:10d} {'NONE':<10s}{node:10d}{direction:4d} {'NONE':<10s}{0:10d}{0:4d}")
    r7 = f"{2:10d}{len(values):10d}{1:10d}{0.0:13.5E}{1e-3:13.5E}{0.0:13.5E}"
    axis = "{:10d}{:5d}{:5d}{:5d} {:<20s} {:<20s}"
    r12 = ["".join(f"{v:13.5E}" for v in values[i:i + 6]) for i in range(0, len(values), 6)]
    return ["    -1", "    58", name, "NONE", "NONE", "NONE", "NONE", r6, r7,
            axis.format(17, 0, 0, 0, "Time", "s"), axis.format(kind, 0, 0, 0, "Response", unit),
            axis.format(0, 0, 0, 0, "NONE", "NONE"), axis.format(0, 0, 0, 0, "NONE", "NONE"), *r12, "    -1"]


VALUES = [[float(i + 1), -0.5, 0.25 * i, 2.0, 0.0, -1.0, 0.125, 3.0] for i in range(5)]


def write_duplicated(path: Path) -> None:
    """Five accelerometers in g on +Z; the fourth (really node 4) is labelled node 1."""
    lines = []
    for i, node in enumerate([1, 2, 3, 1, 5]):
        lines += dataset58(f"acc{i + 1}", node, 3, 12, "g", VALUES[i])
    path.write_text("\n".join(lines) + "\n")


def _import(tmp_path: Path, capsys, *files: Path, map_text: str | None = None,
            out: str = "lab") -> tuple[int, str, str]:
    args = ["import", *map(str, files), "--out", str(tmp_path / out)]
    if map_text is not None:
        (tmp_path / "map.toml").write_text(map_text)
        args += ["--map", str(tmp_path / "map.toml")]
    status = main(args)
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_duplicated_labels_fail_with_the_datasets_and_the_map_entry_that_fixes_them(tmp_path, capsys):
    source = tmp_path / "run1.unv"
    write_duplicated(source)
    status, _, err = _import(tmp_path, capsys, source)
    assert status == 2 and not (tmp_path / "lab").exists()
    first = err.splitlines()[0]
    assert "channels/acceleration_1_z" in first and "run1.unv dataset 1 ('acc1')" in first
    assert "run1.unv dataset 4 ('acc4')" in first
    fix = err[err.index("[[channels]]"):]
    assert 'file = "run1.unv"' in fix and "dataset = 4" in fix and "node = 4" in fix  # the free node
    # the printed entry, pasted into a map, repairs the file
    status, out, err = _import(tmp_path, capsys, source, map_text=fix)
    assert status == 0, err
    assert "run1.unv dataset 4 ('acc4'): node 1 -> 4 (sensor map channels[0])" in out
    trace = read_trace(tmp_path / "lab" / "traces" / "run1.h5")
    assert sorted(trace.channels) == [f"acceleration_{n}_z" for n in (1, 2, 3, 4, 5)]
    np.testing.assert_allclose(trace.channels["acceleration_4_z"].data, np.array(VALUES[3]) * G, rtol=1e-6)
    np.testing.assert_allclose(trace.channels["acceleration_1_z"].data, np.array(VALUES[0]) * G, rtol=1e-6)
    with h5py.File(tmp_path / "lab" / "traces" / "run1.h5") as f:
        attrs = f["channels/acceleration_4_z"].attrs
        assert json.loads(attrs["overrides"]) == {"node": {"file": 1, "map": 4}}
        assert attrs["map_entry"] == "channels[0]" and attrs["source"] == "run1.unv dataset 4"
        assert "overrides" not in f["channels/acceleration_1_z"].attrs


def test_two_duplicates_get_distinct_free_nodes(tmp_path, capsys):
    source = tmp_path / "run2.unv"
    lines = []
    for i, node in enumerate([1, 1, 3, 1]):
        lines += dataset58(f"acc{i + 1}", node, 3, 12, "g", VALUES[i])
    source.write_text("\n".join(lines) + "\n")
    status, _, err = _import(tmp_path, capsys, source)
    assert status == 2 and "dataset 2 ('acc2')" in err and "dataset 4 ('acc4')" in err
    fix = err[err.index("[[channels]]"):]
    status, out, err = _import(tmp_path, capsys, source, map_text=fix)
    assert status == 0, err
    assert sorted(read_trace(tmp_path / "lab" / "traces" / "run2.h5").channels) == \
        ["acceleration_1_z", "acceleration_2_z", "acceleration_3_z", "acceleration_4_z"]


def test_the_map_overrides_every_field_by_name_or_by_dataset(tmp_path, capsys):
    source = tmp_path / "run3.unv"
    lines = dataset58("acc1", 1, 3, 12, "g", VALUES[0]) + dataset58("acc2", 2, 3, 12, "g", VALUES[1]) \
        + dataset58("vel3", 3, -3, 11, "mm/s", VALUES[2])
    source.write_text("\n".join(lines) + "\n")
    text = """[directions]
z = "w"

[[channels]]           # by name: the unit and the direction were wrong
name = "acc1"
unit = "m/s^2"
direction = "v"

[[channels]]           # by file and dataset: not an accelerometer but a velocity sensor in mm/s at node 7
file = "run3.*"
dataset = 2
quantity = "velocity"
unit = "mm/s"
node = 7

[[channels]]           # mounted the other way round after all
file = "run3.unv"
dataset = 3
sign = 1
"""
    status, out, err = _import(tmp_path, capsys, source, map_text=text)
    assert status == 0, err
    lines = [ln for ln in out.splitlines() if ln.startswith("sensor map override")]
    assert len(lines) == 3
    assert "run3.unv dataset 1 ('acc1'): direction 'w' -> 'v', unit 'g' -> 'm/s^2' (sensor map channels[0])" \
        in lines[0]
    assert "quantity 'acceleration' -> 'velocity', node 2 -> 7, unit 'g' -> 'mm/s'" in lines[1]
    assert "sign -1 -> +1" in lines[2]
    trace = read_trace(tmp_path / "lab" / "traces" / "run3.h5")
    assert sorted(trace.channels) == ["acceleration_1_v", "velocity_3_w", "velocity_7_w"]
    np.testing.assert_allclose(trace.channels["acceleration_1_v"].data, VALUES[0], rtol=1e-6)
    np.testing.assert_allclose(trace.channels["velocity_7_w"].data, np.array(VALUES[1]) * 1e-3, rtol=1e-6)
    np.testing.assert_allclose(trace.channels["velocity_3_w"].data, np.array(VALUES[2]) * 1e-3, rtol=1e-6)
    with h5py.File(tmp_path / "lab" / "traces" / "run3.h5") as f:
        assert json.loads(f["channels/velocity_3_w"].attrs["overrides"]) == {"sign": {"file": -1.0, "map": 1.0}}
        assert f["channels/velocity_3_w"].attrs["si_factor"] == pytest.approx(1e-3)
        assert f["channels/velocity_7_w"].attrs["map_entry"] == "channels[1]"


def test_a_dataset_entry_for_another_file_does_not_match(tmp_path, capsys):
    source = tmp_path / "run1.unv"
    write_duplicated(source)
    status, _, err = _import(tmp_path, capsys, source,
                             map_text='[[channels]]\nfile = "other.unv"\ndataset = 4\nnode = 4\n')
    assert status == 2 and "appear twice" in err


def test_csv_column_overridden_by_dataset_number(tmp_path, capsys):
    source = tmp_path / "bench.csv"
    source.write_text("time [s],acceleration_1_w [g],acceleration_1_w [g]\n0,1,2\n0.01,3,4\n0.02,5,6\n")
    status, _, err = _import(tmp_path, capsys, source)
    assert status == 2 and "bench.csv column 2" in err and "bench.csv column 3" in err
    fix = err[err.index("[[channels]]"):]
    assert "dataset = 3" in fix and "node = 2" in fix
    status, out, err = _import(tmp_path, capsys, source, map_text=fix)
    assert status == 0, err
    trace = read_trace(tmp_path / "lab" / "traces" / "bench.h5")
    np.testing.assert_allclose(trace.channels["acceleration_2_w"].data, np.array([2.0, 4.0, 6.0]) * G)


@pytest.mark.parametrize("entry, words", [("dataset = -2", ["channels[0].dataset", "non-negative"]),
                                          ("sign = 2", ["channels[0].sign", "neither 1 nor -1"]),
                                          ('node = "4"', ["channels[0].node"])])
def test_bad_override_values_name_the_map_field(tmp_path, capsys, entry, words):
    source = tmp_path / "run1.unv"
    write_duplicated(source)
    status, _, err = _import(tmp_path, capsys, source, map_text=f"[[channels]]\nname = \"acc4\"\n{entry}\n")
    assert status == 2
    for word in words:
        assert word in err
