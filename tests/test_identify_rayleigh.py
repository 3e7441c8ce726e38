"""Chapter 5 pseudo-Rayleigh quotient on synthetic free responses."""
from __future__ import annotations

import numpy as np
import pytest

from structbench.identifier.errors import IdentificationError
from structbench.identifier.rayleigh import cosine_functions, identify
from structbench.identifier.io.traces import read_trace
from identify_synth import respond, write_trace
from structbench.models import load_model

MEMBRANE_TABLE = np.array([0.0, 1.1912, 1.1915, 2.7641, 5.8445])  # Table 5.2, omega^2


@pytest.fixture(scope="module")
def beam():
    return load_model("ch5-simply-supported-beam")


@pytest.fixture(scope="module")
def membrane():
    return load_model("ch5-membrane")


def beam_trace(beam, folder, duration: float, dt: float, quantities=("displacement", "velocity")):
    """Free response after an impulse of 1 N s at x = L/11 (point 1), 15 modes."""
    x0 = np.concatenate([np.zeros(beam.n_modes), beam.shapes[0]])
    response = respond(beam, np.zeros((round(duration / dt) + 1, beam.n_dof)), dt, x0)
    sensors = [(q, i + 1, "w") for q in quantities for i in range(beam.n_dof)]
    return read_trace(write_trace(folder / f"beam-{duration:g}.h5", beam, response, dt, sensors,
                                  excitation_attrs={"kind": "impulse"}))


def membrane_trace(membrane, folder, node: int, duration: float = 100.0, dt: float = 0.05):
    """Free response from 1 m/s initial velocity at ``node``; velocity and acceleration sensors."""
    n = membrane.n_dof
    x0 = np.zeros(2 * n)
    x0[n + membrane.dof_index(node, "w")] = 1.0
    response = respond(membrane, np.zeros((round(duration / dt) + 1, n)), dt, x0)
    sensors = [(q, i, "w") for q in ("velocity", "acceleration") for i, _ in membrane.dofs]
    return read_trace(write_trace(folder / f"membrane-{node}-{duration:g}.h5", membrane, response, dt,
                                  sensors, test=f"impulse-{node}", excitation_attrs={"kind": "initial"}))


@pytest.fixture(scope="module")
def beam_100(beam, tmp_path_factory):
    return beam_trace(beam, tmp_path_factory.mktemp("beam"), 100.0, 0.01)


def errors_pct(omega, exact):
    return 100 * (np.asarray(omega[:len(exact)]) - exact) / exact


def test_beam_modes_2_to_6_and_the_aliased_7_to_10(beam, beam_100):
    result = identify([beam_100], beam)
    err = errors_pct(result.omega, beam.omega[:10])
    assert result.details["variant"] == "displacement" and result.details["window"] == "hann"
    assert np.all(np.abs(err[1:6]) < 0.6)
    # 15 modes on 10 sensors at iL/11: mode 22 - r looks like mode r, the quotient blends each pair
    assert result.omega[6:10] == pytest.approx([6.683, 8.492, 10.195, 11.464], abs=2e-3)
    truth = beam.shapes[:, :6]
    shapes = np.array(result.mode_shapes[:6]).T
    mac = (np.sum(truth * shapes, axis=0) ** 2) / (np.sum(truth**2, axis=0) * np.sum(shapes**2, axis=0))
    assert np.all(mac > 0.999)


def test_beam_mode_1_plain_record_versus_taper(beam, beam_100):
    """A plain 100 s record holds 1.6 periods of mode 1: +3.9 %. The tapered
    inner product gives the dissertation's -0.4 %."""
    plain = errors_pct(identify([beam_100], beam, window="rectangular").omega, beam.omega[:10])
    tapered = errors_pct(identify([beam_100], beam, window="hann").omega, beam.omega[:10])
    assert plain[0] == pytest.approx(3.9, abs=0.1)
    assert np.all(np.abs(plain[1:6]) < 0.6)
    assert tapered[0] == pytest.approx(-0.44, abs=0.05)


