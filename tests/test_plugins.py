"""A user's own identifier: the example plugin package under docs/examples,
installed with pip into a folder on sys.path, found through its entry point
(group ``structbench.identifiers``) and run by ``identify`` and gated by
``check`` exactly as a built-in method."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import structbench as sb
from structbench.cli import main

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "docs" / "examples" / "structbench-peaks"
CAMPAIGN = f'''
name = "frame-peaks"
structure = "{ROOT / "docs" / "examples" / "shear-frame-3.toml"}"
seed = 1

[check.peaks]
freq_error_pct_max = 0.5

[check.peaks-one]
freq_error_pct_max = 0.001

[[tests]]
name = "impulse"
dt = 0.002
duration = 30.0

[[tests.excitation]]
kind = "impulse"
node = 1
dir = "x"
impulse = 100.0
method = "initial-velocity"

[[tests.sensors]]
nodes = "all"
quantities = ["acceleration"]
'''


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    site, source = tmp_path_factory.mktemp("site"), tmp_path_factory.mktemp("plugin") / "src"
    shutil.copytree(PLUGIN, source, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                    "--target", str(site), str(source)], check=True, capture_output=True)
    sys.path.insert(0, str(site))
    yield site
    sys.path.remove(str(site))


@pytest.fixture(scope="module")
def frame(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("frame")
    (base / "frame.toml").write_text(CAMPAIGN)
    assert main(["run", str(base / "frame.toml"), "--out", str(base / "out"), "--jobs", "0"]) == 0
    return base / "out"


def test_the_plugin_is_a_method(installed):
    method = sb.methods()["peaks"]
    assert method.defaults == {"modes": 3, "quantity": "acceleration", "pad": 8}
    assert "peak picking" in method.help and list(sb.methods())[:3] == ["least-squares", "perturbation", "rayleigh"]


def test_methods_lists_what_each_needs(installed, capsys):
    """``structbench methods --json``: every method of the registry with its options and the channels it needs."""
    assert main(["methods", "--json"]) == 0
    listed = {m["name"]: m for m in json.loads(capsys.readouterr().out)}
    assert list(listed) == list(sb.methods())
    assert listed["peaks"]["channels"] == "one or more channels of the chosen quantity; a free or random response"
    assert listed["modal"]["options"]["input"] == {"default": "auto", "choices": ["auto", "off", "on", "poles"]}
    assert listed["updating"]["needs_prior"] and not listed["least-squares"]["needs_prior"]
    assert all(m["channels"] != "not stated" for name, m in listed.items())
    assert main(["methods"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("least-squares\n  what     chapter 3") and "\npeaks\n" in text


def test_identify_and_check_run_the_plugin(installed, frame, capsys):
    assert main(["identify", str(frame), "--method", "peaks"]) == 0
    assert main(["identify", str(frame), "--method", "peaks", "--option", "modes=1", "--tag", "one"]) == 0
    doc = json.loads((frame / "results" / "peaks.json").read_text())
    assert doc["method"] == "peaks" and doc["options"]["modes"] == 3 and len(doc["runs"][0]["omega"]) == 3
    truth = json.loads((frame / "truth.json").read_text())["omega"]
    assert doc["runs"][0]["omega"] == pytest.approx(truth, rel=2e-3)
    one = json.loads((frame / "results" / "peaks-one.json").read_text())
    assert one["options"]["modes"] == 1 and len(one["runs"][0]["omega"]) == 1
    capsys.readouterr()
    # the 0.001 % gate on mode 1 fails, the 0.5 % gate passes: check exits 1 and says which
    assert main(["check", str(frame)]) == 1
    lines = sorted(capsys.readouterr().out.splitlines()[:2])
    assert lines[0].startswith("FAIL  peaks-one ") and lines[1].startswith("PASS  peaks ")


def test_plugin_option_errors_are_user_errors(installed, frame, capsys):
    assert main(["identify", str(frame), "--method", "peaks", "--option", "bins=3"]) == 2
    assert "unknown option(s) ['bins'] for method peaks" in capsys.readouterr().err
    assert main(["identify", str(frame), "--method", "peaks", "--option", "quantity=\"velocity\""]) == 2
    assert "no velocity channel" in capsys.readouterr().err
