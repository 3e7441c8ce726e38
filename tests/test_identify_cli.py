"""``structbench identify`` on synthetic campaign folders; a TOML model."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from structbench.cli import main
from structbench.identifier import least_squares, rayleigh
from structbench.identifier.io.results import read_results
from structbench.identifier.io.traces import read_trace
from identify_synth import harmonic_force, respond, write_trace
from structbench.models import load_model

SHEAR_FRAME = Path(__file__).resolve().parents[1] / "docs" / "examples" / "shear-frame-3.toml"


@pytest.fixture(scope="module")
def beam_campaign(tmp_path_factory):
    """The chapter 5 beam, two repetitions of one impulse test."""
    beam = load_model("ch5-simply-supported-beam")
    folder = tmp_path_factory.mktemp("ch5")
    x0 = np.concatenate([np.zeros(beam.n_modes), beam.shapes[0]])
    response = respond(beam, np.zeros((2001, beam.n_dof)), 0.05, x0)
    sensors = [(q, i + 1, "w") for q in ("displacement", "velocity") for i in range(beam.n_dof)]
    for r in (0, 1):
        write_trace(folder / "traces" / f"impulse-r{r}.h5", beam, response, 0.05, sensors, test="impulse",
                    repetition=r, excitation_attrs={"kind": "impulse"})
    return folder


def test_rayleigh_writes_one_run_per_repetition(beam_campaign, capsys):
    assert main(["identify", str(beam_campaign), "--method", "rayleigh"]) == 0
    assert "rayleigh: 2 run(s)" in capsys.readouterr().out
    header, runs = read_results(beam_campaign / "results" / "rayleigh.json")
    assert header["method"] == "rayleigh" and header["options"]["window"] == "hann"
    assert [r.repetition for r in runs] == [0, 1]
    assert runs[0].omega[1] == pytest.approx(0.39478, rel=1e-3)
    assert runs[0].sensors[0] == "displacement_1_w" and len(runs[0].mode_shapes[0]) == 10


def test_json_output_and_tag(beam_campaign, capsys):
    assert main(["identify", str(beam_campaign), "--method", "rayleigh", "--window", "rectangular",
                 "--tag", "plain", "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    assert document["format"] == "structbench-result" and document["runs"][0]["details"]["window"] == "rectangular"
    assert (beam_campaign / "results" / "rayleigh-plain.json").is_file()


def test_perturbation_defaults_to_the_postulated_model(tmp_path, capsys):
    actual = load_model("ch4-cantilever-case1")
    t = np.arange(8001) * 0.025
    response = respond(actual, harmonic_force(actual, 7, "w", 1.0, 0.5, t), 0.025)
    write_trace(tmp_path / "traces" / "exact-01.h5", actual, response, 0.025,
                [("displacement", n, d) for n, d in actual.dofs] + [("force", 7, "w")],
                test="exact-01", excitation_attrs={"omega": 0.5})
    assert main(["identify", str(tmp_path), "--method", "perturbation", "--test", "exact-*"]) == 0
    header, runs = read_results(tmp_path / "results" / "perturbation.json")
    assert header["structure"] == "ch4-cantilever-case1-postulated"
    assert runs[0].status == "converged"
    assert runs[0].values() == pytest.approx(actual.values[actual.kind_mask()], rel=1e-4)


@pytest.mark.parametrize("argv, message", [
    (["--method", "rayleigh", "--group", "nope"], "no test group nope"),
    (["--method", "rayleigh", "--test", "nope*"], "no trace matches"),
    (["--method", "least-squares"], "needs a finite-element model"),
    (["--method", "least-squares", "--model", "ch5-simply-supported-beam-fe"], "not a free DOF of model ch5-simply-supported-beam-fe"),
    (["--method", "least-squares", "--model", "no-such-model"], "unknown structure"),
])
def test_user_errors_exit_2(beam_campaign, capsys, argv, message):
    assert main(["identify", str(beam_campaign), *argv]) == 2
    assert message in capsys.readouterr().err


def test_missing_folder(tmp_path, capsys):
    assert main(["identify", str(tmp_path / "absent"), "--method", "rayleigh"]) == 2
    assert "no such campaign folder" in capsys.readouterr().err


def test_shear_frame_from_a_toml_model(tmp_path):
    """Storey masses, springs and dashpots (9 unknowns) noise-free, and its
    natural frequencies from a free response."""
    frame = load_model(SHEAR_FRAME)
    dt = 0.001
    t = np.arange(2001) * dt
    force = np.zeros((t.size, frame.n_dof))
    force[:, frame.dof_index(3, "x")] = 1000.0 * (np.cos(15 * t) + np.cos(40 * t))
    sensors = [(q, n, d) for q in ("displacement", "velocity", "acceleration") for n, d in frame.dofs]
    trace = read_trace(write_trace(tmp_path / "forced.h5", frame, respond(frame, force, dt), dt,
                                   sensors + [("force", 3, "x")]))
    result = least_squares.identify([trace], frame, samples=8, interval=0.1)
    assert {p.kind for p in result.parameters} == {"mass", "damping", "stiffness"}
    assert np.max(np.abs(result.values() / frame.values[frame.kind_mask()] - 1)) < 1e-6
    x0 = np.zeros(2 * frame.n_dof)
    x0[frame.n_dof + frame.dof_index(3, "x")] = 1.0
    free = read_trace(write_trace(tmp_path / "free.h5", frame, respond(frame, np.zeros((10001, 3)), dt, x0), dt,
                                  sensors[:6]))
    modes = rayleigh.identify([free], frame)
    assert np.array(modes.omega) == pytest.approx(frame.modes().omega, rel=0.005)
