"""Invalid values surface as FmuError with the FMU's own message; misuse as UserError."""
from __future__ import annotations

import numpy as np
import pytest

from structbench.harness.fmu_session import FmuError, FmuSession
from structbench.models.errors import UserError


def test_negative_mass_is_rejected_with_a_readable_message(fmus):
    logged: list[str] = []
    with FmuSession(fmus["ch3-free-free-beam"], log=logged.append) as fmu:
        with pytest.raises(FmuError, match=r"m_3 = -1 kg/m rejected: must be positive") as err:
            fmu.set_parameters({"m_3": -1.0})
        assert "element 3" in str(err.value)
        with pytest.raises(FmuError, match="m_3 = -1 kg/m rejected"):  # still set: the run refuses
            fmu.run(["F_7_w"], ["u_7_w"], np.zeros((10, 1)), 0.01)
        fmu.set_parameters({"m_3": 2.3})
        fmu.reset()
        assert fmu.run(["F_7_w"], ["u_7_w"], np.ones((10, 1)), 0.01)[-1, 0] > 0
    assert any("m_3 = -1" in line and line.startswith("[error]") for line in logged)


def test_nan_force_fails_the_step_and_reset_recovers(fmus):
    force = np.ones((20, 1))
    force[12] = np.nan
    with FmuSession(fmus["ch5-membrane"]) as fmu:
        with pytest.raises(FmuError, match=r"t = 0\.12 s.*F_5_w = nan N rejected: must be finite") as err:
            fmu.run(["F_5_w"], ["a_5_w"], force, 0.01)
        assert err.value.messages and err.value.field == "ch5-membrane.fmu"
        with pytest.raises(UserError, match="call reset"):
            fmu.run(["F_5_w"], ["a_5_w"], force[:5], 0.01)
        fmu.reset()
        assert np.isfinite(fmu.run(["F_5_w"], ["a_5_w"], force[:12], 0.01)).all()


@pytest.mark.parametrize("name, value, message", [
    ("zeta_2", -0.1, "must be nonnegative"),
    ("omega_1", float("inf"), "must be finite"),
])
def test_invalid_modal_parameters(fmus, name, value, message):
    with FmuSession(fmus["ch5-simply-supported-beam"]) as fmu:
        with pytest.raises(FmuError, match=f"{name} = .* rejected: {message}"):
            fmu.set_parameters({name: value})


def test_misuse_is_a_user_error(fmus):
    with FmuSession(fmus["ch4-cantilever-case1"]) as fmu:
        with pytest.raises(UserError, match="no variable 'F_99_w'"):
            fmu.run(["F_99_w"], [], np.zeros((3, 1)), 0.01)
        with pytest.raises(UserError, match=r"shape \(n_steps, 1\)"):
            fmu.run(["F_7_w"], [], np.zeros((3, 2)), 0.01)
        with pytest.raises(UserError, match="expected a real parameter"):
            fmu.set_parameters({"u_7_w": 1.0})
        fmu.run(["F_7_w"], ["u_7_w"], np.zeros((3, 1)), 0.01)
        with pytest.raises(UserError, match="u0_7_w cannot change during a run"):
            fmu.set_parameters({"u0_7_w": 1.0})
        with pytest.raises(UserError, match="ended at t = 0.03 s"):
            fmu.run(["F_7_w"], ["u_7_w"], np.zeros((3, 1)), 0.01)
    with pytest.raises(UserError, match="no such FMU"):
        FmuSession("missing.fmu")
