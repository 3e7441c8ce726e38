"""Harmonics in operational records (issue 25.5): the modal method lists
periodic components apart from the modes (band kurtosis and near-zero
damping, identifier/modal/harmonics.py), the campaign's ``disturbance``
excitation adds them (bench/harness/disturbance.py) and ``score`` counts
them (bench/evaluation/modal_scores.py)."""
from __future__ import annotations


import numpy as np
import pytest

from modal_harmonics import frf_velocity, trace, velocity
from modal_synth import band_force
from structbench.evaluation.modal_scores import harmonic_scores, modal_scores
from structbench.harness.campaign import CampaignError, load_campaign
from structbench.harness.disturbance import Disturbance, truth_table
from structbench.harness.excitation import RandomForce, forces
from structbench.harness.truth import truth
from structbench.identifier.modal import identify
from structbench.identifier.modal.harmonics import CONC, RISE, _pole_line, fit, kurtosis

OMEGA = np.array([10.0, 25.0, 40.0])  # rad/s
ZETA = np.array([0.02, 0.015, 0.03])
SHAPES = np.array([[0.5, 1.0, 0.8], [1.0, 0.3, -0.9], [0.7, -0.9, 0.5]])  # (sensors, modes)
DT, N = 0.02, 60_001  # 1200 s
HARMONICS = ((15.0, 20.0), (30.0, 5.0), (45.0, 40.0))  # (rad/s, N): between the modes and above them


def records(seed: int, disturbed: bool, zeta: np.ndarray = ZETA, n: int = N,
            harmonics: tuple = HARMONICS) -> np.ndarray:
    """Velocities (3, n) of the three-mode system under a 10 N RMS random force
    at sensor 1 (plus the harmonic forces there), 2 % sensor noise."""
    rng = np.random.default_rng(seed)
    f = band_force(n, DT, (0.0, np.pi / DT), 10.0, seed)
    t = np.arange(n) * DT
    if disturbed:
        f = f + sum(a * np.cos(w * t + p) for (w, a), p in zip(harmonics, rng.uniform(0, 2 * np.pi, len(harmonics))))
    y = velocity(OMEGA, zeta, SHAPES, np.outer(SHAPES[0], f), DT)
    return y + 0.02 * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(y.shape)


def test_band_kurtosis_is_1_5_for_a_sinusoid_and_3_for_a_random_response():
    t = np.arange(N) * DT
    rng = np.random.default_rng(3)
    sine = np.cos(15.0 * t + 0.3)[None, :] + 0.01 * rng.standard_normal((1, N))
    kappa, used = kurtosis(sine, 15.0, DT, 256, fit(sine, 15.0, t), np.ones(1))
    assert used == 256 and kappa == pytest.approx(1.5, abs=0.02)
    y = records(4, disturbed=False)
    randoms = [kurtosis(y, w, DT, 256, fit(y, w, t), np.mean(y**2, axis=1))[0] for w in OMEGA]
    assert np.all(np.abs(np.array(randoms) - 3.0) < 0.5), randoms


@pytest.fixture(scope="module")
def results():
    return {label: identify([trace(records(7, label == "disturbed"), DT, label)]).to_dict()
            for label in ("clean", "disturbed")}


def test_harmonics_are_listed_with_frequency_amplitude_and_test_and_never_as_modes(results):
    run = results["disturbed"]
    listed = run["details"]["harmonics"]
    assert [round(h["omega"], 3) for h in listed] == [15.0, 30.0, 45.0]
    for h, (w, a) in zip(listed, HARMONICS):
        assert h["omega"] == pytest.approx(w, rel=1e-5)
        assert h["frequency_hz"] == pytest.approx(w / (2 * np.pi), rel=1e-5)
        assert h["test"] in ("kurtosis", "kurtosis+damping") and h["kurtosis"] < 2.6 and h["on_mode"] is None
        steady = np.abs(frf_velocity(OMEGA, ZETA, SHAPES, SHAPES[0], w)) * a  # m/s per sensor
        assert np.array(h["amplitude"]) == pytest.approx(steady, abs=0.03 * steady.max())
    omega = np.array(run["omega"])
    assert omega.size == 3 and np.all(np.abs(omega / OMEGA - 1) < 0.005)
    assert results["clean"]["details"]["harmonics"] == []


