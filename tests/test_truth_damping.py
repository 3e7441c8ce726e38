"""The damping ratios of ``truth.json`` (issue 21, point 2): each mode's zeta
from its own pole pair, NaN for rigid-body and overdamped modes (never a
neighbour's value), checked against references computed here: the Rayleigh
closed form ``zeta_r = alpha / (2 omega_r) + beta omega_r / 2`` (omega_r from
``scipy.linalg.eigh(K, M)``) and, for non-proportional damping, the poles of
``[[0, I], [-M^-1 K, -M^-1 C]]`` from ``scipy.linalg.eig``."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as la

from structbench.evaluation.gates import evaluate
from structbench.evaluation.modal_scores import modal_scores, modal_summary
from structbench.evaluation.truth_checks import read_truth
from structbench.harness.campaign import load_campaign
from structbench.harness.folder import write_json
from structbench.harness.truth import true_damping_ratios, truth
from structbench.models import Structure
from structbench.models.library import CH4, beam

CAMPAIGNS = Path(__file__).resolve().parent.parent / "campaigns"


def matrices(model: Structure) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return model.mass().toarray(), model.damping().toarray(), model.stiffness().toarray()


def undamped_omega(model: Structure) -> np.ndarray:
    """omega_r (rad/s), ascending, of ``K phi = omega^2 M phi``."""
    M, _, K = matrices(model)
    return np.sqrt(np.clip(la.eigh(K, M, eigvals_only=True), 0.0, None))


def rayleigh_zeta(omega: np.ndarray, alpha: float, beta: float) -> np.ndarray:
    """Closed form, NaN where overdamped (zeta > 1)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = alpha / (2 * omega) + beta * omega / 2
    return np.where(zeta > 1, np.nan, zeta)


def cantilever(alpha: float = 0.0, beta: float = 0.0) -> Structure:
    """Chapter 4 cantilever (case 1, 6 elements, 12 DOF, omega 0.098 to 61.8 rad/s) with Rayleigh damping."""
    m, k = CH4["case1"]["actual"]
    return dataclasses.replace(beam("c", m, k, 6.0, supports={1: "clamped"}), rayleigh=(alpha, beta))


def test_overdamped_top_mode_of_a_four_element_cantilever_is_nan_not_mode_7s():
    """c = 0.001 k on every element: C = 0.001 K, zeta_r = 0.0005 omega_r; mode 8 (3262.5 rad/s) has
    zeta 1.63 and is overdamped. The old truth wrote mode 7's 0.9942 for it."""
    model = beam("cantilever-4", [1.0] * 4, [3000.0] * 4, 4.0, supports={1: "clamped"}, damping=[3.0] * 4)
    omega = undamped_omega(model)
    zeta = true_damping_ratios(model, model.modes())
    assert omega[6:] == pytest.approx([1988.4, 3262.5], abs=0.05)
    assert zeta[:7] == pytest.approx(0.0005 * omega[:7], rel=1e-9)
    assert zeta[6] == pytest.approx(0.9942, abs=1e-4)
    assert np.isnan(zeta[7])


RAYLEIGH = [(0.05, 0.01),  # light: every mode underdamped
            (2.0, 0.0),  # mass-proportional: modes 1 and 2 overdamped, the rest not
            (0.0, 0.2),  # stiffness-proportional: modes 7 to 12 overdamped
            (1.0, 0.05),  # both ends overdamped (modes 1, 11, 12), the middle not
            (0.0, 2 * 0.999 / 7.885)]  # mode 6 at zeta 0.999 (nearly critical), 7 to 12 overdamped


@pytest.mark.parametrize("alpha, beta", RAYLEIGH)
def test_rayleigh_damping_matches_the_closed_form_across_zeta_1(alpha, beta):
    model = cantilever(alpha, beta)
    omega = undamped_omega(model)
    expected = rayleigh_zeta(omega, alpha, beta)
    zeta = true_damping_ratios(model, model.modes())
    assert np.array_equal(np.isnan(zeta), np.isnan(expected))
    ok = ~np.isnan(expected)
    assert zeta[ok] == pytest.approx(expected[ok], rel=1e-7)


