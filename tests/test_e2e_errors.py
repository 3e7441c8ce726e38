"""Bad input end to end: traces from real campaign runs that cannot give an
identification end in a clear error (exit 2, message on stderr) and no
numbers: nothing on stdout, no results file."""
from __future__ import annotations

from pathlib import Path

import pytest

from structbench.cli import main
from e2e_fixtures import derive, run
from structbench.identifier import least_squares
from structbench.identifier.errors import IdentificationError
from structbench.identifier.io.traces import read_traces
from structbench.models import load_model


@pytest.fixture(scope="module")
def folders(tmp_path_factory, fmus) -> dict[str, Path]:
    """ch3 noise-free with every sensor, ch3 with transverse sensors only (no
    rotations), ch4 case 2 at 0.5 rad/s only (one tip displacement)."""
    root = tmp_path_factory.mktemp("errors")
    fmu_dir = fmus["ch3-free-free-beam"].parent  # the session's FMUs, all in one folder
    transverse = [{"nodes": "all", "dirs": ["w"], "quantities": ["acceleration", "velocity", "displacement"]},
                  {"nodes": [7], "dirs": ["w"], "quantities": ["force"]}]
    campaigns = {
        "ch3": derive("ch3", root / "ch3", {"harmonic": {"noise": None, "repetitions": None}}),
        "transverse": derive("ch3", root / "transverse", {"harmonic": {"noise": None, "repetitions": None,
                                                                       "sensors": transverse}}),
        "ch4": derive("ch4-case2", root / "ch4", {"exact": {"excitation": {"omegas": [0.5]}}}),
    }
    return {name: run(path, path.parent / "out", fmu_dir) for name, path in campaigns.items()}


@pytest.mark.parametrize("folder, argv, message", [
    ("transverse", ["--method", "least-squares"],
     "DOF (1, 'theta') has none (nor 15 more); missing channel(s) acceleration_1_theta"),
    ("transverse", ["--method", "least-squares"], "at the measured DOF: nothing to fit in the frequency domain"),
    ("ch4", ["--method", "rayleigh", "--variant", "displacement"],
     "missing channel velocity_7_w (channels: displacement_7_w)"),
    ("ch3", ["--method", "least-squares", "--model", "ch4-cantilever-case1"],
     "channel acceleration_1_theta is at (1, 'theta'), which is not a free DOF of model ch4-cantilever-case1: "
     "the model's DOF do not match the traces"),
    ("ch3", ["--method", "least-squares", "--model", "ch3-damped-beam", "--samples", "1"],
     "fewer equations (32) than unknowns (45)"),
    ("ch4", ["--method", "perturbation"], "fewer equations (1) than unknowns (12)"),
])
def test_clear_error_and_no_numbers(folders, capsys, folder, argv, message):
    assert main(["identify", str(folders[folder]), *argv]) == 2
    out, err = capsys.readouterr()
    assert err.startswith("structbench identify: error: ") and message in err
    assert out == ""
    assert not (folders[folder] / "results").exists()


def test_the_python_api_raises_identification_error(folders):
    traces = read_traces(folders["ch3"])
    with pytest.raises(IdentificationError, match=r"fewer equations \(32\) than unknowns \(45\)"):
        least_squares.identify(traces, load_model("ch3-damped-beam"), samples=1)
