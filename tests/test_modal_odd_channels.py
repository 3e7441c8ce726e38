"""Channels that carry no response of their own (identifier/modal/sensors.py
``usable``): a dead sensor (constant in every trace) and a channel logged
twice make the outputs' covariance singular; before they were left out the
first raised ``ValueError`` (NaN scale) and the second ``LinAlgError``
(Cholesky of a singular Gram matrix) out of ``modal.identify``. A clipped
channel (an overloaded sensor) adds harmonics and intermodulation that pass
for modes: random responses of the held-out profile clipped at 3 RMS gave
invented modes in about one record in three. Left out, with a warning naming
them, the identification is that of the other channels; with none left, a
refusal that names each channel's fault."""
from __future__ import annotations

import modal_fuzz
import numpy as np
from modal_synth import forced

import pytest
from structbench.identifier import modal
from structbench.identifier.errors import IdentificationError
from structbench.identifier.modal.sensors import clipped, usable

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


def test_clipping_is_told_from_a_tail_and_a_quantised_crest():
    """Gaussian records of 40,000 samples clipped at 2 and 3 RMS (about 910 and 54 samples beyond each
    side): flagged with every sample beyond the level counted (20 seeds, 4 channels each), and 2,000
    samples of them at 2.5 RMS wherever 3 or more are beyond; unclipped, quantised to 8 bits, a quantised
    sinusoid (the arcsine law piles samples at its crest) or a one-sided record at rest before and after:
    never flagged."""
    for seed in range(20):
        rng = np.random.default_rng(seed)
        y = rng.standard_normal((4, 40_000))
        for level in (2.0, 3.0):
            beyond = np.maximum(np.sum(y >= level, axis=1), np.sum(y <= -level, axis=1))
            assert np.array_equal(clipped(np.clip(y, -level, level)), beyond)
        step = np.abs(y).max() / 127
        crest = np.round(rng.uniform(3, 200) * np.sin(rng.uniform(0.5, 2) * np.arange(40_000) * 0.01))
        assert not clipped(y).any() and not clipped(np.round(y / step) * step).any()
        assert not clipped(crest[None]).any()
        few = np.clip(y[:, :2_000], -2.5, 2.5)  # a short continuous record: a few samples beyond suffice
        beyond = np.maximum(np.sum(y[:, :2_000] >= 2.5, axis=1), np.sum(y[:, :2_000] <= -2.5, axis=1))
        assert np.array_equal(clipped(few), np.where(beyond >= 3, beyond, 0))
        rest = np.concatenate([np.zeros((4, 300)), y[:, :2_000] ** 2, np.zeros((4, 50))], axis=1)
        assert not clipped(rest).any()  # one-sided, at rest before and after: its zeros are no pile-up


def test_a_clipped_channel_is_left_out_and_a_clipped_record_refused():
    """Three sensors, one clipped at 2 RMS (about 140 of 6,000 samples beyond each side): the modes of
    the other two, the clipped one named; one sensor, clipped: refused, naming it."""
    y = _record(2, 3)
    cut = 2.0 * y[1].std()
    odd = np.vstack([y[0], np.clip(y[1], -cut, cut), y[2]])
    alone = modal.identify([_trace(y[[0, 2]])])
    result = modal.identify([_trace(odd)])
    assert np.array_equal(result.omega, alone.omega) and np.allclose(np.sort(alone.omega), OMEGA, rtol=0.02)
    assert [w for w in result.details["warnings"] if "clipped" in w] == [
        f"channel displacement_2_w is clipped ({clipped(odd[1:2])[0]} samples at its extreme value): left out"]
    with pytest.raises(IdentificationError, match="displacement_1_w is clipped"):
        modal.identify([_trace(odd[1:2])])
