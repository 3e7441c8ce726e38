"""Excitation points of ``structbench plan`` (``--drives``): every candidate
scored against a full ``plan --method modal`` of the test driven there; a
drive at a node of some modes is ranked after those that show every mode;
the written campaign carries the best point; user errors exit 2."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import structbench as sb
from structbench.cli.main import main


def beam(folder: Path, elements: int = 8) -> Path:
    """A damped simply supported beam (L = 10 m, m = 1 kg/m, EI = 1 N m^2) of
    ``elements`` beam elements, a free decay after an impulse at node 3 seen
    by three displacement sensors (nodes 2, 4, 7); the campaign's path."""
    lines = [f'name = "beam{elements}"', "rayleigh = [0.004, 0.004]"]
    lines += [f"[[nodes]]\nid = {i + 1}\nx = {i * 10 / elements!r}" for i in range(elements + 1)]
    lines += [f'[[elements]]\ntype = "beam"\nnodes = [{i + 1}, {i + 2}]\nm = 1.0\nk = {(elements / 10) ** 3!r}'
              for i in range(elements)]
    lines += ['[[supports]]\nnode = 1\nfix = ["w"]', f'[[supports]]\nnode = {elements + 1}\nfix = ["w"]']
    (folder / "beam.toml").write_text("\n".join(lines) + "\n")
    return write_campaign(folder / "c.toml", 3, "w")


def write_campaign(path: Path, node: int, direction: str, kind: str = "impulse") -> Path:
    excitation = (f'kind = "impulse"\nnode = {node}\ndir = "{direction}"\nimpulse = 1.0\nmethod = "initial-velocity"'
                  if kind == "impulse" else f'kind = "harmonic"\nnode = {node}\ndir = "{direction}"\n'
                                            'amplitude = 1.0\nomega = 0.5')
    path.write_text(f"""structure = "beam.toml"
[[tests]]
name = "knock"
dt = 0.05
duration = 300.0
noise = {{sensor = 0.02}}
[[tests.excitation]]
{excitation}
[[tests.sensors]]
nodes = [2, 4, 7]
dirs = ["w"]
quantities = ["displacement"]
""")
    return path


def test_each_drive_is_scored_as_a_plan_of_the_test_driven_there(tmp_path: Path) -> None:
    campaign = beam(tmp_path)
    drives = [(n, "w") for n in range(2, 9)] + [(1, "theta"), (5, "theta")]
    (tmp_path / "drives.csv").write_text("node,dir\n" + "".join(f"{n},{d}\n" for n, d in drives))
    doc = sb.plan(campaign, "modal", drives=tmp_path / "drives.csv", layout_out=tmp_path / "best.toml")
    section = doc["drives"]
    assert section["candidates"] == 9 and len(section["ranking"]) == 9
    assert section["sensors"] == [[2, "w", "displacement"], [4, "w", "displacement"], [7, "w", "displacement"]]
    targets = np.array(section["target_modes"])
    by_point = {(r["node"], r["dir"]): r for r in section["ranking"]}
    best_rel: dict[float, float] = {}  # per mode seen from some point: its least relative omega std
    for node, direction in drives:  # the independent route: the whole modal plan of a campaign driven there
        single = sb.plan(write_campaign(tmp_path / f"d{node}{direction}.toml", node, direction), "modal")
        rel = {round(m["omega"], 8): m["predicted_omega_std"] / m["omega"] for m in single["modes"]}
        best_rel |= {w: min(v, best_rel.get(w, np.inf)) for w, v in rel.items()}
        seen = [w for w in targets if round(w, 8) in rel]
        row = by_point[(node, direction)]
        assert row["missed"] == pytest.approx([w for w in targets if round(w, 8) not in rel], rel=1e-12)
        assert row["rms_rel_omega_std"] == pytest.approx(
            np.sqrt(np.mean([rel[round(w, 8)] ** 2 for w in seen])), rel=1e-9)
    # the targets: the modes some point determines to 0.5 % (here not every mode seen)
    assert sorted(round(w, 8) for w in targets) == sorted(w for w, v in best_rel.items() if v < 0.005)
    assert len(best_rel) > len(targets) >= 5
    # node 5 is the midspan: modes 2, 4, 6 have a node there and are not seen from it
    midspan = by_point[(5, "w")]
    assert len(midspan["missed"]) >= 3
    order = [(r["node"], r["dir"]) for r in section["ranking"]]
    assert all(order.index((5, "w")) > order.index(p) for p, r in by_point.items() if not r["missed"])
    keys = [(len(r["missed"]), r["rms_rel_omega_std"]) for r in section["ranking"]]
    assert keys == sorted(keys)
    # the written campaign is driven at the best point and the plan's modes are its
    best = sb.load_campaign(tmp_path / "best.toml").tests[0]
    (item,) = best.excitation
    assert (item.node, item.direction) == tuple(section["chosen"]) == order[0]
    assert sorted(c.name for c in best.channels) == ["displacement_2_w", "displacement_4_w", "displacement_7_w"]
    planned = {round(m["omega"], 8): m["predicted_omega_std"] / m["omega"] for m in doc["modes"]}
    hit = [round(w, 8) for w in targets if round(w, 8) in planned]
    assert len(hit) == len(targets) - len(section["ranking"][0]["missed"])
    assert np.sqrt(np.mean([planned[w] ** 2 for w in hit])) == pytest.approx(section["ranking"][0]["rms_rel_omega_std"],
                                                                            rel=1e-9)


