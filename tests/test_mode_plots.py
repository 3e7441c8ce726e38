"""``structbench plot-modes``: each mode drawn on the geometry. The node
positions plotted (read back from the Figure's artists) are the file's
coordinates (undeformed) and those plus the scaled shape along each node's
displacement directions (deformed); 3-D axes for a 3-D geometry, 2-D for a
beam; a PNG per mode and GIF or HTML animations; no pyplot."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import structbench as sb
from structbench.cli import main
from structbench.evaluation.mode_plots import DEFORMED, UNDEFORMED, mode_figure, mode_view
from structbench.labdata.geometry import geometry_from_model, read_geometry
from structbench.models import load_model

from test_labdata_geometry import EXPECTED, geometry_lines


def _i(*values: int) -> str:
    return "".join(f"{v:10d}" for v in values)


def _e(*values: float) -> str:
    return "".join(f"{v:13.5E}" for v in values)


# two normal modes at nodes 1-4 of the frame (x y z per node)
SHAPES = {1: [(0.0, 0.0, 1.0), (0.2, 0.0, 0.0)], 2: [(1.0, 0.0, 0.5), (0.0, 0.0, -1.0)],
          3: [(0.0, 0.5, 0.0), (0.0, 0.0, 0.0)], 4: [(0.0, 0.0, -0.5), (0.0, 1.0, 0.0)]}


def frame_folder(tmp_path: Path) -> Path:
    """A folder with the frame's geometry and two imported normal modes."""
    lines = geometry_lines()
    for k, f in enumerate((2.0, 5.0)):
        lines += ["    -1", "    55", "frame modes", "NONE", "NONE", "NONE", "NONE", _i(1, 2, 2, 8, 2, 3),
                  _i(2, 4, 1, k + 1), _e(f, 1.0, 0.01, 0.0)]
        for node, values in SHAPES.items():
            lines += [_i(node), _e(*values[k])]
        lines.append("    -1")
    source = tmp_path / "frame.unv"
    source.write_text("\n".join(lines) + "\n")
    sb.import_data([source], tmp_path / "lab")
    return tmp_path / "lab"


def _points(fig, label: str) -> np.ndarray:
    ax = fig.axes[0]
    line = next(a for a in ax.get_lines() if a.get_label() == label)
    data = line.get_data_3d() if hasattr(line, "get_data_3d") else line.get_data()
    return np.column_stack([np.asarray(v, dtype=float) for v in data])


def test_plotted_nodes_are_the_file_coordinates_and_the_scaled_shape(tmp_path):
    folder = frame_folder(tmp_path)
    geometry = read_geometry(folder / "geometry.json")
    doc = json.loads((folder / "results" / "uff55-frame.json").read_text())
    run = doc["runs"][0]
    for k in range(2):
        view = mode_view(geometry, run["sensors"], np.array(run["mode_shapes"][k]), "mode", scale=0.1)
        fig = mode_figure(view)
        assert fig.axes[0].name == "3d" and type(fig.canvas).__name__ == "FigureCanvasAgg"
        undeformed = _points(fig, UNDEFORMED)
        np.testing.assert_allclose(undeformed, [EXPECTED[n] for n in (1, 2, 3, 4)], atol=1e-12)
        # expected motion: each x/y/z value along the node's displacement system (node 2: system 1, x -> global y)
        axes = {n: np.eye(3) for n in EXPECTED} | {2: np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]])}
        # the results' shapes are scaled to a positive largest entry: the file's sign may be flipped
        node, code = run["sensors"][0].split("_")[1:]
        sign = np.sign(run["mode_shapes"][k][0] * SHAPES[int(node)][k]["xyz".index(code)] or 1.0)
        assert run["sensors"][0] == "displacement_1_x" and sign == (1 if k == 0 else -1)
        moved = sign * np.array([np.array(SHAPES[n][k]) @ axes[n] for n in (1, 2, 3, 4)])
        size = np.linalg.norm(np.ptp(undeformed, axis=0))
        expected = undeformed + moved * 0.1 * size / np.abs(moved).max()
        np.testing.assert_allclose(_points(fig, DEFORMED), expected, atol=1e-9)