def test_beam_mode_1_long_plain_record(beam, tmp_path):
    """A plain record of 1,200 s also gives -0.4 % (and mode 2 -0.1 %), as printed."""
    long = beam_trace(beam, tmp_path, 1200.0, 0.05)
    err = errors_pct(identify([long], beam, window="rectangular").omega, beam.omega[:10])
    assert err[0] == pytest.approx(-0.40, abs=0.05)
    assert err[1] == pytest.approx(-0.10, abs=0.03)


@pytest.fixture(scope="module")
def membrane_traces(membrane, tmp_path_factory):
    folder = tmp_path_factory.mktemp("membrane")
    return {node: membrane_trace(membrane, folder, node) for node in (5, 6)}


@pytest.mark.parametrize("admissible", [None, "cosine"])
def test_membrane_two_impulse_tests_give_the_five_lowest(membrane, membrane_traces, admissible):
    result = identify(list(membrane_traces.values()), membrane, admissible=admissible)
    lam = np.array(result.eigenvalues[:5])
    assert result.details["variant"] == "velocity"
    assert lam[0] == 0.0
    assert np.all(np.abs(lam[1:] / MEMBRANE_TABLE[1:] - 1) < 0.01)


def test_membrane_single_impulse_cannot_split_the_close_pair(membrane, membrane_traces):
    """One impulse excites the pair 1.1912/1.1915 in phase (delta omega T = 0.014):
    the pair comes out split by about +-1.7 %, the others within 1 %."""
    lam = np.array(identify([membrane_traces[5]], membrane, admissible="cosine").eigenvalues[:5])
    err = np.abs(lam[1:] / MEMBRANE_TABLE[1:] - 1)
    assert lam[0] == 0.0 and np.all(err[2:] < 0.01)
    assert np.all((err[:2] > 0.01) & (err[:2] < 0.02))


def test_membrane_mode_shapes(membrane, membrane_traces):
    result = identify(list(membrane_traces.values()), membrane, admissible="cosine")
    exact = membrane.modes(5).shapes[:, 3]
    shape = np.array(result.mode_shapes[3])
    assert (exact @ shape) ** 2 / (exact @ exact * shape @ shape) > 0.999


def test_fewer_admissible_functions_is_a_ritz_reduction(membrane, membrane_traces):
    result = identify(list(membrane_traces.values()), membrane, admissible="cosine", functions=6)
    assert result.details["functions"] == 6 and len(result.omega) <= 6
    assert result.eigenvalues[1] == pytest.approx(1.1912, rel=0.01)


def test_cosine_functions_on_the_grid():
    xy = np.array([[x, y, 0.0] for y in range(4) for x in range(4)], dtype=float)
    chi = cosine_functions(xy, 4)
    assert np.allclose(chi[0], 1.0)
    assert np.allclose(chi[1], np.cos(np.pi * xy[:, 1] / 3)) and np.allclose(chi[2], np.cos(np.pi * xy[:, 0] / 3))


def test_missing_partner_channel_is_named(beam, tmp_path):
    x0 = np.concatenate([np.zeros(beam.n_modes), beam.shapes[0]])
    response = respond(beam, np.zeros((501, beam.n_dof)), 0.1, x0)
    sensors = [(q, i + 1, "w") for q in ("displacement", "velocity") for i in range(beam.n_dof)]
    trace = read_trace(write_trace(tmp_path / "gap.h5", beam, response, 0.1, sensors, drop=("velocity_3_w",)))
    with pytest.raises(IdentificationError, match="velocity_3_w"):
        identify([trace], beam)


def test_admissible_functions_need_every_dof(membrane, membrane_traces, tmp_path):
    n = membrane.n_dof
    x0 = np.zeros(2 * n)
    x0[n + 4] = 1.0
    response = respond(membrane, np.zeros((201, n)), 0.05, x0)
    sensors = [(q, i, "w") for q in ("velocity", "acceleration") for i, _ in membrane.dofs if i != 16]
    trace = read_trace(write_trace(tmp_path / "m.h5", membrane, response, 0.05, sensors))
    with pytest.raises(IdentificationError, match=r"missing \(16, w\)"):
        identify([trace], membrane, admissible="cosine")
    with pytest.raises(IdentificationError, match="finite-element model"):
        identify([trace], load_model("ch5-simply-supported-beam"), admissible="cosine")