def test_the_sweep_crosses_zeta_1_where_stated():
    omega = undamped_omega(cantilever())
    overdamped = [np.flatnonzero(np.isnan(rayleigh_zeta(omega, a, b))) + 1 for a, b in RAYLEIGH]
    assert [list(o) for o in overdamped] == [[], [1, 2], list(range(7, 13)), [1, 11, 12], list(range(7, 13))]
    assert rayleigh_zeta(omega, *RAYLEIGH[-1])[5] == pytest.approx(0.999, rel=1e-3)


@pytest.mark.parametrize("scale", [0.5, 1.0])
def test_non_proportional_damping_matches_the_state_space_poles(scale):
    """Element dampers not proportional to the element stiffnesses plus alpha M: Phi^T C Phi has
    off-diagonal terms 20 % of its diagonal. Each underdamped pole pair of the first-order matrix
    (sorted by |s|) is one finite truth zeta (in mode order); each overdamped mode (NaN) owns two
    real poles. scale 0.5: modes 10 and 11 overdamped, mode 12 not (|s| 46.1, zeta 0.666)."""
    m, k = CH4["case1"]["actual"]
    c = [scale * x for x in [0.3, 0.02, 0.5, 0.01, 0.2, 0.05]]
    model = dataclasses.replace(beam("np", m, k, 6.0, supports={1: "clamped"}, damping=c), rayleigh=(0.05, 0.0))
    M, C, K = matrices(model)
    n = M.shape[0]
    state = np.block([[np.zeros((n, n)), np.eye(n)], [-la.solve(M, K), -la.solve(M, C)]])
    s = la.eig(state, right=False)
    upper = s[s.imag > 1e-9 * np.abs(s).max()]
    upper = upper[np.argsort(np.abs(upper))]
    real = s[np.abs(s.imag) <= 1e-9 * np.abs(s).max()]
    zeta = true_damping_ratios(model, model.modes())
    finite = zeta[~np.isnan(zeta)]
    assert real.size == 2 * np.isnan(zeta).sum() and np.all(real.real < 0)
    assert finite == pytest.approx(-upper.real / np.abs(upper), rel=1e-8)
    if scale == 0.5:
        assert list(np.flatnonzero(np.isnan(zeta)) + 1) == [10, 11]
        assert zeta[11] == pytest.approx(0.6661, abs=1e-4)


def test_truth_json_holds_nan_for_overdamped_modes_and_scoring_skips_them(tmp_path):
    """ch3-damped (C = 0.05 K): modes 29 to 32 overdamped (zeta 1.17 to 1.84). truth.json is written
    with NaN there (Python's JSON ``NaN``), read back by the scorer's checks, and the damping errors
    and coverage of those modes are NaN (skipped) while their frequencies still score."""
    campaign = load_campaign(CAMPAIGNS / "ch3-damped.toml")
    data = truth(campaign)
    omega = np.asarray(data["omega"])
    expected = rayleigh_zeta(omega, 0.0, 0.05)
    expected[:2] = np.nan  # rigid-body modes
    assert list(np.flatnonzero(np.isnan(expected)) + 1) == [1, 2, 29, 30, 31, 32]
    assert np.array_equal(np.isnan(data["zeta"]), np.isnan(expected))
    assert np.asarray(data["zeta"])[2:28] == pytest.approx(expected[2:28], rel=1e-7)
    write_json(tmp_path / "truth.json", data)
    assert (tmp_path / "truth.json").read_text().count("NaN") == 6
    back = read_truth(tmp_path / "truth.json")
    assert np.array_equal(np.isnan(back["zeta"]), np.isnan(expected))
    found = np.arange(2, 32)  # an identifier reporting every elastic mode, damping 5 % high, 0.9 if overdamped
    run = {"method": "modal", "omega": list(omega[found] * 1.001), "damping_std": [0.01] * found.size,
           "damping": list(np.where(np.isnan(expected[found]), 0.9, 1.05 * expected[found])),
           "omega_std": list(omega[found] * 0.002)}
    scores = modal_scores(run, back)
    err = np.asarray(scores["damping_error_pct"])
    assert err[2:28] == pytest.approx(5.0) and np.all(np.isnan(err[28:]))
    assert np.all(np.isnan(np.asarray(scores["zeta_covered"], dtype=float)[28:]))
    assert np.asarray(scores["freq_error_pct"])[2:] == pytest.approx(0.1)
    summary = modal_summary([scores, scores])
    rows = evaluate({"damping_error_pct_max": 5.5, "modes": list(range(3, 29))}, {"modal": {"summary": summary}})
    assert rows[0]["ok"]