def test_modes_are_as_accurate_with_the_harmonics_as_without(results):
    clean, disturbed = results["clean"], results["disturbed"]
    for key, std in (("omega", "omega_std"), ("damping", "damping_std")):
        moved = np.abs(np.subtract(disturbed[key], clean[key]))
        assert np.all(moved < 2 * np.array(clean[std])), (key, moved, clean[std])
    assert np.abs(np.array(disturbed["damping"]) / ZETA - 1).max() < 0.25


def test_a_lightly_damped_mode_of_a_short_random_record_stays_a_mode():
    """Mode 2 at zeta 0.1 %: 15 decay times in a 600 s record. Its band
    kurtosis over 1024 blocks looks like a sinusoid's (the blocks share a
    few envelope values) and its damping was under the old fixed 0.3 %
    near-zero threshold: it was subtracted and listed as a harmonic. Its
    damping is resolved by the record (15 decay times, not under 2) and a
    mode's peak explains its line: it stays a mode and no harmonic is listed."""
    zeta = np.array([0.02, 0.001, 0.03])
    run = identify([trace(records(2, False, zeta=zeta, n=30_000), DT, "light")], uncertainty="off").to_dict()
    omega = np.array(run["omega"])
    assert np.min(np.abs(omega - 25.0)) < 0.05, run["omega"]
    assert run["details"]["harmonics"] == []


def test_a_weak_harmonic_in_a_modes_band_is_never_a_mode():
    """A 1 N harmonic at 25.25 rad/s, inside mode 2's half-power band
    (25 +- 0.375 rad/s), too weak for the line and kurtosis tests: SSI gives
    it a pole of damping 0 (to 1e-5), which the old fixed threshold let
    through only with a low kurtosis. A pole that does not decay over the
    record (under 2 decay times) is listed as a harmonic (``damping``)."""
    y = records(1, True, harmonics=((25.25, 1.0),))
    run = identify([trace(y, DT, "weak")], uncertainty="off").to_dict()
    omega = np.array(run["omega"])
    assert not np.any(np.abs(omega - 25.25) < 0.05), run["omega"]
    assert np.min(np.abs(omega - 25.0)) < 0.1
    listed = [h for h in run["details"]["harmonics"] if abs(h["omega"] - 25.25) < 0.01]
    assert len(listed) == 1 and listed[0]["test"] in ("damping", "kurtosis+damping", "line")


def test_a_harmonic_found_through_its_poles_is_subtracted_and_takes_no_model_order():
    """The weak harmonic above is found only through its SSI poles, which took
    model orders from the modes: the record is identified again with it
    subtracted, so that the final stabilisation diagram holds no stable pole
    at it, and the harmonic is still listed with its amplitude."""
    y = records(1, True, harmonics=((25.25, 1.0),))
    run = identify([trace(y, DT, "weak")], uncertainty="off").to_dict()
    diagram = run["details"]["stabilisation"]
    at = (np.abs(np.array(diagram["omega"]) - 25.25) < 0.02) & np.array(diagram["stable"])
    assert not at.any(), np.array(diagram["zeta"])[at]
    listed = [h for h in run["details"]["harmonics"] if abs(h["omega"] - 25.25) < 0.01]
    steady = np.abs(frf_velocity(OMEGA, ZETA, SHAPES, SHAPES[0], 25.25))  # m/s per N at each sensor
    assert len(listed) == 1 and np.array(listed[0]["amplitude"]) == pytest.approx(steady, rel=0.1)


