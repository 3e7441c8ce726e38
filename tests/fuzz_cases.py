"""The fuzzed formats: seed files and one property per format, shared by
tests/test_fuzz_*.py (short, derandomized) and benchmarks/fuzz_long.py.

Each property takes a drawn case and a scratch folder, runs the command
line on it and asserts success or a clean exit 2 (:func:`assert_clean_failure`).
"""
from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from faulty_fixtures import build_faulty
from fuzz_strategies import assert_clean_failure, cli, copy_folder, damage_trace, toml_value
from identify_synth import harmonic_force, respond, write_trace

REPO = Path(__file__).resolve().parent.parent
CAMPAIGNS = sorted(p for p in (REPO / "campaigns").glob("*.toml") if "[[tests]]" in p.read_text())  # not models
MODELS = [REPO / "docs" / "examples" / "shear-frame-3.toml"]
FRAME = MODELS[0]
SENSORS = [(q, n, "x") for q in ("displacement", "velocity", "acceleration") for n in (1, 2, 3)] + [("force", 3, "x")]


def parsed(path: Path) -> tuple[str, dict[str, Any]]:
    text = path.read_text()
    return text, tomllib.loads(text)


# ---- seeds -------------------------------------------------------------------

def trace_seed(root: Path) -> Path:
    """Four harmonic traces of the 3-storey frame (every identifier succeeds on them)."""
    from structbench.models import load_model

    model = load_model(FRAME)
    t = np.arange(401) * 0.01
    for i, omega in enumerate([5.0, 11.0, 17.0, 30.0]):
        response = respond(model, harmonic_force(model, 3, "x", 1000.0, omega, t), 0.01)
        write_trace(root / "traces" / f"h{i}.h5", model, response, 0.01, SENSORS, test=f"h{i}",
                    excitation_attrs={"omega": omega})
    return root


def score_seed(root: Path) -> Path:
    """A campaign folder with results of two methods, truth.json and a [check] table."""
    trace_seed(root)
    for method in ("least-squares", "rayleigh"):
        code, err = cli(["identify", str(root), "--method", method, "--model", str(FRAME)])
        assert code == 0, err
    ls = json.loads((root / "results" / "least-squares.json").read_text())["runs"][0]
    ry = json.loads((root / "results" / "rayleigh.json").read_text())["runs"][0]
    truth = {"format": "structbench-truth", "parameters": [{"label": p["label"], "value": p["value"] * 1.01}
                                                           for p in ls["parameters"]],
             "omega": ry["omega"], "sensor_dofs": [[1, "x"], [2, "x"], [3, "x"]],
             "mode_shapes": np.array(ry["mode_shapes"]).T.tolist()}
    (root / "truth.json").write_text(json.dumps(truth, indent=1))
    (root / "campaign.toml").write_text('name = "frame"\n[check]\nrms_max = 0.1\nmac_min = 0.9\n'
                                        '[check.rayleigh]\nmodes = [1, 2]\n')
    return root


EXTERNAL = """\
name = "mapped"
structure = "Faulty.fmu"

[locations]
1 = [0.0, 0.0, 0.0]

[defaults]
dt = 0.01
duration = 0.2
sensors = [{nodes = "all", dirs = ["z"], quantities = ["displacement", "acceleration", "force"]}]

[[tests]]
name = "sine"
excitation = [{kind = "harmonic", node = 1, dir = "z", amplitude = 1.0, omega = 5.0}]
"""


def external_seed(root: Path) -> Path:
    """The C test FMU (well-behaved: fail_kind 0) next to where the campaigns go."""
    build_faulty(root)
    return root


# ---- properties ----------------------------------------------------------------

def _no_leftovers(out: Path) -> None:
    """Nothing half-written: no temporary files, and no traces or status after a refusal."""
    assert not list(out.rglob(".*.tmp"))
    assert not list(out.rglob("*.h5")) and not (out / "status.json").exists()


def campaign_case(text: str, scratch: Path, fmu_dir: Path) -> int:
    """``run`` a mutated campaign with the simulation left out (tests stay
    pending): loading, the output folder, the FMU and the truth."""
    from structbench.harness import run as harness_run

    path, out = scratch / "campaign.toml", scratch / "out"
    shutil.rmtree(out, ignore_errors=True)
    path.write_text(text)
    original = harness_run.Scheduler.run
    harness_run.Scheduler.run = lambda self: None
    try:
        code, err = cli(["run", str(path), "--out", str(out), "--jobs", "0", "--fmu-dir", str(fmu_dir)])
    finally:
        harness_run.Scheduler.run = original
    assert_clean_failure(code, err, (0, 2), path.name)
    if code == 2 and out.exists():
        _no_leftovers(out)
    return code


def model_case(text: str, scratch: Path) -> int:
    """``modes`` of a mutated model file."""
    path = scratch / "model.toml"
    path.write_text(text)
    code, err = cli(["modes", str(path), "--count", "3"])
    assert_clean_failure(code, err, (0, 2), path.name)
    return code


def trace_case(damage: tuple[str, dict], which: int, method: str, seed: Path, scratch: Path) -> int:
    """``identify`` on a campaign folder with one damaged trace file."""
    folder = copy_folder(seed, scratch / "traces-case")
    victim = sorted((folder / "traces").glob("*.h5"))[which % 4]
    damage_trace(victim, *damage)
    code, err = cli(["identify", str(folder), "--method", method, "--model", str(FRAME)])
    assert_clean_failure(code, err, (0, 2), victim.name)
    if code == 2:
        assert not (folder / "results").exists()
    return code


def results_case(text: str, target: str, command: str, seed: Path, scratch: Path) -> int:
    """``score`` or ``check`` with one damaged JSON file (a results file or truth.json)."""
    folder = copy_folder(seed, scratch / "score-case")
    (folder / target).write_text(text)
    code, err = cli([command, str(folder)])
    assert_clean_failure(code, err, (0, 1, 2) if command == "check" else (0, 2), Path(target).name)
    return code


def mapping_case(mapping: dict[str, Any], seed: Path, scratch: Path) -> int:
    """``run`` (really: 0.2 s on the C FMU, in process) with a random ``[mapping]``."""
    path, out = seed / "mapped.toml", scratch / "mapped-out"
    shutil.rmtree(out, ignore_errors=True)
    path.write_text(f"mapping = {toml_value(mapping)}\n" + EXTERNAL)
    code, err = cli(["run", str(path), "--out", str(out), "--jobs", "0"])
    assert_clean_failure(code, err, (0, 2), path.name)
    if code == 2 and out.exists():
        _no_leftovers(out)
    return code

