"""Sensor and actuator noise, reproducible from explicit seeds.

Seeds: repetition ``r`` of test ``name`` with base seed ``b`` (the test's
``noise.seed``, else the campaign's ``seed``) uses
``derived_seed(b, name, r)``. From that repetition seed ``s`` the actuator noise draws from
``default_rng([s, 0])`` and the sensor noise of a channel from
``default_rng([s, 1, crc32(channel name)])``, so each channel's noise is
independent of which other channels are logged.
"""
from __future__ import annotations

import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

MODES = ("rms", "proportional")


@dataclass(frozen=True)
class NoiseSpec:
    """Noise settings of a test.

    ``sensor`` maps a quantity (``displacement``, ..., ``force``) to its
    noise-to-signal ratio at one standard deviation (absent: exact);
    ``mode`` is ``rms`` (sigma = ratio x RMS of the noise-free channel over the
    record) or ``proportional`` (sigma_k = ratio x |value_k|, a gain error);
    ``actuator_*`` are the actuator noise ratios on amplitude and frequency.
    """

    sensor: Mapping[str, float] = field(default_factory=dict)
    mode: str = "rms"
    actuator_amplitude: float = 0.0
    actuator_frequency: float = 0.0
    seed: int = 0

    def ratio(self, quantity: str) -> float:
        return float(self.sensor.get(quantity, 0.0))

    @property
    def actuator(self) -> bool:
        """Does actuator noise change the simulation from one repetition to the next?"""
        return self.actuator_amplitude > 0 or self.actuator_frequency > 0


def derived_seed(*parts: int | str) -> int:
    """A 32-bit seed from integers and strings (strings enter as their crc32)."""
    entropy = [zlib.crc32(p.encode()) if isinstance(p, str) else int(p) for p in parts]
    return int(np.random.SeedSequence(entropy).generate_state(1)[0])


def actuator_rng(seed: int) -> np.random.Generator:
    return np.random.default_rng([seed, 0])


def channel_rng(seed: int, channel: str) -> np.random.Generator:
    return np.random.default_rng([seed, 1, zlib.crc32(channel.encode())])


def with_sensor_noise(signal: np.ndarray, ratio: float, mode: str, rng: np.random.Generator) -> np.ndarray:
    """``signal`` (n,) plus Gaussian noise at noise-to-signal ``ratio``.

    The RMS is taken of ``signal / max|signal|`` and scaled back, so no finite
    signal overflows (no RuntimeWarning); a non-finite signal gives a
    non-finite result, which the harness refuses to write."""
    if ratio == 0:
        return signal.copy()
    z = rng.standard_normal(signal.shape)
    if mode == "proportional":
        return signal + ratio * np.abs(signal) * z
    return signal + ratio * rms(signal) * z


def rms(signal: np.ndarray) -> float:
    """Root mean square of ``signal`` (n,), without overflow for any finite
    samples (``max|x| sqrt(mean((x / max|x|)^2))``); NaN when one is not finite."""
    scale = float(np.max(np.abs(signal))) if signal.size else 0.0
    if not np.isfinite(scale):
        return float("nan")
    if scale == 0.0:
        return 0.0
    return scale * float(np.sqrt(np.mean((signal / scale) ** 2)))


def noisy_channels(clean: Mapping[str, np.ndarray], ratios: Mapping[str, float], mode: str,
                   seed: int) -> dict[str, np.ndarray]:
    """Every channel of ``clean`` (name -> (n,)) with its sensor noise added."""
    return {name: with_sensor_noise(x, ratios[name], mode, channel_rng(seed, name))
            for name, x in clean.items()}
