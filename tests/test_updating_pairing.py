"""Model updating with a mode the modal identifier reported twice (damage
seed 123: the baseline's modes 5 and 6 at 252.6 and 256.8 rad/s, shapes MAC
0.999), and the refusal of an answer with every parameter on a bound."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from structbench.identifier.errors import IdentificationError
from structbench.identifier.updating import update
from structbench.models import load_model

from test_identify_updating import K_SMU, modal_data, smu_frame

ROOT = Path(__file__).resolve().parents[1]
SENSORS = [(n, "w") for n in (5, 10, 15, 20, 25)]


def test_a_duplicated_mode_is_left_out_and_named(tmp_path: Path) -> None:
    """The 25-element cantilever, 5 sensors, exact modes 1-10 with mode 5
    repeated 1.6 % higher (its shape slightly changed). One-to-one pairing
    gave the copy model mode 15 (the same shape at these 5 sensors, 10x the
    frequency) and the update ran every stiffness onto the lower bound; the
    copy is left out and the prior (5 % off) goes to the truth."""
    truth = load_model(ROOT / "campaigns" / "cantilever-25.toml")
    rng = np.random.default_rng(5)
    p = truth.values.copy()
    stiff = np.array([par.kind == "stiffness" for par in truth.parameters])
    p[stiff] *= np.exp(rng.uniform(np.log(0.95), np.log(1.05), stiff.sum()))
    prior = truth.with_values(p)
    found = truth.modes(10)
    shapes = found.shapes[[truth.dof_index(*d) for d in SENSORS]]
    omega = np.sqrt(found.lam)
    modes = [{"omega": float(w), "omega_std": 1e-4 * float(w), "shape": s.tolist(), "shape_std": 1e-4}
             for w, s in zip(omega, shapes.T)]
    copy = shapes[:, 4] + 0.01 * np.abs(shapes[:, 4]).max() * rng.standard_normal(5)
    modes.insert(5, {"omega": 1.016 * float(omega[4]), "omega_std": 1e-4 * float(omega[4]), "shape": copy.tolist(),
                     "shape_std": 1e-4})
    path = tmp_path / "modes.json"
    path.write_text(json.dumps({"format": "structbench-modal-data", "dofs": [list(d) for d in SENSORS],
                                "modes": modes}))
    result = update(prior, path)
    left = result.details["left_out"]
    assert [(d["mode"], d["kept"], d["model_mode"]) for d in left] == [(6, 5, 5)]
    assert "measured mode 6" in left[0]["text"] and left[0]["mac"] > 0.99
    assert result.details["at_bound"] == [] and result.details["pairs"] == list(range(1, 11))
    # exact data of the true model: every frequency fitted within its stated error (1e-4 relative)
    assert np.allclose(result.omega, omega, rtol=1e-4) and result.details["misfit"] < 1.0


def test_every_parameter_on_a_bound_is_refused() -> None:
    """Eigenvalues 100 times the frame's (stiffness 100 times the prior's)
    within alpha in [-0.5, 0.5]: every stiffness would end at +0.5, which is
    not an answer; the error names the bounds and the worst pairs."""
    data = modal_data(smu_frame(K_SMU), 4, [(d, "x") for d in (1, 4, 7, 9, 12, 15, 18)])
    data.lam *= 100.0
    with pytest.raises(IdentificationError, match=r"every parameter \(18.*bound of alpha \[-0.5, 0.5\].*"
                                                  r"measured mode \d \("):
        update(smu_frame(K_SMU), data, bounds=(-0.5, 0.5))
    seven = [(d, "x") for d in (1, 4, 7, 9, 12, 15, 18)]
    inside = update(smu_frame(K_SMU), modal_data(smu_frame(1.2 * K_SMU), 4, seven), bounds=(-0.5, 0.5))
    assert inside.details["at_bound"] == [] and np.allclose(inside.details["alpha"], 0.2, atol=1e-4)