def test_a_beam_from_the_model_is_drawn_in_its_plane(tmp_path):
    model = load_model("ch3-free-free-beam")
    geometry = geometry_from_model(model)
    sensors = [f"acceleration_{n}_w" for n in range(1, 17)] + ["acceleration_3_theta"]
    shape = np.r_[np.cos(np.linspace(0, np.pi, 16)), 5.0]  # the rotation is not drawn
    fig = mode_figure(mode_view(geometry, sensors, shape, "beam", scale=0.2))
    ax = fig.axes[0]
    assert ax.name == "rectilinear" and ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "z (m)"
    x, z = _points(fig, UNDEFORMED).T
    np.testing.assert_allclose(x, [model.nodes[n][0] for n in range(1, 17)])
    np.testing.assert_allclose(z, 0.0)
    _, w = _points(fig, DEFORMED).T
    np.testing.assert_allclose(w, shape[:16] * 0.2 * 15.0 / 1.0)


@pytest.mark.parametrize("animate", ["gif", "html"])
def test_plot_modes_command_writes_a_png_per_mode_and_animations(tmp_path, capsys, animate):
    folder = frame_folder(tmp_path)
    assert main(["plot-modes", str(folder), "--animate", animate]) == 0
    names = sorted(p.name for p in (folder / "modes").iterdir())
    assert names == sorted([f"uff55-frame-mode{k}.{ext}" for k in (1, 2) for ext in ("png", animate)])
    png = (folder / "modes" / "uff55-frame-mode1.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    animation = (folder / "modes" / f"uff55-frame-mode1.{animate}").read_bytes()
    assert animation[:6] == b"GIF89a" if animate == "gif" else b"<script" in animation
    assert "uff55-frame-mode2.png" in capsys.readouterr().out


def test_campaign_results_use_the_model_geometry_and_geometry_option(tmp_path, capsys):
    results = tmp_path / "c" / "results"
    results.mkdir(parents=True)
    run = {"method": "modal", "structure": "ch5-membrane", "repetition": 0, "tests": ["t"], "omega": [3.0],
           "eigenvalues": [9.0], "mode_shapes": [[1.0, -0.5, 0.5]], "damping": [0.01],
           "sensors": ["acceleration_1_w", "acceleration_6_w", "acceleration_16_w"]}
    (results / "modal.json").write_text(json.dumps(
        {"format": "structbench-result", "format_version": 1, "method": "modal", "campaign": "c",
         "structure": "ch5-membrane", "model": "ch5-membrane", "software": "x", "options": {}, "runs": [run]}))
    written = sb.plot_modes(tmp_path / "c")
    assert [p.name for p in written] == ["modal-mode1.png"]
    sb.model_geometry("ch5-membrane", tmp_path / "membrane.json")
    assert main(["plot-modes", str(tmp_path / "c"), "--geometry", str(tmp_path / "membrane.json"),
                 "--out", str(tmp_path / "plots")]) == 0
    assert (tmp_path / "plots" / "modal-mode1.png").is_file()
    run["structure"] = "lab-thing"
    (results / "modal.json").write_text(json.dumps(
        {"format": "structbench-result", "format_version": 1, "method": "modal", "campaign": "c",
         "structure": "lab-thing", "model": "lab-thing", "software": "x", "options": {}, "runs": [run]}))
    assert main(["plot-modes", str(tmp_path / "c")]) == 2
    assert "--geometry" in capsys.readouterr().err


def test_plotting_leaves_pyplot_alone(tmp_path):
    folder = frame_folder(tmp_path)
    # the rcParams entry read without resolving it (matplotlib.get_backend() would import pyplot)
    code = ("import sys, matplotlib; backend = lambda: dict.__getitem__(matplotlib.rcParams, 'backend'); "
            f"before = backend(); import structbench as sb; sb.plot_modes({str(folder)!r}, animate='gif'); "
            "assert 'matplotlib.pyplot' not in sys.modules, 'pyplot imported'; assert backend() == before")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=300)


def test_undrawn_sensors_are_named_in_the_title(tmp_path):
    geometry = geometry_from_model(load_model("ch3-free-free-beam"))
    view = mode_view(geometry, ["acceleration_1_w", "acceleration_2_theta", "acceleration_99_w"],
                     np.array([1.0, 0.5, 0.2]), "beam")
    assert "2 of 3 sensors not drawn" in mode_figure(view).axes[0].get_title()
    with pytest.raises(sb.UserError, match="no sensor"):
        mode_view(geometry, ["acceleration_99_w"], np.array([1.0]), "beam")
