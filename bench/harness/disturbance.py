"""Harmonic disturbances: periodic forces (mains multiples, rotating
machinery) added to a test's other excitation, so that an operational
identifier can be scored on telling them from modes.

A ``disturbance`` item is the force at one DOF

    F(t) = sum_k A_k cos(omega_k t + phi_k)   N (N m on rotations),

``omega_k`` rad/s either listed (``omegas``) or the ``multiples`` ``h_k`` of a
``base`` frequency (``omega_k = h_k base``: mains 50 Hz and its odd
multiples, a shaft speed and its orders); amplitudes ``A_k`` N; phases
``phi_k`` uniform in [0, 2 pi) from ``numpy.random.default_rng(seed)`` (the
same in every repetition: a machine, not a random process). It sits beside a
``random`` item of the same test (items at one DOF add up). The truth
(``truth.json`` ``harmonics``, :func:`truth_table`) lists, per test, each
sinusoid's ``omega``, ``frequency_hz``, ``amplitude`` N and DOF;
``structbench score`` counts those the modal method lists and those it
reports as modes (:mod:`structbench.evaluation.modal_scores`).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

KEYS = ("kind", "node", "dir", "amplitudes", "omegas", "base", "multiples", "seed")


@dataclass(frozen=True)
class Disturbance:
    """A sum of sinusoids at one DOF (module docstring): ``amplitudes`` N,
    ``omegas`` rad/s (same length), phases from ``seed``."""

    kind: ClassVar[str] = "disturbance"
    node: int
    direction: str
    amplitudes: tuple[float, ...]
    omegas: tuple[float, ...]
    seed: int

    @property
    def phases(self) -> np.ndarray:
        """Phases (k,) rad, uniform in [0, 2 pi) from ``default_rng(seed)``."""
        return np.random.default_rng(self.seed).uniform(0.0, 2 * np.pi, len(self.omegas))

    def force(self, t: np.ndarray, dt: float) -> np.ndarray:
        """The force (n,) N on the grid ``t`` (s)."""
        a, w = np.asarray(self.amplitudes, dtype=float), np.asarray(self.omegas, dtype=float)
        return np.cos(np.outer(t, w) + self.phases) @ a

    def perturbed(self, gain: float, omega_gain: float) -> "Disturbance":
        return dataclasses.replace(self, amplitudes=tuple(a * gain for a in self.amplitudes),
                                   omegas=tuple(w * omega_gain for w in self.omegas))


def read(item: Any, node: int, direction: str, seed: int, dt: float) -> Disturbance:
    """A ``disturbance`` item of a campaign (``item``: its table with
    ``number``, ``integer``, ``get`` and ``error``, bench/harness/toml_table.py):
    ``amplitudes`` (N) and either ``omegas`` (rad/s) or ``base`` (rad/s) and
    integer ``multiples``; every frequency in (0, pi / dt]; ``seed`` (default
    ``seed``, derived from the campaign's)."""
    amplitudes = _numbers(item, "amplitudes")
    if ("omegas" in item.data) == ("base" in item.data):
        raise item.error("omegas", "give either omegas (rad/s) or base (rad/s) with multiples")
    if "base" in item.data:
        base = item.number("base", positive=True)
        multiples = item.get("multiples")
        if not (isinstance(multiples, list) and multiples and all(
                isinstance(h, int) and not isinstance(h, bool) and h >= 1 for h in multiples)):
            raise item.error("multiples", f"expected a non-empty list of integers >= 1, got {multiples!r}")
        omegas = tuple(base * h for h in multiples)
    else:
        omegas = _numbers(item, "omegas")
    if len(omegas) != len(amplitudes):
        raise item.error("amplitudes", f"{len(amplitudes)} amplitudes for {len(omegas)} frequencies")
    nyquist = math.pi / dt
    if not all(0 < w <= nyquist * (1 + 1e-9) for w in omegas):
        raise item.error("omegas" if "omegas" in item.data else "base",
                         f"frequencies {list(omegas)} rad/s must lie in (0, pi/dt = {nyquist:g}]")
    return Disturbance(node, direction, amplitudes, omegas, item.integer("seed", seed, low=0))


def _numbers(item: Any, key: str) -> tuple[float, ...]:
    values = item.get(key)
    if not (isinstance(values, list) and values and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values)):
        raise item.error(key, f"expected a non-empty list of numbers, got {values!r}")
    return tuple(float(v) for v in values)


def truth_table(tests: Any) -> dict[str, list[dict[str, Any]]]:
    """Per test name (of TestSpecs ``tests``) its disturbance sinusoids:
    ``omega`` rad/s, ``frequency_hz``, ``amplitude`` N, ``phase`` rad,
    ``node``, ``dir``; tests without any are left out."""
    out: dict[str, list[dict[str, Any]]] = {}
    for test in tests:
        rows = [{"omega": w, "frequency_hz": w / (2 * np.pi), "amplitude": a, "phase": float(p),
                 "node": item.node, "dir": item.direction}
                for item in test.excitation if isinstance(item, Disturbance)
                for w, a, p in zip(item.omegas, item.amplitudes, item.phases)]
        if rows:
            out[test.name] = rows
    return out
