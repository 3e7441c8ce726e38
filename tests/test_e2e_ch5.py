"""Chapter 5 end to end: ``campaigns/ch5-beam.toml`` (the 100 s impulse
test) and ``campaigns/ch5-membrane.toml`` run through the FMUs and the
harness, identified by ``structbench identify --method rayleigh`` and scored
against ``truth.json``."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from structbench.cli import main
from e2e_fixtures import derive, identify, run

# simply supported beam, m = 1 kg/m, EI = 1 N m^2, L = 10 m: omega_r = (r pi / L)^2
BEAM_EXACT = (np.arange(1, 11) * np.pi / 10.0) ** 2
# Table 5.1: modes 7-10 identified at (rad/s), sensors at x = r L / 11 alias mode 22 - r onto mode r
BEAM_ALIASED = [6.68, 8.49, 10.20, 11.47]
# Table 5.2, actual column (it holds omega^2, rad^2/s^2): the five lowest
MEMBRANE_LAMBDA = [0.0, 1.1912, 1.1915, 2.7641, 5.8445]


@pytest.fixture(scope="module")
def beam(tmp_path_factory, fmus) -> Path:
    root = tmp_path_factory.mktemp("ch5-beam")
    campaign = derive("ch5-beam", root, {"impulse": {}})
    return run(campaign, root / "out", fmus["ch5-simply-supported-beam"].parent)


@pytest.fixture(scope="module")
def membrane(tmp_path_factory, fmus) -> Path:
    root = tmp_path_factory.mktemp("ch5-membrane")
    campaign = derive("ch5-membrane", root, {"initial-velocity": {}, "initial-velocity-node6": {}})
    return run(campaign, root / "out", fmus["ch5-membrane"].parent)


def test_beam_modes_2_to_6_and_the_aliasing_of_7_to_10(beam):
    (result,) = identify(beam, "rayleigh", "--group", "impulse", "--tag=hann")["runs"]
    omega = np.array(result["omega"])
    assert result["omega_true"] == pytest.approx(BEAM_EXACT, rel=1e-12)
    assert np.all(np.abs(omega[1:6] / BEAM_EXACT[1:6] - 1) < 0.006)
    assert omega[6:10] == pytest.approx(BEAM_ALIASED, abs=0.05)


def test_beam_mode_1_hann_and_rectangular(beam):
    """1.6 periods of mode 1 in 100 s: within 0.6 % with the Hann taper,
    about +3.9 % with the plain time average."""
    (hann,) = identify(beam, "rayleigh", "--group", "impulse", "--tag=hann")["runs"]
    (plain,) = identify(beam, "rayleigh", "--group", "impulse", "--window", "rectangular", "--tag=plain")["runs"]
    assert abs(hann["omega"][0] / BEAM_EXACT[0] - 1) < 0.006
    assert plain["omega"][0] / BEAM_EXACT[0] - 1 == pytest.approx(0.039, abs=0.002)


def test_beam_check_gates_frequencies_and_mode_shapes(beam, capsys):
    """The campaign's gates on modes 1-6: frequencies and MAC."""
    identify(beam, "rayleigh", "--group", "impulse", "--tag=hann")
    assert main(["check", str(beam)]) == 0
    rows = [line.split()[:3] for line in capsys.readouterr().out.splitlines() if line.startswith("PASS")]
    assert ["PASS", "rayleigh-hann", "mac_min"] in rows and ["PASS", "rayleigh-hann", "freq_error_pct_max"] in rows


def test_membrane_jointly_with_the_node_6_record(membrane, capsys):
    (result,) = identify(membrane, "rayleigh", "--admissible", "cosine", "--joint", "--tag=joint")["runs"]
    assert np.array(result["omega"][:5]) ** 2 == pytest.approx(MEMBRANE_LAMBDA, rel=0.01, abs=1e-6)
    assert main(["check", str(membrane)]) == 0
    assert "PASS  rayleigh-joint " in capsys.readouterr().out


def test_membrane_single_record_leaves_the_close_pair_unresolved(membrane):
    """The node-5 record alone: 0, 2.7641 and 5.8445 within 1 %. The pair 1.1912 / 1.1915 (beat period 46,000 s)
    is excited in phase and stays so over 100 s; the quotient then returns
    1.171 and 1.212 (-1.7 %, +1.7 %), exactly what it gives for these two
    modes' exact responses alone: the method's limit, not the harness's.
    Their mean is right."""
    (result,) = identify(membrane, "rayleigh", "--group", "initial-velocity", "--admissible", "cosine",
                         "--tag=single")["runs"]
    lam = np.array(result["omega"][:5]) ** 2
    assert lam[[0, 3, 4]] == pytest.approx(np.array(MEMBRANE_LAMBDA)[[0, 3, 4]], rel=0.01, abs=1e-6)
    assert lam[1:3] == pytest.approx([1.171, 1.212], abs=0.002)
    assert lam[1:3].mean() == pytest.approx(np.mean(MEMBRANE_LAMBDA[1:3]), rel=1e-3)
