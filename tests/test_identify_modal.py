"""The modal method (SSI-cov with automatic order selection and jackknife
errors) on synthetic traces written in the trace format from the models'
exact simulation: the chapter 5 beam (closed-form frequencies), a damped
variant (its modal damping ratios), the membrane's close pair; and its
bad-input errors."""
from __future__ import annotations

import dataclasses

import h5py
import numpy as np
import pytest

from identify_synth import respond, write_trace
from modal_synth import modal_response
from structbench.cli import main
from structbench.identifier.errors import IdentificationError
from structbench.identifier.modal import identify
from structbench.identifier.io.traces import read_trace
from structbench.models import load_model

BEAM_EXACT = (np.arange(1, 16) * np.pi / 10.0) ** 2  # omega_r = (r pi / L)^2, EI = m = 1, L = 10 m
ZETA = np.array([0.02, 0.015, 0.01, 0.008, 0.01, 0.012, 0.015, 0.018, 0.02, 0.025,
                 0.03, 0.035, 0.04, 0.045, 0.05])  # campaigns/ch5-damped.toml
MEMBRANE_LAMBDA = np.array([1.1912, 1.1915, 2.7641, 5.8445])  # Table 5.2, omega^2 of the four lowest flexible


def pair(omega: list[float], exact: np.ndarray) -> np.ndarray:
    """Identified frequency nearest each exact one (rad/s)."""
    w = np.asarray(omega)
    return np.array([w[np.argmin(np.abs(w - e))] for e in exact])


def beam_trace(folder, model, duration, dt, noise=0.0, seed=0, quantity="displacement", force=None,
               impulse=1.0, name="impulse"):
    """A trace file of the beam's exact response (modal_synth, checked against
    ``StateSpace.simulate`` below) to an impulse and/or a force at point 1."""
    n = round(duration / dt) + 1
    response = modal_response(model, dt, n, 1, impulse=impulse, force=force)
    response["force"] = np.zeros((n, model.n_dof))
    sensors = [(quantity, i + 1, "w") for i in range(model.n_dof)]
    return read_trace(write_trace(folder / f"{name}-{seed}.h5", model, response, dt, sensors,
                                  noise={quantity: noise}, seed=seed, test=name,
                                  excitation_attrs={"kind": "impulse"}))


def test_fast_modal_response_is_the_exact_simulation(beam):
    dt, n = 0.05, 300
    force = np.random.default_rng(0).standard_normal(n)
    fast = modal_response(dataclasses.replace(beam, zeta=ZETA), dt, n, 1, impulse=1.0, force=force)
    forces = np.zeros((n, beam.n_dof))
    forces[:, 0] = force
    exact = respond(dataclasses.replace(beam, zeta=ZETA), forces, dt,
                    np.concatenate([np.zeros(beam.n_modes), beam.shapes[0]]))
    for quantity in ("displacement", "velocity", "acceleration"):
        assert fast[quantity] == pytest.approx(exact[quantity], abs=1e-12 * np.abs(exact[quantity]).max())


@pytest.fixture(scope="module")
def beam():
    return load_model("ch5-simply-supported-beam")


@pytest.fixture(scope="module")
def damped(beam):
    return dataclasses.replace(beam, zeta=ZETA)


def test_noise_free_beam_every_visible_mode_exact(beam, tmp_path):
    result = identify([beam_trace(tmp_path, beam, 100.0, 0.01)], beam)
    visible = np.r_[0:10, 11:15]  # mode 11's shape sin(11 pi r / 11) vanishes at every sensor
    assert len(result.omega) == 14
    assert np.array(result.omega) == pytest.approx(BEAM_EXACT[visible], rel=1e-7)
    assert np.abs(result.damping).max() < 1e-8
    exact = beam.shapes[:, visible]
    shapes = np.array(result.mode_shapes).T
    mac = (np.sum(shapes * exact, 0) ** 2 / np.sum(shapes**2, 0) / np.sum(exact**2, 0))
    assert mac.min() > 0.99999
    assert np.array(result.mpc).min() > 0.9999
    assert set(result.details["stabilisation"]["order"]) <= set(range(2, 81, 2))


