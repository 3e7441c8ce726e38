"""The equations of motion through a stable low-pass prefilter, from any one response quantity per DOF.

Why. Least squares needs ``a``, ``v`` and ``u`` on every DOF. Differentiating
a noisy displacement twice multiplies its noise by ``omega^2`` up to the
Nyquist frequency; integrating it (``M u + C int u + K intint u = intint f``
from rest) turns white noise into a random walk whose variance grows like
``t^3``. Both leave equation errors dominated by noise far outside the band
the structure responds in. A linear time-invariant filter ``L`` applied to
every term keeps the equations exact,

    M (L a) + C (L v) + K (L u) = L f,

and with ``L`` a low-pass of the right order every filtered term is a
*proper* filter of whichever quantity was measured: with
``P(s) = lam / (s + lam)`` (one first-order stage, ``lam`` rad/s) and
``L(s) = s^e P(s)^r``,

    L s^(sigma - ell) = lam^d (1 - P)^d P^(r - d),   d = e + sigma - ell >= 0,

(``s P = lam (1 - P)``) for slot ``sigma`` (2: ``a``, 1: ``v``, 0: ``u``) of a
DOF measured at level ``ell`` (2 acceleration, 1 velocity, 0 displacement).
``e`` (zeros at s = 0) is the highest level measured on any DOF, so no slot
needs an integrator; ``r = max(4, e + 3 - lowest level)`` keeps every slot
filter strictly proper (its noise gain bounded: ``d <= r - 1``). The force
slot is ``lam^e (1 - P)^e P^(r - e) f``. This is the classical
state-variable-filter method of continuous-time identification; as
``lam -> 0`` with ``e = 0`` it becomes the repeated integration above.

Discretisation (sampling interval ``dt``): each stage ``P`` is one
first-order recursion with the exact pole ``p = exp(-lam dt)``, applied
stage by stage (well conditioned for any ``lam dt``; a transfer function of
``r`` repeated poles near 1 is not). Responses: first-order hold (exact for
a piecewise-linear signal), ``y_k = p y_(k-1) + b0 x_(k-1) + b1 x_k``, whose
error is a gain ``1 - (omega dt)^2 / 12`` per stage (the linear
interpolant's). A high-pass stage ``lam (x - P x)`` would mix that gain
with an exact identity (a phase error: 3 % on the damping of a 100 rad/s
oscillator at 1 ms), so its identity branch is smoothed alike,
``S x = (x_(k-2) + 10 x_(k-1) + x_k) / 12`` (gain ``1 - (omega dt)^2 / 12 +
O((omega dt)^4)``, one sample late, as is the stage). Force: the first
stage is the zero-order hold the trace format prescribes (exact), the later
ones first-order hold, followed by :data:`FORCE_SMOOTHINGS` passes of ``S``:
measured on a 1-DOF oscillator (1 ms, ``omega = 100`` rad/s, ``lam`` 50-400
rad/s, impulse and random forces, noise-free) the force slot is then
consistent with the response slots to 1e-6 in scale (one pass: 6e-4, none:
1.3e-3); what remains (``O(lam dt^2)``, and ``O(dt)`` for accelerations,
which jump with the held force) :mod:`identifier.least_squares.defect`
computes on a simulation and removes. Every slot is delayed to :attr:`SlotFilter.delay`
samples: equation ``k`` holds at ``t_(k - delay)``.

Noise. A channel's noise is white with per-sample standard deviation
``sigma_l`` (declared or estimated); through a slot filter with impulse
response ``h`` it is coloured, and the slot noises of one channel are
correlated. Over a record of ``m`` samples, for slots with impulse
responses ``h``, ``h'`` of the same channel,

    sum_k E[xi_k xi'_k] = sum_l sigma_l^2 H(m - 1 - l),   H(j) = sum_(i <= j) h_i h'_i,

which is what bias compensation subtracts (:mod:`identifier.least_squares.colored`).

Assumptions: the structure and the filter start at rest at the first
sample (as for integrated accelerations); the filter transient of any other
initial state decays like ``t^(r-1) exp(-lam t)`` and biases the first
``(r + 8) / lam`` s or so. Fails when ``lam`` is near the Nyquist frequency
(``lam dt`` not small: the discretisation error grows like ``(lam dt)^2``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LEVELS = {"displacement": 0, "velocity": 1, "acceleration": 2}
SLOTS = ("acceleration", "velocity", "displacement")  # slot levels 2, 1, 0; raw-channel blocks 0, 1, 2
FORCE_SMOOTHINGS = 2  # passes of S after the force's stages (module docstring)
SMOOTH = np.array([1.0, 10.0, 1.0]) / 12  # S: gain 1 - (omega dt)^2 / 12 + O((omega dt)^4), one sample late


@dataclass(frozen=True)
class SlotFilter:
    """``lam^d (1 - P)^d P^(r - d)``: ``d`` high-pass and ``r - d`` low-pass
    first-order stages at ``lam`` rad/s, sampled every ``dt`` s; ``held``:
    the input is a zero-order-hold signal (force: exact first stage, then
    :data:`FORCE_SMOOTHINGS` passes of ``S``), else piecewise linear."""

    lam: float
    dt: float
    d: int
    r: int
    held: bool = False

    def _stage(self, x: np.ndarray, held: bool) -> np.ndarray:
        """One low-pass stage ``P`` along the last axis."""
        from scipy.signal import lfilter  # here: importing scipy.signal takes seconds

        q = self.lam * self.dt
        one_p = -np.expm1(-q)  # 1 - p, accurate for small q
        b = np.array([0.0, one_p]) if held else np.array([1.0 - one_p / q, one_p / q - (1.0 - one_p)])
        return lfilter(b, np.array([1.0, one_p - 1.0]), x, axis=-1)

    @staticmethod
    def _delay(x: np.ndarray, k: int) -> np.ndarray:
        out = np.zeros_like(x)
        out[..., k:] = x[..., :x.shape[-1] - k]
        return out

    def _forward(self, x: np.ndarray) -> np.ndarray:
        """The causal operator along the last axis, delayed by :attr:`delay` samples."""
        from scipy.signal import lfilter

        late = 0
        # a held signal's first stage is the exact low-pass; the later ones see a continuous signal
        kinds = ((["low"] if self.held else []) + ["high"] * self.d
                 + ["low"] * (self.r - self.d - (1 if self.held else 0)))
        for i, kind in enumerate(kinds):
            low = self._stage(x, self.held and i == 0)
            if kind == "high":  # lam (1 - P) x, the identity smoothed like the stage (S), one sample late
                same = lfilter(SMOOTH, [1.0], x, axis=-1)
                x, late = self.lam * (same - self._delay(low, 1)), late + 1
            else:
                x = low
        for _ in range(FORCE_SMOOTHINGS if self.held else 0):
            x, late = lfilter(SMOOTH, [1.0], x, axis=-1), late + 1
        return self._delay(x, self.delay - late)

    @property
    def delay(self) -> int:
        """Samples by which every slot's output lags (the same for all slots of one ``r``)."""
        return self.r + 1 + FORCE_SMOOTHINGS

    def __call__(self, x: np.ndarray, reverse: bool = False) -> np.ndarray:
        """The filtered signal (same shape as ``x``, along axis 0), output ``k``
        belonging to time ``t_(k - delay)``; ``reverse``: the adjoint
        (``sum_(k >= l) h_(k - l) x_k``)."""
        y = np.ascontiguousarray(np.moveaxis(np.asarray(x, dtype=float), 0, -1))
        if reverse:
            return np.moveaxis(self._forward(y[..., ::-1])[..., ::-1], -1, 0)
        return np.moveaxis(self._forward(y), -1, 0)

    def impulse(self, m: int) -> np.ndarray:
        """Impulse response ``h`` (m,)."""
        unit = np.zeros(m)
        unit[0] = 1.0
        return self(unit)


