"""Excitation from a file (issue 24.4): a recorded force (a measured shaker
drive) at one DOF, and a recorded ground acceleration as the equivalent
nodal forces ``-M r a_g``; CSV, UFF 58 and HDF5, units to SI, resampled to
the test's communication step."""
from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import pyuff
import scipy.linalg as la

from structbench.harness.campaign import load_campaign
from structbench.harness.excitation import GroundForce, RecordedForce, Recording, read_recording, resample
from structbench.harness.run import run_campaign
from structbench.models import load_model
from structbench.models.errors import UserError
from structbench.pytest_plugin import cached_campaign

ROOT = Path(__file__).resolve().parents[1]
FRAME = ROOT / "docs" / "examples" / "shear-frame-3.toml"
STEP, DURATION = 0.01, 4.0


def campaign(folder: Path, excitation: str, structure: str = str(FRAME), extra: str = "") -> Path:
    path = folder / "c.toml"
    path.write_text(f'name = "c"\nstructure = "{structure}"\n{extra}\n[[tests]]\nname = "t"\ndt = {STEP}\n'
                    f'duration = {DURATION}\n\n[[tests.excitation]]\n{excitation}\n'
                    '[[tests.sensors]]\nnodes = "all"\nquantities = ["displacement", "acceleration"]\n')
    return path


def write_csv(path: Path, t: np.ndarray, columns: dict[str, np.ndarray], time_unit: str = "s") -> Path:
    header = ",".join([f"time [{time_unit}]", *columns])
    rows = [",".join(repr(float(v)) for v in row) for row in np.column_stack([t, *columns.values()])]
    path.write_text("\n".join([header, *rows]) + "\n")
    return path


def traces(out: Path) -> dict[str, np.ndarray]:
    with h5py.File(out / "traces" / "t.h5", "r") as f:
        data = {f"channels/{k}": v[()] for k, v in f["channels"].items()}
        data |= {f"excitation/{k}": v[()] for k, v in f["excitation"].items()}
        data["spec"] = json.loads(f["excitation"].attrs["spec"])
    return data


def grid() -> np.ndarray:
    return np.arange(round(DURATION / STEP) + 1) * STEP


def test_a_recorded_drive_is_the_force_it_records(tmp_path):
    """A CSV of 100 cos(15 t) N (in kN) drives the frame as the harmonic item does."""
    t = grid()
    write_csv(tmp_path / "drive.csv", t, {"F [kN]": 0.1 * np.cos(15.0 * t)})
    recorded = run_campaign(campaign(tmp_path, 'kind = "recorded"\nnode = 3\ndir = "x"\nfile = "drive.csv"\n'),
                            tmp_path / "rec", jobs=0)
    (tmp_path / "h").mkdir()
    harmonic = run_campaign(campaign(tmp_path / "h", 'kind = "harmonic"\nnode = 3\ndir = "x"\namplitude = 100.0\n'
                                                     'omega = 15.0\n'), tmp_path / "harm", jobs=0)
    assert recorded.failed == harmonic.failed == 0
    a, b = traces(tmp_path / "rec"), traces(tmp_path / "harm")
    for name in ("excitation/force_3_x", "channels/displacement_1_x", "channels/acceleration_3_x"):
        np.testing.assert_allclose(a[name], b[name], rtol=0, atol=1e-12 * np.abs(b[name]).max())
    (item,) = a["spec"]
    assert item["kind"] == "recorded" and item["unit"] == "kN" and item["channel"] == "F"
    assert "signal" not in item and len(item["sha256"]) == 64


def test_resampling_to_the_step():
    t = np.arange(201) * 0.02
    coarse = Recording("a", "N", np.sin(3.0 * t), 0.02)
    np.testing.assert_allclose(resample(coarse, 0.01, 450, start=0.5),
                               np.interp(np.arange(450) * 0.01, 0.5 + t, np.sin(3.0 * t), left=0, right=0))
    fine_t = np.arange(800) * 0.005  # 4 s: whole periods of 10 Hz and of 80 Hz (above pi/step, 50 Hz)
    fine = Recording("a", "N", np.sin(2 * np.pi * 10 * fine_t) + np.sin(2 * np.pi * 80 * fine_t), 0.005)
    np.testing.assert_allclose(resample(fine, 0.01, 400), np.sin(2 * np.pi * 10 * np.arange(400) * 0.01), atol=1e-9)