def test_noisy_beam_modes_1_to_10_within_003_percent(beam, tmp_path):
    """2 % noise on every displacement sensor, two seeds: the dissertation's
    aliased modes 7-10 come out right (benchmarks/modal_accuracy.py: 20 seeds)."""
    errors = []
    for seed in (1, 2):
        result = identify([beam_trace(tmp_path, beam, 100.0, 0.01, noise=0.02, seed=seed)], beam)
        errors.append(100 * (pair(result.omega, BEAM_EXACT[:10]) - BEAM_EXACT[:10]) / BEAM_EXACT[:10])
        assert len(result.omega) <= 14  # no noise mode
    median = np.median(np.abs(errors), axis=0)
    assert median[2:].max() < 0.03
    assert median[:2].max() < 0.1  # modes 1-2 have 1.6 and 6 periods in the record


def test_damped_impulse_frequencies_damping_and_errors(damped, tmp_path):
    """Free decay of the damped beam (1000 s, 2 % velocity noise): the lowest
    ten modes' frequencies within 0.1 %, damping ratios within 10 %, and the
    stated standard errors of the right size (|error| < 4 std)."""
    result = identify([beam_trace(tmp_path, damped, 1000.0, 0.05, noise=0.02, seed=4, quantity="velocity")],
                      damped)
    w = np.array(result.omega)
    idx = [int(np.argmin(np.abs(w - e))) for e in BEAM_EXACT[:10]]
    assert w[idx] == pytest.approx(BEAM_EXACT[:10], rel=1e-3)
    zeta = np.array(result.damping)[idx]
    assert zeta == pytest.approx(ZETA[:10], rel=0.1)
    se_w, se_z = np.array(result.omega_std)[idx], np.array(result.damping_std)[idx]
    assert np.all(np.abs(w[idx] - BEAM_EXACT[:10]) < 4 * se_w)
    assert np.all(np.abs(zeta - ZETA[:10]) < 4 * se_z)
    assert np.all(np.isfinite(se_w) & (se_w < 0.01 * BEAM_EXACT[:10]))


def test_damped_random_output_only(damped, tmp_path):
    """Response to an unmeasured random force (1 h, 2 % noise), one realisation:
    modes 5-10 within 1 % and damping within 25 % (20 realisations:
    benchmarks/modal_accuracy.py)."""
    dt, n = 0.05, 72001
    force = np.random.default_rng(7).standard_normal(n)
    result = identify([beam_trace(tmp_path, damped, (n - 1) * dt, dt, noise=0.02, seed=5, quantity="velocity",
                                  force=force, impulse=0.0, name="random")], damped)
    w = np.array(result.omega)
    idx = [int(np.argmin(np.abs(w - e))) for e in BEAM_EXACT[4:10]]
    assert w[idx] == pytest.approx(BEAM_EXACT[4:10], rel=1e-2)
    assert np.array(result.damping)[idx] == pytest.approx(ZETA[4:10], rel=0.25)


def free_responses(dt: float) -> list[dict]:
    """Free responses of the membrane from 1 m/s at node 5 and at node 6, 100 s at ``dt``."""
    membrane = load_model("ch5-membrane")
    n = membrane.n_dof
    out = []
    for node in (5, 6):
        x0 = np.zeros(2 * n)
        x0[n + membrane.dof_index(node, "w")] = 1.0
        out.append(respond(membrane, np.zeros((round(100 / dt) + 1, n)), dt, x0))
    return out


@pytest.fixture(scope="module")
def membrane():
    return load_model("ch5-membrane")


@pytest.fixture(scope="module")
def membrane_responses():
    return free_responses(0.02)


def membrane_traces(folder, membrane, responses, noise, dt=0.02):
    """Trace files (free responses: /excitation kind ``initial``) of velocity at every node."""
    sensors = [("velocity", i, "w") for i, _ in membrane.dofs]
    return [read_trace(write_trace(folder / f"m{k}-{noise}.h5", membrane, response, dt, sensors,
                                   noise={"velocity": noise}, seed=k, test=f"node{5 + k}",
                                   excitation_attrs={"kind": "initial"}))
            for k, response in enumerate(responses)]


