"""A free decay's pole that the ML refinement moves by more than ``MOVE``
SSI standard errors, with nothing to explain the move, keeps SSI's value
with its errors widened by the move (identifier/modal/refine.py): the two
estimates' difference is the model error neither states."""
from __future__ import annotations

import modal_fuzz
import numpy as np

from structbench.identifier import modal
from structbench.identifier.modal import refine


def test_an_unexplained_move_widens_the_kept_pole_errors():
    """Held-out profile seed 1,002,218 (a tuning seed, looked at after its
    check): one velocity sensor, true modes at 1.248 and 1.431 rad/s (under
    two decay times each in the record) that SSI fits with one pole at
    1.337; the refinement moves it 4.5 standard errors, to the lower one.
    With SSI's errors alone (0.020 rad/s) it was 4.5 of them from every
    true mode: invented."""
    trace = modal_fuzz.unseen_trace(modal_fuzz.unseen_record(1_002_218))
    ssi = modal.identify([trace], refine="off")
    kept = modal.identify([trace])
    i = int(np.argmin(np.abs(np.array(kept.omega) - ssi.omega[0])))
    assert kept.omega[i] == ssi.omega[0] and abs(kept.omega[i] - 1.337) < 0.005
    assert any("widened" in reason for reason in kept.details["ml_refinement"]["mode_reasons"])
    move = np.sqrt(kept.omega_std[i] ** 2 - ssi.omega_std[0] ** 2)  # Delta of the widening, rad/s
    assert refine.MOVE * ssi.omega_std[0] < move < 1.337 - 1.248 + 0.01  # the move: 4.5 se, to the lower mode
    assert abs(kept.omega[i] - 1.248) <= 1.96 * kept.omega_std[i]  # the interval reaches the true mode
    assert abs(ssi.omega[0] - 1.248) > 4 * ssi.omega_std[0]  # SSI's alone did not: 4.5 se
    assert abs(kept.omega[i] - 1.431) <= 1.96 * kept.omega_std[i]  # and the upper one (unsupported)