def test_csv_uff58_and_hdf5_read_the_same_ground_motion(tmp_path):
    t = np.arange(300) * 0.005
    a = np.sin(7.0 * t) * np.exp(-t)  # in g
    write_csv(tmp_path / "g.csv", t * 1e3, {"ag [g]": a, "other [m/s^2]": 0 * a}, time_unit="ms")
    pyuff.UFF(str(tmp_path / "g.uff")).write_sets([pyuff.prepare_58(
        func_type=1, rsp_node=1, rsp_dir=1, ref_node=0, ref_dir=0, id1="ground x", x=t, data=a, abscissa_spacing=1,
        abscissa_spec_data_type=17, abscissa_axis_units_lab="s", ordinate_spec_data_type=12,
        ordinate_axis_units_lab="g", orddenom_spec_data_type=0, rsp_ent_name="lab", ref_ent_name="lab")], "add")
    with h5py.File(tmp_path / "g.h5", "w") as f:
        f.create_dataset("ground/x", data=a * 9.80665).attrs.update({"unit": "m/s^2", "dt": 0.005})
    read = [read_recording(tmp_path / "g.csv", "ag", "acceleration"),
            read_recording(tmp_path / "g.uff", None, "acceleration"),
            read_recording(tmp_path / "g.h5", "/ground/x", "acceleration")]
    assert [r.unit for r in read] == ["g", "g", "m/s^2"] and [r.channel for r in read] == ["ag", "ground x", "/ground/x"]
    for r in read:
        assert r.dt == pytest.approx(0.005, rel=1e-9)
        np.testing.assert_allclose(r.values, a * 9.80665, rtol=1e-5, atol=1e-6)  # UFF ASCII: 13 digits
    assert read_recording(tmp_path / "g.csv", "ag", "acceleration", unit="m/s^2").values[1] == pytest.approx(a[1])


def test_ground_motion_is_minus_m_r_ag(tmp_path):
    """The frame's relative response to a recorded ground acceleration, against
    the exact zero-order-hold solution of M u'' + C u' + K u = -M r a_g."""
    t = np.arange(2001) * 0.002
    ag = 2.0 * np.sin(9.0 * t) * np.exp(-0.5 * t)  # m/s^2, sampled finer than the step
    write_csv(tmp_path / "quake.csv", t, {"ag [m/s^2]": ag})
    out = tmp_path / "out"
    path = campaign(tmp_path, 'kind = "ground"\ndir = "x"\nfile = "quake.csv"\n')
    assert run_campaign(path, out, jobs=0).failed == 0
    data = traces(out)
    assert [(i["kind"], i["node"], i["mass"]) for i in data["spec"]] == [("ground", 1, 2000.0), ("ground", 2, 2000.0),
                                                                          ("ground", 3, 1500.0)]
    model = load_model(FRAME)
    m, c, k = (x.toarray() for x in (model.mass(), model.damping(), model.stiffness()))
    a_g = resample(Recording("ag", "m/s^2", ag, 0.002), STEP, grid().size)
    np.testing.assert_allclose(data["excitation/force_3_x"], -1500.0 * a_g, rtol=1e-12)
    n = m.shape[0]
    system = np.block([[np.zeros((n, n)), np.eye(n)], [-la.solve(m, k), -la.solve(m, c)]])
    ad = la.expm(system * STEP)
    bd = la.solve(system, (ad - np.eye(2 * n)) @ np.concatenate([np.zeros(n), -np.ones(n)]))  # -M^-1 M r
    x, u = np.zeros(2 * n), []
    for value in a_g:
        u.append(x[:n])
        x = ad @ x + bd * value
    u = np.array(u)
    for j in range(n):
        np.testing.assert_allclose(data[f"channels/displacement_{j + 1}_x"], u[:, j], atol=1e-8 * np.abs(u).max())


def test_ground_motion_uses_the_masses_the_campaign_sets(tmp_path):
    write_csv(tmp_path / "q.csv", grid(), {"ag [g]": np.ones(grid().size)})
    spec = load_campaign(campaign(tmp_path, 'kind = "ground"\ndir = "x"\nfile = "q.csv"\nscale = 0.5\n',
                                  extra="[parameters]\nm_1 = 2500.0\n"))
    items = spec.tests[0].excitation
    assert all(isinstance(i, GroundForce) for i in items) and [i.mass for i in items] == [2500.0, 2000.0, 1500.0]
    np.testing.assert_allclose(items[0].force(grid()[:3], STEP), -2500.0 * 0.5 * 9.80665)