def macs(result, exact_shapes, exact_omega):
    """MAC of the identified mode nearest each exact one."""
    w = np.asarray(result.omega)
    shapes = np.array(result.mode_shapes).T[:, [int(np.argmin(np.abs(w - e))) for e in exact_omega]]
    return np.sum(shapes * exact_shapes, 0) ** 2 / np.sum(shapes**2, 0) / np.sum(exact_shapes**2, 0)


def test_membrane_noise_free_every_mode_exact(membrane, membrane_responses, tmp_path):
    modes = membrane.modes()
    result = identify(membrane_traces(tmp_path, membrane, membrane_responses, 0.0), membrane)
    assert pair(result.omega, modes.omega[1:6]) == pytest.approx(modes.omega[1:6], rel=1e-7)
    assert pair(result.omega, modes.omega[1:5]) ** 2 == pytest.approx(MEMBRANE_LAMBDA, rel=2e-4)


def test_membrane_noisy_single_record_reports_each_close_pair_once(membrane, membrane_responses, tmp_path):
    """One record, 2 % noise: a pair that the record moves as one shape is
    reported once, at the pair's frequency (within 0.1 %), never invented twice."""
    exact = membrane.modes().omega
    w = np.array(identify(membrane_traces(tmp_path, membrane, membrane_responses[:1], 0.02), membrane).omega)
    for low, high in ((exact[1], exact[2]), (exact[4], exact[5])):
        near = w[np.abs(w - (low + high) / 2) < 0.01 * high]
        assert near.size == 1
        assert low * (1 - 1e-3) < near[0] < high * (1 + 1e-3)


def _two_records_resolve_both_pairs(membrane, tmp_path, block_rows):
    """Both records (free responses, 100 s at 0.01 s as in the campaign), 2 %
    noise, one realisation: the pair 0.08 % apart (omega 2.4175, 2.4196) and
    the pair 0.009 % apart (1.09144, 1.09154; SSI-cov alone cannot split it,
    the free-decay fit of identifier/mode_split.py does; with the default block
    rows SSI-cov drops it and the fit finds it in its residual) come out as two
    modes each within 0.01 % with MAC >= 0.99 (20 seeds: benchmarks/modal_accuracy.py)."""
    modes = membrane.modes()
    result = identify(membrane_traces(tmp_path, membrane, free_responses(0.01), 0.02, dt=0.01), membrane,
                      block_rows=block_rows)
    for close in (slice(1, 3), slice(4, 6)):
        w = pair(result.omega, modes.omega[close])
        assert w[0] != w[1]
        assert w == pytest.approx(modes.omega[close], rel=1e-4)
        assert macs(result, modes.shapes[:, close], modes.omega[close]).min() >= 0.99
    assert sum(result.details["refined"]) >= 2


def test_membrane_noisy_two_records_resolve_both_pairs_with_200_block_rows(membrane, tmp_path):
    _two_records_resolve_both_pairs(membrane, tmp_path, 200)


def test_membrane_noisy_two_records_resolve_both_pairs_default_rows(membrane, tmp_path):
    _two_records_resolve_both_pairs(membrane, tmp_path, None)


def test_bad_input_is_named(beam, tmp_path):
    trace = beam_trace(tmp_path, beam, 100.0, 0.01)
    short = beam_trace(tmp_path, beam, 20.0, 0.01, name="short")
    with pytest.raises(IdentificationError, match="too few"):
        identify([short], beam, block_rows=200)
    none = dataclasses.replace(trace, channels={})
    with pytest.raises(IdentificationError, match="at least 1 motion sensor"):
        identify([none], beam)
    data = trace.channels["displacement_3_w"].data.copy()
    data[50] = np.nan
    bad = dataclasses.replace(trace, channels=trace.channels | {
        "displacement_3_w": dataclasses.replace(trace.channels["displacement_3_w"], data=data)})
    with pytest.raises(IdentificationError, match="displacement_3_w") as err:
        identify([bad], beam)
    assert err.value.field == "displacement_3_w"
    flat = dataclasses.replace(trace, channels={k: dataclasses.replace(c, data=np.full_like(c.data, 0.25))
                                                for k, c in trace.channels.items()})
    with pytest.raises(IdentificationError, match="every displacement channel is constant"):
        identify([flat], beam)