def test_a_pole_fitted_to_a_line_is_told_from_a_mode_by_its_peak():
    """The ``line`` test (_pole_line) on a periodogram of exponential scatter
    (a random response's): a broad mode (half-width 80 lines) with a line 60
    lines off its centre, and a weak line next to it that SSI gave a pole
    of half-width 9 lines 8 lines away. The pole fitted to the line: its
    line stands far above a 9-line mode's peak and its band does not rise
    over its surroundings; the broad mode's band rises (a mode with a
    harmonic on it stays a mode); a lightly damped mode alone (half-width 9
    lines, no line) is a mode's peak."""
    rng = np.random.default_rng(0)
    k = np.arange(20_000, dtype=float)
    lorentz = lambda j, h: 1.0 / (1.0 + ((k - j) / h)**2)
    smooth = 1.0 + 400.0 * lorentz(10_000, 80.0) + 50.0 * lorentz(12_000, 9.0)
    P = smooth * rng.exponential(size=k.size)
    P[10_060] += 400.0 * 40  # a harmonic on the broad mode
    P[5_008] += 2_000.0  # a weak line on a flat background
    bin_w = 0.01
    _, excess, rise = _pole_line(P, 5_000 * bin_w, 9 * bin_w / (5_000 * bin_w), bin_w)
    assert excess >= CONC and rise < RISE
    _, excess, rise = _pole_line(P, 10_000 * bin_w, 80 * bin_w / (10_000 * bin_w), bin_w)
    assert rise >= RISE
    _, excess, rise = _pole_line(P, 12_000 * bin_w, 9 * bin_w / (12_000 * bin_w), bin_w)
    assert excess < CONC


def test_score_counts_harmonics_listed_missed_and_reported_as_modes():
    truth = {"omega": [10.0, 25.0], "harmonics": {"run": [{"omega": 15.0}, {"omega": 30.0}, {"omega": 50.0}]}}
    run = {"omega": [10.01, 25.02, 50.1], "tests": ["run"], "details": {
        "record_s": 1000.0, "harmonics": [{"omega": 15.001}, {"omega": 25.0}]}}
    scores = modal_scores(run, truth)["harmonics"]
    assert scores == {"harmonics": 3, "listed": 1, "missed": 2, "listed_each": [True, False, False],
                      "as_modes": 1, "listed_spurious": 1, "modes_as_harmonics": 1}
    assert harmonic_scores(run, [], truth)["harmonics"] == 0


CAMPAIGN = """\
name = "hum"
structure = "ch5-simply-supported-beam"
seed = 5
[[tests]]
name = "ambient"
dt = 0.1
duration = 100.0
sensors = [{nodes = "all", quantities = ["velocity"]}]
[[tests.excitation]]
kind = "random"
node = 1
dir = "w"
rms = 1.0
band = [0.0, 30.0]
[[tests.excitation]]
kind = "disturbance"
node = 4
dir = "w"
base = 2.5
multiples = [1, 3, 5]
amplitudes = [0.5, 0.2, 0.1]
"""


def test_disturbance_excitation_sums_seeded_sinusoids_and_enters_the_truth(tmp_path):
    path = tmp_path / "hum.toml"
    path.write_text(CAMPAIGN)
    campaign = load_campaign(path)
    test = campaign.tests[0]
    random, hum = test.excitation
    assert isinstance(random, RandomForce) and isinstance(hum, Disturbance)
    assert hum.omegas == (2.5, 7.5, 12.5) and hum.amplitudes == (0.5, 0.2, 0.1)
    t = np.arange(1001) * 0.1
    phases = np.random.default_rng(hum.seed).uniform(0, 2 * np.pi, 3)
    expected = sum(a * np.cos(w * t + p) for w, a, p in zip(hum.omegas, hum.amplitudes, phases))
    assert hum.force(t, 0.1) == pytest.approx(expected, abs=1e-12)
    both = forces(test.excitation, [(1, "w"), (4, "w")], t, 0.1)
    assert both[:, 1] == pytest.approx(expected, abs=1e-12)
    assert np.sqrt(np.mean(both[:, 0]**2)) == pytest.approx(1.0, rel=1e-9)
    table = truth_table([test])["ambient"]
    assert [row["omega"] for row in table] == [2.5, 7.5, 12.5] and table[1]["amplitude"] == 0.2
    assert table[2]["frequency_hz"] == pytest.approx(12.5 / (2 * np.pi)) and table[0]["node"] == 4
    assert truth(campaign)["harmonics"] == {"ambient": table}
    bad = CAMPAIGN.replace("base = 2.5", "base = 2.5\nomegas = [1.0]")
    path.write_text(bad)
    with pytest.raises(CampaignError, match="either omegas"):
        load_campaign(path)
    path.write_text(CAMPAIGN.replace("multiples = [1, 3, 5]", "multiples = [1, 3, 50]"))
    with pytest.raises(CampaignError, match="pi/dt"):
        load_campaign(path)