@pytest.mark.parametrize("excitation, files, message", [
    ('kind = "recorded"\nnode = 3\ndir = "x"\nfile = "a.csv"', {"a.csv": "time [s],a [m/s^2]\n0,1\n0.01,2\n"},
     "c.toml:13: tests[1].excitation[1].file: a.csv: a: unit 'm/s^2' is not a force unit; known: N, kN"),
    ('kind = "recorded"\nnode = 3\ndir = "x"\nfile = "a.csv"', {"a.csv": "time [s],a [N],b [N]\n0,1,1\n0.01,2,2\n"},
     "a.csv: holds 2 columns (a, b); name one with channel"),
    ('kind = "recorded"\nnode = 3\ndir = "x"\nfile = "a.csv"\nchannel = "c"', {"a.csv": "time [s],a [N]\n0,1\n1,2\n"},
     "a.csv: no column 'c'; it holds a"),
    ('kind = "recorded"\nnode = 3\ndir = "x"\nfile = "a.csv"', {"a.csv": "time [s],a [N]\n0,1\n0.01,2\n0.5,3\n"},
     "a.csv: a: sample times are not uniformly spaced and increasing"),
    ('kind = "recorded"\nnode = 3\ndir = "x"\nfile = "nowhere.csv"', {}, "nowhere.csv: no such file"),
    ('kind = "recorded"\nnode = 3\ndir = "x"\nfile = "a.txt"', {"a.txt": ""}, "a.txt: unknown signal file type '.txt'"),
    ('kind = "ground"\ndir = "y"\nfile = "a.csv"', {"a.csv": "time [s],a [g]\n0,1\n0.01,2\n"},
     "c.toml:11: tests[1].excitation[1].dir: 'y': not a translation of shear-frame-3 (directions: x)"),
    ('kind = "ground"\nnode = 1\ndir = "x"\nfile = "a.csv"', {"a.csv": "time [s],a [g]\n0,1\n0.01,2\n"},
     "unknown key"),
])
def test_bad_signal_files_name_the_file_and_field(tmp_path, excitation, files, message):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    with pytest.raises(UserError) as err:
        load_campaign(campaign(tmp_path, excitation))
    assert "c.toml:" in str(err.value) and message in str(err.value)


def test_uff_labels_left_blank_read_as_no_unit(tmp_path):
    """A UFF 58 record written without unit labels holds ``NONE`` (pyuff's and
    other writers' empty label): the time is then in s and the force needs
    ``unit``; with it the record reads as a labelled one."""
    t = np.arange(5) * 0.01
    pyuff.UFF(str(tmp_path / "drive.uff")).write_sets([pyuff.prepare_58(
        func_type=1, rsp_node=1, rsp_dir=1, ref_node=1, ref_dir=1, id1="drive", x=t, data=np.arange(5.0),
        abscissa_spacing=1, abscissa_spec_data_type=17, ordinate_spec_data_type=13, orddenom_spec_data_type=0,
        z_axis_spec_data_type=0, rsp_ent_name="lab", ref_ent_name="lab")], "overwrite")
    assert "NONE" in (tmp_path / "drive.uff").read_text()
    with pytest.raises(UserError, match=r"drive.uff: drive: no unit \(give unit\) is not a force unit"):
        load_campaign(campaign(tmp_path, 'kind = "recorded"\nnode = 3\ndir = "x"\nfile = "drive.uff"'))
    read = read_recording(tmp_path / "drive.uff", None, "force", unit="kN")
    assert read.dt == pytest.approx(0.01, rel=1e-9) and read.values.tolist() == pytest.approx([0, 1e3, 2e3, 3e3, 4e3])


def test_hdf5_without_a_unit_and_ground_on_a_modal_model(tmp_path):
    with h5py.File(tmp_path / "a.h5", "w") as f:
        f.create_dataset("a", data=np.ones(5)).attrs["dt"] = 0.01
    with pytest.raises(UserError, match=r"a.h5: /a: no unit \(give unit\) is not a force unit"):
        load_campaign(campaign(tmp_path, 'kind = "recorded"\nnode = 3\ndir = "x"\nfile = "a.h5"'))
    spec = load_campaign(campaign(tmp_path, 'kind = "recorded"\nnode = 3\ndir = "x"\nfile = "a.h5"\nunit = "lbf"'))
    (item,) = spec.tests[0].excitation
    assert isinstance(item, RecordedForce) and item.force(np.array([0.0, 0.04, 0.05]), STEP).tolist() == [
        4.4482216152605, 4.4482216152605, 0.0]  # zero after the record
    with pytest.raises(UserError, match="ground motion needs a finite-element structure's mass matrix"):
        load_campaign(campaign(tmp_path, 'kind = "ground"\ndir = "w"\nfile = "a.h5"\nunit = "g"',
                               structure="ch5-simply-supported-beam"))


def test_the_plugins_cache_key_follows_the_signal(tmp_path):
    write_csv(tmp_path / "drive.csv", grid(), {"F [N]": np.cos(15.0 * grid())})
    path = campaign(tmp_path, 'kind = "recorded"\nnode = 3\ndir = "x"\nfile = "drive.csv"\n')
    first = cached_campaign(path, tmp_path / "cache", jobs=0)
    assert cached_campaign(path, tmp_path / "cache", jobs=0) == first
    write_csv(tmp_path / "drive.csv", grid(), {"F [N]": 2 * np.cos(15.0 * grid())})
    second = cached_campaign(path, tmp_path / "cache", jobs=0)
    assert second != first and traces(second)["excitation/force_3_x"][0] == 2.0
