"""Refuse FMU output that is not finite or diverges, before noise is added.

A stable structure's response stays within a bound set by its force: it
may grow while the force grows, or polynomially (rigid-body drift, t^2 under
a constant force; resonance build-up, t; a point where early terms cancel,
t^3 on the chapter 3 beam), but not exponentially while the force's running
maximum stays put. An FMU integrated beyond its stability limit (explicit
Euler at omega h > 2 zeta) grows by a constant factor per step. So, per
motion channel x (n,) at the sample times:

1. a NaN or infinite sample fails at its time;
2. |x - x_0| >= :data:`ABSURD` (m, m/s, m/s^2, rad: no structure moves so
   far; squares of such numbers overflow) fails at its first sample;
3. with the record cut into :data:`BLOCKS` blocks, e_b the largest
   |x - x_0| in block b and F_b the largest |force| up to the end of block b
   (1 when no force acts), s the first block that starts after the force
   began: the channel diverges at block j > s where e_j / F_j exceeds
   :data:`GROWTH` times e_m / F_m, m = s + (j - s) // 2 (about half the time
   since the force began: t^p grows by about 2^p there, exp(sigma t) by
   exp(sigma t / 2)); it fails at the first sample of block j beyond that bound.

Each failure is a :class:`SimulationError` naming the channel, the time of
the first bad sample and its value.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

ABSURD = 1e100   # |x - x_0| above this is divergence (units of the channel)
BLOCKS = 20      # blocks of the growth test
GROWTH = 1e3     # growth of e/F over the latter half of the time since the force began


class SimulationError(RuntimeError):
    """A simulation produced unusable output (NaN, infinity, divergence)."""


def first_bad(name: str, x: np.ndarray, dt: float) -> None:
    """Raise naming ``name`` if ``x`` (n,) holds a NaN/inf sample (``dt`` s apart)."""
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise SimulationError(f"{name} is {x[bad[0]]} at t = {bad[0] * dt:.9g} s (first non-finite sample)")


def check_output(signals: Mapping[str, np.ndarray], force: np.ndarray, dt: float) -> None:
    """Every channel of ``signals`` (name -> (n,)) finite and not diverging
    under the force history ``force`` (n, n_forces) N; raises
    :class:`SimulationError` at the first bad channel (``dt``: sample interval, s)."""
    n = next(iter(signals.values())).size if signals else 0
    fmag = np.abs(force).max(axis=1) if force.size else np.zeros(n)
    nb = BLOCKS if n >= 4 * BLOCKS else 0
    if nb:
        edges = np.linspace(0, n, nb + 1).astype(int)
        f_run = np.maximum.accumulate(np.maximum.reduceat(fmag, edges[:-1]))
        started = np.flatnonzero(f_run > 0)
        first = (started[0] + 1) if started.size else 1  # a full block after the force began
        f_run = np.where(f_run > 0, f_run, 1.0)
    for name, x in signals.items():
        first_bad(name, x, dt)
        dev = np.abs(x - x[0])
        big = np.flatnonzero(dev >= ABSURD)
        if big.size:
            raise SimulationError(f"{name} diverged: {x[big[0]]:.3g} at t = {big[0] * dt:.9g} s")
        if not nb or first + 1 >= nb:
            continue
        ratio = np.maximum.reduceat(dev, edges[:-1]) / f_run
        j = np.arange(first + 1, nb)
        m = first + (j - first) // 2
        grown = j[(ratio[m] > 0) & (ratio[j] > GROWTH * ratio[m])]
        if grown.size:
            jj = grown[0]
            mm = first + (jj - first) // 2
            bound = GROWTH * ratio[mm] * f_run[jj]
            k = edges[jj] + int(np.argmax(dev[edges[jj]:edges[jj + 1]] > bound))
            raise SimulationError(
                f"{name} diverges: its excursion from the initial value grew {ratio[jj] / ratio[mm]:.3g} times "
                f"between t = {edges[mm] * dt:.6g} s and {edges[jj + 1] * dt:.6g} s with the force no larger; first "
                f"over {GROWTH:.0e} times at t = {k * dt:.9g} s ({x[k]:.3g}); the FMU's integration is unstable at "
                "this step (try substeps or interface = \"model-exchange\")")
