"""Channels that carry no response of their own (identifier/modal/sensors.py
``usable``): a dead sensor (constant in every trace) and a channel logged
twice make the outputs' covariance singular; before they were left out the
first raised ``ValueError`` (NaN scale) and the second ``LinAlgError``
(Cholesky of a singular Gram matrix) out of ``modal.identify``. Left out, with
a warning naming them, the identification is that of the other channels."""
from __future__ import annotations

import modal_fuzz
import numpy as np
from modal_synth import forced

from structbench.identifier import modal
from structbench.identifier.modal.sensors import usable

OMEGA, ZETA, DT, N, LEAD = np.array([4.0, 11.0]), 0.02, 0.04, 6_000, 2_000


def _record(seed: int, m: int) -> np.ndarray:
    """(m, N) displacements of two modes under white forces, 1 % noise."""
    rng = np.random.default_rng(seed)
    q = np.array([forced(w, ZETA, DT, rng.standard_normal(N + LEAD))[0][LEAD:] for w in OMEGA])
    y = rng.uniform(-1.0, 1.0, (m, 2)) @ q
    return y + 0.01 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


def _trace(y: np.ndarray):
    m = y.shape[0]
    return modal_fuzz.unseen_trace({"y": y, "dt": DT, "quantities": np.array(["displacement"] * m),
                                    "noise": np.zeros(m)})


def test_dead_and_repeated_channels_are_left_out_by_name():
    """Constant, a copy up to scale and offset, and a copy of a copy: left out; the rest kept in order."""
    y = _record(0, 3)
    rows = np.vstack([y[0], np.full(N, 0.7), -2.5 * y[0] + 1.0, y[1], y[2], y[1]])
    keep, notes = usable([rows], list("abcdef"))
    assert keep == [0, 3, 4]
    assert notes == ["channel b is constant in every trace: left out",
                     "channel c repeats channel a (correlation 1): left out",
                     "channel f repeats channel d (correlation 1): left out"]
    keep, _ = usable([rows[[0, 3]], rows[[0, 3]] + 1e-3 * np.random.default_rng(1).standard_normal((2, N))],
                     ["a", "d"])
    assert keep == [0, 1]  # independent channels stay, whatever the traces


def test_the_identification_is_that_of_the_other_channels():
    """One sensor and three, each with a dead channel and a repeated one added: the same modes as without them."""
    for seed, m in ((0, 1), (1, 3)):
        y = _record(seed, m)
        alone = modal.identify([_trace(y)])
        odd = modal.identify([_trace(np.vstack([y, np.zeros(N), 3.0 * y[:1]]))])
        assert np.array_equal(odd.omega, alone.omega) and len(alone.omega) == 2
        assert np.allclose(np.sort(alone.omega), OMEGA, rtol=0.02)
        assert odd.sensors == alone.sensors
        assert sum("left out" in w for w in odd.details["warnings"]) == 2