@dataclass(frozen=True)
class Design:
    """The prefilter ``L = s^e P^r`` at ``lam`` rad/s."""

    lam: float
    e: int
    r: int

    @staticmethod
    def for_levels(levels: np.ndarray, lam: float) -> "Design":
        """The design for the measured levels per DOF (n,) (see the module docstring)."""
        e = int(levels.max())
        return Design(float(lam), e, max(4, e + 3 - int(levels.min())))

    def slot(self, sigma: int, ell: int, dt: float) -> SlotFilter:
        return SlotFilter(self.lam, dt, self.e + sigma - ell, self.r)

    def force(self, dt: float, held: bool) -> SlotFilter:
        return SlotFilter(self.lam, dt, self.e, self.r, held)


def noise_sums(sigma: np.ndarray, h: np.ndarray, h2: np.ndarray) -> np.ndarray:
    """``sum_k E[xi_k xi'_k]`` for white noise ``sigma`` (m, c) through impulse
    responses ``h``, ``h2`` (m,): ``sum_l sigma_l^2 H(m - 1 - l)``, (c,)."""
    H = np.cumsum(h * h2)[::-1]
    return H @ sigma**2


def band(signals: np.ndarray, levels: np.ndarray, dt: float) -> float:
    """A characteristic response frequency (rad/s): the power-weighted median
    frequency of the displacement-equivalent spectra ``|X|^2 / omega^(2 ell)``
    of the measured signals (m, c) at levels (c,), the zero line excluded."""
    m = signals.shape[0]
    spec = np.abs(np.fft.rfft(signals - signals.mean(axis=0), axis=0)) ** 2
    omega = 2 * np.pi * np.fft.rfftfreq(m, dt)
    power = np.sum(spec[1:] / omega[1:, None] ** (2 * levels[None, :]), axis=1)
    power = power / np.sum(power, axis=0, keepdims=True).clip(np.finfo(float).tiny)
    return float(omega[1:][np.searchsorted(np.cumsum(power), 0.5)])
