"""Excitation of a test: forces at (node, direction) as functions of time,
initial conditions, actuator noise on amplitude and frequency, and the
realisation of a random force per repetition.

Forces are evaluated on the FMU communication grid ``t`` (s, shape (n,)) and
held over each communication step; several items at one DOF add up.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .noise import derived_seed

Dof = tuple[int, str]


def ramp_envelope(t: np.ndarray, ramp: float) -> np.ndarray:
    """Soft start from 0 to 1 over ``ramp`` s: ``s - sin(2 pi s) / (2 pi)`` with
    ``s = t / ramp`` (zero slope at both ends, so little free vibration is
    excited); 1 from ``t = ramp`` on (and everywhere when ``ramp`` is 0)."""
    if ramp <= 0:
        return np.ones_like(t)
    s = np.clip(t / ramp, 0.0, 1.0)
    return s - np.sin(2 * np.pi * s) / (2 * np.pi)


@dataclass(frozen=True)
class Harmonic:
    """``A cos(omega t + phase)`` N (N m on rotations) after a soft-start ramp.

    ``settle`` (s) is the wait after the ramp before the analysis window; the
    window starts at ``ramp + settle``.
    """

    kind: ClassVar[str] = "harmonic"
    node: int
    direction: str
    amplitude: float
    omega: float
    phase: float = 0.0
    ramp: float = 0.0
    settle: float = 0.0

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        return self.amplitude * ramp_envelope(t, self.ramp) * np.cos(self.omega * t + self.phase)

    def perturbed(self, gain: float, omega_gain: float) -> "Harmonic":
        return dataclasses.replace(self, amplitude=self.amplitude * gain, omega=self.omega * omega_gain)

    @property
    def window_start(self) -> float:
        return self.ramp + self.settle


@dataclass(frozen=True)
class Impulse:
    """An impulse of ``impulse`` N s at ``time`` s.

    ``method = "pulse"``: a rectangular force ``impulse / dt`` over one
    sampling interval ``dt`` from ``time``. ``"initial-velocity"``: the exact
    impulse at t = 0 as initial velocities (``M^-1 I e``; modal FMUs
    ``qd0_r = I phi_r(x)``); no force input.
    """

    kind: ClassVar[str] = "impulse"
    node: int
    direction: str
    impulse: float
    time: float = 0.0
    method: str = "pulse"

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        if self.method != "pulse":
            return np.zeros_like(t)
        eps = 1e-9 * dt
        on = (t >= self.time - eps) & (t < self.time + dt - eps)
        return np.where(on, self.impulse / dt, 0.0)

    def perturbed(self, gain: float, omega_gain: float) -> "Impulse":
        return dataclasses.replace(self, impulse=self.impulse * gain)


@dataclass(frozen=True)
class RandomForce:
    """Band-limited Gaussian force of RMS ``rms`` N over ``band`` (rad/s):
    white noise from ``default_rng(seed)`` on the communication grid, cut to
    the band by FFT and scaled to the exact RMS over the record.
    ``per_repetition``: every repetition draws a realisation of its own
    (ambient, operational excitation; see :func:`realisations`); otherwise
    every repetition replays the same signal, as a shaker drive file would."""

    kind: ClassVar[str] = "random"
    node: int
    direction: str
    rms: float
    band: tuple[float, float]
    seed: int
    per_repetition: bool = False

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        n = t.size
        step = float(t[1] - t[0]) if n > 1 else dt
        spectrum = np.fft.rfft(np.random.default_rng(self.seed).standard_normal(n))
        omega = 2 * np.pi * np.fft.rfftfreq(n, step)
        spectrum[(omega < self.band[0]) | (omega > self.band[1])] = 0.0
        x = np.fft.irfft(spectrum, n)
        rms = np.sqrt(np.mean(x**2))
        return self.rms * x / rms if rms > 0 else x

    def perturbed(self, gain: float, omega_gain: float) -> "RandomForce":
        return dataclasses.replace(self, rms=self.rms * gain)


@dataclass(frozen=True)
class Initial:
    """Initial displacement (m or rad) and velocity (m/s or rad/s) at one DOF;
    the other DOF start at rest."""

    kind: ClassVar[str] = "initial"
    node: int
    direction: str
    displacement: float = 0.0
    velocity: float = 0.0

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        return np.zeros_like(t)

    def perturbed(self, gain: float, omega_gain: float) -> "Initial":
        return self


Excitation = Harmonic | Impulse | RandomForce | Initial


def is_force(item: Excitation) -> bool:
    """Does the item need a force input to the FMU?"""
    return isinstance(item, (Harmonic, RandomForce)) or (isinstance(item, Impulse) and item.method == "pulse")


def force_dofs(items: tuple[Excitation, ...]) -> list[Dof]:
    """DOF that receive a force, in order of first appearance."""
    return list(dict.fromkeys((i.node, i.direction) for i in items if is_force(i)))


def forces(items: tuple[Excitation, ...], dofs: list[Dof], t: np.ndarray, dt: float) -> np.ndarray:
    """Force at each of ``dofs`` on the grid ``t``, shape (n, len(dofs)), N."""
    out = np.zeros((t.size, len(dofs)))
    column = {d: j for j, d in enumerate(dofs)}
    for item in items:
        if is_force(item):
            out[:, column[(item.node, item.direction)]] += item.force(t, dt)
    return out


def perturb(items: tuple[Excitation, ...], rng: np.random.Generator, amplitude_ratio: float,
            frequency_ratio: float) -> tuple[Excitation, ...]:
    """Actuator noise: each item's amplitude times ``1 + amplitude_ratio z1``
    and frequency times ``1 + frequency_ratio z2``, two standard normal draws
    per item in order (drawn for every item, so the stream does not depend on
    the kinds), constant over the test."""
    z = rng.standard_normal((len(items), 2))
    return tuple(item.perturbed(1 + amplitude_ratio * za, 1 + frequency_ratio * zf)
                 for item, (za, zf) in zip(items, z))


def realisations(items: tuple[Excitation, ...], repetition: int) -> tuple[Excitation, ...]:
    """The excitation of one repetition: a random force with ``per_repetition``
    gets the seed ``derived_seed(seed, "repetition", repetition)``; every
    other item is the same in every repetition."""
    return tuple(dataclasses.replace(i, seed=derived_seed(i.seed, "repetition", repetition))
                 if isinstance(i, RandomForce) and i.per_repetition else i for i in items)


def varies(items: tuple[Excitation, ...]) -> bool:
    """Does the excitation differ from one repetition to the next?"""
    return any(isinstance(i, RandomForce) and i.per_repetition for i in items)


def kind_label(items: tuple[Excitation, ...]) -> str:
    """``harmonic``, ``impulse+initial``, ...: the kinds in order, joined by ``+``."""
    return "+".join(dict.fromkeys(i.kind for i in items))


def spec(item: Excitation) -> dict:
    """The item as a JSON-ready dict with its ``kind``."""
    return {"kind": item.kind, **dataclasses.asdict(item)}
