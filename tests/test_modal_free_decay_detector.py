"""The free-decay detector (identifier/modal/ssi/covariance.py,
``is_free_decay``): a free decay whose slow mode hardly decays (0.33
decay times in the record, as 700,318 of the held-out profile) is told by
the channel its fast mode carries; stationary responses of the same modes
are not taken for free decays."""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from structbench.identifier.modal.ssi.covariance import decaying_channel, is_free_decay

OMEGA = np.array([1.276, 80.72])  # rad/s
ZETA = np.array([0.33 / (1.276 * 220.0), 0.01])  # 0.33 and 176 decay times in 220 s
DT = np.pi / (3.0 * OMEGA[1])
N = int(220.0 / DT)
SHAPES = np.array([[1.0, 0.3], [0.8, -0.2], [-0.9, 0.1], [0.05, 1.0]])  # (4 channels, 2 modes)


def modal(rng: np.random.Generator, stationary: bool) -> np.ndarray:
    """Modal coordinates (2, N): a free decay from unit amplitudes at random
    phases, or each mode's response to white noise with its poles (10
    decay times of the slow mode run in and dropped)."""
    t = np.arange(N) * DT
    if not stationary:
        phase = rng.uniform(0, 2 * np.pi, 2)
        return np.exp(-ZETA * OMEGA * t[:, None]).T * np.cos(np.outer(OMEGA * np.sqrt(1 - ZETA**2), t) + phase[:, None])
    lead = int(10.0 / (ZETA[0] * OMEGA[0] * DT))
    poles = np.exp((-ZETA * OMEGA + 1j * OMEGA * np.sqrt(1 - ZETA**2)) * DT)
    return np.vstack([lfilter([1.0], np.poly([p, p.conjugate()]).real, rng.standard_normal(lead + N))[lead:]
                      for p in poles])


def record(seed: int, stationary: bool) -> np.ndarray:
    """Sensor records (4, N): the shapes times unit-RMS modal coordinates, 1 % white noise."""
    rng = np.random.default_rng(seed)
    q = modal(rng, stationary)
    y = SHAPES @ (q / np.sqrt(np.mean(q**2, axis=1, keepdims=True)))
    return y + 0.01 * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(y.shape)


def pooled_ratio(y: np.ndarray) -> float:
    """The first tenth's mean square over the last's, unit-RMS channels pooled (the rule's first part)."""
    z = y / np.sqrt(np.mean(y**2, axis=1, keepdims=True))
    tenth = y.shape[1] // 10
    return float(np.mean(z[:, :tenth] ** 2) / np.mean(z[:, -tenth:] ** 2))


def test_a_free_decay_with_a_slow_mode_is_a_free_decay():
    """The pooled ratio is under 10 (the old rule alone says stationary);
    the fast mode's channel decays by orders of magnitude."""
    for seed in range(5):
        y = record(seed, stationary=False)
        assert pooled_ratio(y) < 10.0
        assert decaying_channel(y / np.sqrt(np.mean(y**2, axis=1, keepdims=True)))
        assert is_free_decay(y)


def test_stationary_responses_of_the_same_modes_are_not():
    """A slow, lightly damped random response (0.33 decay times: its tenths
    differ by chance) and the fast mode's channel: none of 40 taken for a
    free decay by the channel rule (expected about 0.04 at DECAY_ALPHA)."""
    records = [record(seed, stationary=True) for seed in range(40)]
    taken = [seed for seed, y in enumerate(records)
             if decaying_channel(y / np.sqrt(np.mean(y**2, axis=1, keepdims=True)))]
    assert taken == []


def test_white_records_pass_at_about_the_stated_rate():
    """White Gaussian records of 8 channels (F law exact but for the tenths' own scaling): of 2000, the
    channel rule takes 0-8 for free decays (DECAY_ALPHA = 1e-3: 2 expected)."""
    rng = np.random.default_rng(1)
    taken = sum(decaying_channel(rng.standard_normal((8, 500))) for _ in range(2000))
    assert taken <= 8
