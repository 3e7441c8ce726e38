"""A candidate whose damping ratio lies below zero by more than ``UNDAMPED``
standard errors is a growing pole, no mode of a passive structure
(identifier/modal/support.py, growing)."""
from __future__ import annotations

import modal_fuzz
import numpy as np

from structbench.identifier import modal
from structbench.identifier.modal import support


def test_the_rule_at_its_edge():
    omega = np.array([10.0, 20.0, 30.0])
    zeta = np.array([-0.0021, -0.0019, 0.01])
    zeta_std = np.full(3, 0.001)  # -0.0021 is 2.1 standard errors below zero, -0.0019 1.9
    verdict = support.judge(omega, zeta, np.full(3, 1e-3), zeta_std, np.zeros(3), np.full(3, 30),
                            np.ones(3), np.eye(3, dtype=complex), 100.0, True, 8)
    assert verdict.keep.tolist() == [False, True, True]
    assert "growing pole" in verdict.reasons[0]


def test_a_growing_second_pole_of_a_free_decay_is_not_reported():
    """Held-out profile seed 1,004,339 (the fourteenth round's fresh check,
    looked at after its figures were written): one acceleration sensor,
    4,070 samples, true modes at 1.781 (``zeta`` 0.082) and 38.741 rad/s
    (0.063); SSI's second pole at 36.94 rad/s, damping -0.016 +- 0.0024,
    was reported. Which test lists it apart depends on the last bits of the
    BLAS build (the growing-pole rule on the machine it was found on, the
    duplicate rule beside the 38.72 rad/s mode on a later one, OpenBLAS
    0.3.31 ``SkylakeX``); the rule itself is tested above. Every candidate
    listed as growing lies below zero by over ``UNDAMPED`` standard errors."""
    result = modal.identify([modal_fuzz.unseen_trace(modal_fuzz.unseen_record(1_004_339))])
    assert not any(35.0 < w < 38.0 for w in result.omega)
    assert any(abs(w / 38.741 - 1) < 0.01 for w in result.omega)
    assert any(35.0 < r["omega"] < 38.0 for r in result.details["rejected"])
    growing = [r for r in result.details["rejected"] if "growing pole" in r["reason"]]
    assert growing and all(float(r["reason"].split()[2]) < 0 for r in growing)
    assert np.all(np.array(result.damping) + support.UNDAMPED * np.array(result.damping_std) >= 0)
