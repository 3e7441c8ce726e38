"""Scoring of modal results: modes paired with the truth's, damping errors,
coverage of the stated errors, gates; and the true damping ratios of a
damped finite-element model (closed form for stiffness-proportional damping)."""
from __future__ import annotations

import numpy as np
import pytest

from structbench.evaluation.gates import evaluate
from structbench.evaluation.modal_scores import modal_scores, modal_summary
from structbench.harness.truth import true_damping_ratios
from structbench.models import load_model

TRUTH = {"omega": [1.0, 2.0, 3.0], "zeta": [0.01, 0.02, 0.0], "sensor_dofs": [[1, "w"], [2, "w"]],
         "mode_shapes": [[1.0, 1.0, 0.0], [1.0, -1.0, 1.0]]}


def run(omega, damping, omega_std, damping_std, shapes):
    return {"method": "modal", "omega": omega, "damping": damping, "omega_std": omega_std,
            "damping_std": damping_std, "mode_shapes": shapes, "sensors": ["velocity_1_w", "velocity_2_w"]}


def test_modes_are_paired_not_indexed():
    """Mode 1 missed, a spurious mode at 1.5: errors line up with the true modes."""
    scores = modal_scores(run([1.5, 2.002, 3.0], [0.1, 0.021, 0.001], [0.001, 0.0011, 0.01], [0.001, 0.0005, 0.01],
                              [[0.3, 0.7], [1.0, -1.0], [0.0, 1.0]]), TRUTH)
    assert np.isnan(scores["freq_error_pct"][0])
    assert scores["freq_error_pct"][1] == pytest.approx(0.1)
    assert scores["damping_error_pct"][1] == pytest.approx(5.0)
    assert np.isnan(scores["damping_error_pct"][2])  # true damping ratio 0: no relative error
    assert scores["mac"][1] == pytest.approx(1.0)
    assert scores["extra_modes"] == 1
    assert scores["omega_covered"][1:] == [1.0, 1.0]  # 0.002 within 1.96 x 0.0011
    assert scores["zeta_covered"][1] == 0.0  # 0.001 off, 1.96 x 0.0005 = 0.00098
    summary = modal_summary([scores, scores])
    assert summary["found_fraction"] == [0.0, 1.0, 1.0]
    rows = {r["gate"]: r for r in evaluate({"freq_error_pct_max": 0.2, "damping_error_pct_max": 4.0, "modes": [2]},
                                           {"modal": {"summary": summary}})}
    assert rows["freq_error_pct_max"]["ok"] and not rows["damping_error_pct_max"]["ok"]
    missed = evaluate({"freq_error_pct_max": 1.0, "modes": [1]}, {"modal": {"summary": summary}})
    assert not missed[0]["ok"]  # a mode that was not found fails its gate


def test_stiffness_proportional_damping_ratios():
    """c_j = 0.05 k_j for every element: C = 0.05 K, so zeta_r = 0.05 omega_r / 2."""
    beam = load_model("ch3-damped-beam")
    modes = beam.modes()
    omega, zeta = modes.omega, true_damping_ratios(beam, modes)
    assert np.all(np.isnan(zeta[:2]))  # rigid-body modes
    assert zeta[2:12] == pytest.approx(0.025 * omega[2:12], rel=1e-6)