def test_drives_with_a_layout_use_its_sensors(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """A layout of criterion d-optimal: the points are ranked on its sensors
    (the frequencies criterion chooses both together: tests/test_plan_joint.py)."""
    campaign = beam(tmp_path)
    (tmp_path / "cand.toml").write_text('[[candidates]]\nnodes = "all"\ndirs = ["w"]\nquantities = ["displacement"]\n')
    (tmp_path / "drives.toml").write_text('[[drives]]\nnodes = [2, 3, 4, 5]\ndirs = ["w"]\n')
    base = ["plan", str(campaign), "--method", "modal", "--candidates", str(tmp_path / "cand.toml"), "--sensors", "3",
            "--drives", str(tmp_path / "drives.toml"), "--layout-out", str(tmp_path / "out.toml"),
            "--criterion", "d-optimal"]
    assert main(base + ["--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["drives"]["sensors"] == doc["layout"]["sensors"] and doc["drives"]["candidates"] == 4
    assert doc["drives"]["target_modes"] == doc["layout"]["target_modes"]
    written = sb.load_campaign(tmp_path / "out.toml").tests[0]
    assert (written.excitation[0].node, written.excitation[0].direction) == tuple(doc["drives"]["chosen"])
    assert sorted(c.name for c in written.channels) == sorted(f"{q}_{n}_{d}" for n, d, q in doc["layout"]["sensors"])
    assert main(base) == 0
    assert f"excitation point: node {doc['drives']['chosen'][0]} w (4 candidates" in capsys.readouterr().out


@pytest.mark.parametrize("drives, kind, method, message", [
    ("node,dir\n1,w\n", "impulse", "modal", "not a free DOF"),  # node 1's w is supported
    ("node,where\n2,w\n", "impulse", "modal", "header node,dir"),
    ("node,dir\n2,w\n", "harmonic", "modal", "one impulse"),
    ("node,dir\n2,w\n", "impulse", "least-squares", "modal method"),
])
def test_user_errors(tmp_path: Path, capsys: pytest.CaptureFixture, drives: str, kind: str, method: str,
                     message: str) -> None:
    beam(tmp_path)
    campaign = write_campaign(tmp_path / "c.toml", 3, "w", kind)
    (tmp_path / "drives.csv").write_text(drives)
    assert main(["plan", str(campaign), "--method", method, "--drives", str(tmp_path / "drives.csv"),
                 "--layout-out", str(tmp_path / "out.toml")]) == 2
    err = capsys.readouterr().err
    assert message in err and "--drives" in err and "Traceback" not in err