def test_cli_one_line_and_exit_2(beam, tmp_path, capsys):
    folder = tmp_path / "campaign"
    x0 = np.concatenate([np.zeros(beam.n_modes), beam.shapes[0]])
    response = respond(beam, np.zeros((1001, beam.n_dof)), 0.01, x0)
    write_trace(folder / "traces" / "impulse.h5", beam, response, 0.01,
                [("displacement", i + 1, "w") for i in range(beam.n_dof)], test="impulse")
    assert main(["identify", str(folder), "--method", "modal", "--block-rows", "60"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "too few" in err[0]
    assert main(["identify", str(folder), "--method", "modal", "--block-rows", "20", "--json"]) == 0
    out = capsys.readouterr().out
    assert '"damping_std"' in out and (folder / "results" / "modal-stabilisation-00.png").is_file()
    assert main(["identify", str(folder), "--method", "modal", "--block-rows", "20", "--uncertainty", "off",
                 "--json"]) == 0
    assert '"uncertainty": "off"' in capsys.readouterr().out


def test_uncertainty_off_same_modes_without_errors(damped, tmp_path):
    """``uncertainty="off"`` skips only the jackknife: on the damped beam's
    noisy impulse response the modes it reports are those of the default
    run (whose replicates find every one again), bit for bit, with NaN
    errors; an unknown value is named."""
    trace = beam_trace(tmp_path, damped, 200.0, 0.05, noise=0.02, seed=3, quantity="velocity")
    full = identify([trace], damped)
    quick = identify([trace], damped, uncertainty="off")
    assert quick.omega == full.omega and quick.damping == full.damping
    assert quick.mode_shapes == full.mode_shapes
    assert np.isnan(quick.omega_std).all() and np.isnan(quick.damping_std).all()
    assert np.isfinite(full.omega_std).sum() >= 8
    assert quick.details["uncertainty"] == "off"
    with pytest.raises(IdentificationError, match="unknown uncertainty 'none'") as err:
        identify([trace], damped, uncertainty="none")
    assert err.value.field == "uncertainty"



def test_cli_prints_a_clipped_channel_left_out(damped, tmp_path, capsys):
    """A free decay of the damped beam (200 s, 2 % velocity noise) whose third sensor clipped at half its
    peak: ``identify`` names it in one warning (the method's ``details.warnings``) and finds the lowest
    five modes from the other channels within 0.5 %."""
    trace = beam_trace(tmp_path, damped, 200.0, 0.05, noise=0.02, seed=4, quantity="velocity")
    folder = tmp_path / "campaign" / "traces"
    folder.mkdir(parents=True)
    with h5py.File(trace.path) as src, h5py.File(folder / "impulse.h5", "w") as dst:
        for key in src:
            src.copy(src[key], dst, key)
        dst.attrs.update(src.attrs)
        data = dst["channels/velocity_3_w"]
        data[...] = np.clip(data[...], -0.5 * np.abs(data[...]).max(), 0.5 * np.abs(data[...]).max())
    assert main(["identify", str(folder.parent), "--method", "modal"]) == 0
    out = capsys.readouterr().out.splitlines()
    warned = [line for line in out if line.startswith("WARNING")]
    assert len(warned) == 1 and "channel velocity_3_w is clipped" in warned[0]
    w = np.array([float(line.split("omega =")[1].split()[0]) for line in out if line.lstrip().startswith("mode ")])
    assert pair(w, BEAM_EXACT[:5]) == pytest.approx(BEAM_EXACT[:5], rel=5e-3)
