"""Sensors and excitation point chosen together (``plan --candidates --drives``,
criterion ``frequencies``): the pair equals an exhaustive search over every
point and every layout, beats the sequential choice (layout at the test's
own point, then the best point for it) on a beam where the two differ, and
its score is the plan of the campaign it writes."""
from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest

import structbench as sb
from structbench.cli.main import main
from structbench.planning import drives as dv
from structbench.planning import free_decay as fd
from structbench.planning import layouts
from test_plan_layout import small_beam


def exhaustive(campaign: Path, cand_file: Path, drive_file: Path, k: int,
               targets: list[float]) -> tuple[tuple[int, float], list[tuple]]:
    """The least (missed, RMS) over every point and every k of the candidate
    channels (at most one per location), each pair scored by the bound of
    the decay driven there through those channels; the pairs reaching it."""
    loaded = sb.load_campaign(campaign)
    model, test = loaded.model, loaded.tests[0]
    cands = layouts.read_candidates(cand_file, model)
    points = dv.read_drives(drive_file, model)
    base = fd.decay(model, test)
    index = np.flatnonzero(np.isclose(base.omega[:, None], np.array(targets)[None], rtol=1e-9).any(axis=1))
    assert index.size == len(targets)
    cache: dict = {}
    keys = {}
    for sub in itertools.combinations(cands, k):
        if len({(n, d) for n, d, _ in sub}) < k:
            continue
        seen, rel = dv.point_bounds(model, base, 1.0, points, dv.sensor_channels(model, test, list(sub)), cache)
        for p, s, r in zip(points, seen, rel):
            keys[(p, sub)] = dv.rank_key(dv.score_row(p, s, r, index, base.omega))
    best = min(keys.values())
    return best, [pair for pair, key in keys.items() if key[0] == best[0] and key[1] <= best[1] * (1 + 1e-9)]


def test_joint_choice_is_the_exhaustive_optimum_and_beats_the_sequential_one(tmp_path: Path) -> None:
    """7 beam elements, 14 candidate channels (w and theta), 2 sensors, 14
    points: 1,274 pairs. The joint pair is the global optimum (or its mirror
    image); the sequential pair, computed through the public route (plan the
    layout, then rank the points on it), is 1.4 times worse."""
    campaign = small_beam(tmp_path, elements=7)
    (tmp_path / "drives.toml").write_text('[[drives]]\nnodes = "all"\n')
    doc = sb.plan(campaign, "modal", candidates=tmp_path / "cand.toml", sensors=2, drives=tmp_path / "drives.toml",
                  layout_out=tmp_path / "joint.toml")
    section = doc["drives"]
    assert section["joint"] and section["candidates"] == 14
    best, pairs = exhaustive(campaign, tmp_path / "cand.toml", tmp_path / "drives.toml", 2, section["target_modes"])
    top = section["ranking"][0]
    assert (len(top["missed"]), top["rms_rel_omega_std"]) == (best[0], pytest.approx(best[1], rel=1e-9))
    chosen = (tuple(section["chosen"]), tuple(tuple(s) for s in section["sensors"]))
    assert chosen in pairs
    # the sequential route: the layout at the test's own point, then the best point for it
    alone = sb.plan(campaign, "modal", candidates=tmp_path / "cand.toml", sensors=2, layout_out=tmp_path / "lay.toml")
    loaded = sb.load_campaign(campaign)
    ranked = dv.rank_drives(loaded.model, loaded.tests[0], [tuple(s) for s in alone["layout"]["sensors"]],
                            dv.read_drives(tmp_path / "drives.toml", loaded.model), targets=section["target_modes"])
    sequential = ranked["ranking"][0]
    assert section["sequential"]["rms_rel_omega_std"] == pytest.approx(sequential["rms_rel_omega_std"], rel=1e-9)
    assert top["rms_rel_omega_std"] < 0.8 * sequential["rms_rel_omega_std"]
    # the written campaign: the chosen point and sensors; its own plan predicts the pair's score
    written = sb.load_campaign(tmp_path / "joint.toml").tests[0]
    (item,) = written.excitation
    assert (item.node, item.direction) == chosen[0]
    assert sorted(c.name for c in written.channels) == sorted(f"{q}_{n}_{d}" for n, d, q in chosen[1])
    rel = {round(m["omega"], 8): m["predicted_omega_std"] / m["omega"] for m in doc["modes"]}
    assert np.sqrt(np.mean([rel[round(w, 8)] ** 2 for w in section["target_modes"]])) == pytest.approx(
        top["rms_rel_omega_std"], rel=1e-9)
    # every point is ranked with a layout of its own, best first (RMS within 1e-6 relative: tied)
    keys = [(len(r["missed"]), r["rms_rel_omega_std"]) for r in section["ranking"]]
    assert len(keys) == 14 and all(a[0] < b[0] or (a[0] == b[0] and a[1] <= b[1] * (1 + 1e-6))
                                   for a, b in zip(keys, keys[1:]))


def test_joint_choice_on_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """The JSON's drives section (joint, sequential, each point's sensors) and
    the table's excitation line."""
    campaign = small_beam(tmp_path, elements=5)
    (tmp_path / "drives.csv").write_text("node,dir\n2,w\n3,w\n1,theta\n3,theta\n")
    base = ["plan", str(campaign), "--method", "modal", "--candidates", str(tmp_path / "cand.toml"), "--sensors", "3",
            "--drives", str(tmp_path / "drives.csv"), "--layout-out", str(tmp_path / "out.toml")]
    assert main(base + ["--json"]) == 0
    section = json.loads(capsys.readouterr().out)["drives"]
    assert section["joint"] and {(r["node"], r["dir"]) for r in section["ranking"]} == {
        (2, "w"), (3, "w"), (1, "theta"), (3, "theta")}
    assert all(len(r["sensors"]) == 3 for r in section["ranking"])
    assert section["sensors"] == section["ranking"][0]["sensors"]
    assert section["ranking"][0]["rms_rel_omega_std"] <= section["sequential"]["rms_rel_omega_std"]
    assert main(base) == 0
    assert f"excitation point: node {section['chosen'][0]} {section['chosen'][1]} (4 candidates" in \
        capsys.readouterr().out
