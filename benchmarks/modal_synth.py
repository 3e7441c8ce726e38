"""Fast exact responses of a modal model for the modal benchmarks, as
in-memory traces (no FMU, no files).

Each mode ``q_r'' + 2 zeta_r omega_r q_r' + omega_r^2 q_r = phi_r(x_f) f(t)`` is
discretised exactly for a force held over each step (zero-order hold, as the
FMUs do) and run with ``scipy.signal.lfilter``; an impulse of ``impulse`` N s
is the initial modal velocity ``phi_r(x_f) impulse``. Sensor noise: ``ratio x
RMS`` of each clean channel, Gaussian, from ``numpy.random.default_rng(seed)``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.linalg as la
from scipy.signal import lfilter

from structbench.identifier.io.traces import Channel, Trace

UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


def _mode_filter(omega: float, zeta: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """ZOH discretisation of one mode: ``Ad`` (2, 2), ``Bd`` (2,) for the state (q, q')."""
    A = np.array([[0.0, 1.0], [-omega**2, -2 * zeta * omega]])
    big = la.expm(np.block([[A, np.array([[0.0], [1.0]])], [np.zeros((1, 3))]]) * dt)
    return big[:2, :2], big[:2, 2]


def mode_transfer(omega: float, zeta: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One mode's zero-order-hold filters from its force (``lfilter``
    coefficients, (3,) each): the numerators to ``q`` and ``q'`` and their
    common denominator, from :func:`_mode_filter`'s ``x_{k+1} = Ad x_k + Bd f_k``."""
    Ad, Bd = _mode_filter(omega, zeta, dt)
    return (np.r_[0.0, Bd[0], Ad[0, 1] * Bd[1] - Ad[1, 1] * Bd[0]],
            np.r_[0.0, Bd[1], Ad[1, 0] * Bd[0] - Ad[0, 0] * Bd[1]], np.poly(Ad))


def forced(omega: float, zeta: float, dt: float, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``q`` and ``q'`` (n,) of one mode ``q'' + 2 zeta omega q' + omega^2 q
    = f`` from rest under the force samples ``f`` (n,) held over each step
    of ``dt`` s."""
    num_q, num_v, den = mode_transfer(omega, zeta, dt)
    return lfilter(num_q, den, f), lfilter(num_v, den, f)


def modal_response(model, dt: float, n: int, node: int, impulse: float = 0.0,
                   force: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Displacement, velocity, acceleration (n, n_dof) of a modal model
    after an impulse (N s) and/or a held force (n,) N at point ``node``."""
    shapes = model.shapes  # (n_dof, r), mass-normalised at the points
    load = shapes[node - 1]
    q = np.zeros((n, model.n_modes))
    qd = np.zeros_like(q)
    f = np.zeros(n) if force is None else np.asarray(force, dtype=float)
    for r, (w, z) in enumerate(zip(model.omega, model.zeta)):
        # the forced response (two IIR filters of the force) plus the free decay from the impulse
        free = _free(_mode_filter(w, z, dt)[0], np.array([0.0, load[r] * impulse]), n)
        q[:, r], qd[:, r] = forced(w, z, dt, load[r] * f)
        q[:, r] += free[:, 0]
        qd[:, r] += free[:, 1]
    acc = -(q * model.omega**2 + qd * 2 * model.zeta * model.omega) + np.outer(f, load)
    return {"displacement": q @ shapes.T, "velocity": qd @ shapes.T, "acceleration": acc @ shapes.T}


def _free(Ad: np.ndarray, x0: np.ndarray, n: int) -> np.ndarray:
    """``Ad^k x0`` for k < n, (n, 2), by the eigen-decomposition of ``Ad``."""
    mu, V = la.eig(Ad)
    c = la.solve(V, x0)
    return ((V * c) @ np.power.outer(mu, np.arange(n))).T.real


def band_force(n: int, dt: float, band: tuple[float, float], rms: float, seed: int) -> np.ndarray:
    """Band-limited Gaussian force (n,) as the harness makes it (FFT cut, exact RMS)."""
    spectrum = np.fft.rfft(np.random.default_rng(seed).standard_normal(n))
    omega = 2 * np.pi * np.fft.rfftfreq(n, dt)
    spectrum[(omega < band[0]) | (omega > band[1])] = 0.0
    x = np.fft.irfft(spectrum, n)
    return rms * x / np.sqrt(np.mean(x**2))


def trace(model, response: dict[str, np.ndarray], dt: float, quantity: str, ratio: float, seed: int,
          name: str = "synthetic", nodes: list[int] | None = None, excitation: dict | None = None) -> Trace:
    """An in-memory :class:`Trace` of one quantity at ``nodes`` (default all) with sensor noise;
    ``excitation``: the attributes of ``/excitation`` (its ``kind``, ``spec``)."""
    rng = np.random.default_rng(seed)
    data = response[quantity]
    n = data.shape[0]
    nodes = nodes or list(range(1, data.shape[1] + 1))
    channels = {}
    for node in nodes:
        clean = data[:, node - 1]
        noisy = clean + ratio * np.sqrt(np.mean(clean**2)) * rng.standard_normal(n)
        channels[f"{quantity}_{node}_w"] = Channel(f"{quantity}_{node}_w", noisy, quantity, UNITS[quantity],
                                                   node, "w", np.full(3, np.nan), ratio)
    return Trace(Path(f"{name}.h5"), np.arange(n) * dt, dt, dt, channels, {},
                 {"test": name, "repetition": seed, "structure": model.name}, excitation or {})


def free_decays(omega: np.ndarray, zeta: np.ndarray, shapes: np.ndarray, participations: np.ndarray,
                dt: float, n: int, ratio: float, seed: int) -> list[np.ndarray]:
    """Records (m, n) of free decays ``y_r(t) = sum_a phi_a Re(p_ra e^(lambda_a t))``
    (``lambda_a = -zeta_a omega_a + i omega_a sqrt(1 - zeta_a^2)``; shapes (m, p),
    participations (R, p) complex) with white noise of ``ratio x`` each clean channel's RMS."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    poles = -zeta * omega + 1j * omega * np.sqrt(1 - zeta**2)
    out = []
    for p in np.atleast_2d(participations):
        clean = shapes @ (p[:, None] * np.exp(np.outer(poles, t))).real
        out.append(clean + ratio * np.sqrt(np.mean(clean**2, axis=1))[:, None] * rng.standard_normal(clean.shape))
    return out
