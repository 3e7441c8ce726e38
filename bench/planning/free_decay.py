"""Cramer-Rao bounds of natural frequencies and damping ratios from a free decay.

Signal model (damped sinusoids in white noise): channel ``c`` samples
``t_k = k dt``, k = 0..m-1,

    y_c(t) = sum_r exp(-alpha_r t) (a_cr cos(wd_r t) + b_cr sin(wd_r t)) + n_c(t),

``alpha_r = zeta_r omega_r``, ``wd_r = omega_r sqrt(1 - zeta_r^2)``, noise
white with standard deviation ``sigma_c``. The nonlinear unknowns are
``(alpha_r, wd_r)`` (shared by every channel), the linear ones every
channel's amplitudes ``(a_cr, b_cr)``, free per channel (what an
output-only identifier knows). With ``Phi = [g_r, h_r]`` (m, 2R) the basis
``g = exp(-alpha t) cos(wd t)``, ``h = exp(-alpha t) sin(wd t)`` and
``Psi = t Phi``, the channel's derivatives are ``Psi L_c`` with ``L_c``
block-diagonal, ``[[-a, b], [-b, -a]]`` per mode; eliminating each channel's
own amplitudes (Schur complement) gives the Fisher information

    J = sum_c L_c^T Q L_c / sigma_c^2,   Q = Psi^T Psi - Psi^T Phi (Phi^T Phi)^-1 Phi^T Psi  (2R, 2R),

``Cov(omega, zeta) >= T J^-1 T^T`` with ``T = d(omega, zeta) / d(alpha, wd)``.
Every channel is one (2R, 2R) block: cost O(m R^2 + C R^3), so thousands of
candidate channels are cheap (:mod:`.layouts`).

The amplitudes come from the planning model's modes: mass-normalised shapes
``phi``, damping ratios ``phi_r^T C phi_r / (2 omega_r)`` (exact for
proportional damping), modal initial conditions from ``initial`` items and
impulses (``qd0 = Phi^T I e``; a ``pulse`` counts as an impulse at its time
0). Displacement, velocity and acceleration channels have the amplitudes
of ``q``, ``dq/dt``, ``d2q/dt2``. Noise ``rms`` mode: ``sigma_c = ratio x
RMS`` of the clean channel (``beta_c^T Phi^T Phi beta_c / m``).

Fails (:class:`UserError`) for tests with a force acting during the record
(harmonic, random: not a free decay), ``proportional`` noise, or no noise.
Modes whose signal-to-noise energy ``sum_c |beta_cr|^2 m / (2 sigma_c^2)``
is below :data:`VISIBLE` are left out (reported as not visible).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from structbench.harness.excitation import Impulse, Initial
from structbench.harness.test_entries import TestSpec
from structbench.models import ModalModel, Model, Structure
from structbench.models.channels import Channel
from structbench.models.errors import UserError

VISIBLE = 25.0  # least summed signal-to-noise energy of a mode to be planned for
MAX_MODES = 30
ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}


@dataclass(frozen=True)
class Decay:
    """Modes of a free decay: ``omega``, ``zeta`` (R,), modal displacement
    amplitudes ``A``, ``B`` (R,) of ``q_r = exp(-alpha t)(A cos + B sin)``, shapes
    at the model DOF (n, R), and the samples ``dt`` s, ``m``."""

    omega: np.ndarray
    zeta: np.ndarray
    A: np.ndarray
    B: np.ndarray
    shapes: np.ndarray
    dt: float
    m: int

    @property
    def alpha(self) -> np.ndarray:
        return self.zeta * self.omega

    @property
    def wd(self) -> np.ndarray:
        return self.omega * np.sqrt(1 - self.zeta**2)


def model_modes(model: Model, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``omega`` (R,) rad/s, ``zeta`` (R,), mass-normalised shapes (n, R) of the
    lowest ``count`` flexible modes (rigid-body modes dropped)."""
    if isinstance(model, ModalModel):
        order = np.argsort(model.omega)[:count]
        return model.omega[order], model.zeta[order], model.shapes[:, order]
    rigid = 6
    found = model.modes(min(model.n_dof, count + rigid))
    keep = np.flatnonzero(found.omega > 0)[:count]
    phi, omega = found.shapes[:, keep], found.omega[keep]
    C = model.damping()
    zeta = np.einsum("ir,ir->r", phi, np.asarray(C @ phi)) / (2 * omega)
    return omega, zeta, phi


def decay(model: Model, test: TestSpec) -> Decay:
    """The free decay of ``test`` on ``model`` (modes below 0.8 x Nyquist)."""
    if test.noise.mode != "rms":
        raise UserError("modal planning needs noise mode 'rms' (white noise of constant level)", field="noise")
    nyquist = np.pi / test.dt
    omega, zeta, phi = model_modes(model, MAX_MODES)
    keep = (omega < 0.8 * nyquist) & (zeta < 1)
    omega, zeta, phi = omega[keep], zeta[keep], phi[:, keep]
    q0, qd0 = np.zeros(omega.size), np.zeros(omega.size)
    for item in test.excitation:
        if isinstance(item, Impulse):
            qd0 += item.impulse * phi[model.dof_index(item.node, item.direction)]
        elif isinstance(item, Initial) and isinstance(model, Structure):
            e = np.zeros(model.n_dof)
            j = model.dof_index(item.node, item.direction)
            M = model.mass()
            e[j] = item.displacement
            q0 += phi.T @ (M @ e)
            e[j] = item.velocity
            qd0 += phi.T @ (M @ e)
        else:
            raise UserError(f"modal planning needs a free decay (impulse or initial conditions); test "
                            f"{test.group!r} has a {item.kind} excitation", field="excitation")
    wd = omega * np.sqrt(1 - zeta**2)
    return Decay(omega, zeta, q0, (qd0 + zeta * omega * q0) / wd, phi, test.dt, test.n_samples)


def modal_channels(test: TestSpec) -> list[Channel]:
    """The channels the modal identifier uses (``quantity="auto"``): one per
    sensor location, its displacement, else velocity, else acceleration."""
    best: dict[tuple[int, str], Channel] = {}
    for c in test.channels:
        if c.quantity in ORDER and (c.dof not in best or ORDER[c.quantity] < ORDER[best[c.dof].quantity]):
            best[c.dof] = c
    return [best[d] for d in sorted(best)]


def amplitudes(d: Decay, rows: np.ndarray, orders: np.ndarray) -> np.ndarray:
    """``beta`` (C, R, 2): (a, b) per channel and mode for shapes rows ``rows``
    (C,) and time-derivative orders ``orders`` (C,) (0 displacement, 1 velocity, 2 acceleration)."""
    a, b = d.shapes[rows] * d.A, d.shapes[rows] * d.B  # (C, R)
    al, wd = d.alpha, d.wd
    for k in range(int(orders.max(initial=0))):
        da, db = -al * a + wd * b, -al * b - wd * a
        step = (orders > k)[:, None]
        a, b = np.where(step, da, a), np.where(step, db, b)
    return np.stack([a, b], axis=2)


def grams(d: Decay) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``Phi^T Phi``, ``Psi^T Phi`` and ``Psi^T Psi`` (2R, 2R) of the module docstring."""
    t = np.arange(d.m) * d.dt
    env = np.exp(-np.outer(t, d.alpha))
    phase = np.outer(t, d.wd)
    Phi = np.empty((d.m, 2 * d.omega.size))
    Phi[:, 0::2], Phi[:, 1::2] = env * np.cos(phase), env * np.sin(phase)
    Psi = t[:, None] * Phi
    return Phi.T @ Phi, Psi.T @ Phi, Psi.T @ Psi


def bases(d: Decay) -> tuple[np.ndarray, np.ndarray]:
    """``Phi^T Phi / m`` and ``Q`` (2R, 2R) of the module docstring."""
    PP, SP, SS = grams(d)
    Q = SS - SP @ la.solve(PP, SP.T, assume_a="pos")
    return PP / d.m, 0.5 * (Q + Q.T)


def cached_bases(d: Decay, cache: dict[bytes, tuple[np.ndarray, np.ndarray]] | None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`bases` of ``d``, kept in ``cache`` (if given) under its modes'
    ``omega``, ``zeta``, ``dt`` and ``m`` (all the bases depend on)."""
    if cache is None:
        return bases(d)
    key = d.omega.tobytes() + d.zeta.tobytes() + np.array([d.dt, d.m], dtype=float).tobytes()
    if key not in cache:
        cache[key] = bases(d)
    return cache[key]


def channel_sigma(beta: np.ndarray, ratio: np.ndarray, gram: np.ndarray) -> np.ndarray:
    """Noise ``sigma_c`` (C,) = ``ratio`` (C,) x RMS of the clean channel, from
    its amplitudes ``beta`` (C, R, 2) and ``gram`` = ``Phi^T Phi / m``."""
    flat = beta.reshape(beta.shape[0], -1)
    return ratio * np.sqrt(np.maximum(np.einsum("ci,ij,cj->c", flat, gram, flat), 0.0))


def channel_information(beta: np.ndarray, sigma: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Per channel the information ``L_c^T Q L_c / sigma_c^2`` (C, 2R, 2R) on
    ``(alpha_r, wd_r)`` interleaved (channels without noise: zero); ``L_c``'s
    2 x 2 blocks keep it O(C R^2)."""
    C, R = beta.shape[:2]
    a, b = beta[..., 0], beta[..., 1]
    blocks = np.empty((C, R, 2, 2))  # [c, r, basis (g, h), parameter (alpha, wd)]
    blocks[:, :, 0, 0], blocks[:, :, 1, 0] = -a, -b
    blocks[:, :, 0, 1], blocks[:, :, 1, 1] = b, -a
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(sigma > 0, 1.0 / sigma**2, 0.0)
    Qb = Q.reshape(R, 2, R, 2)
    left = np.einsum("crai,rasb->crisb", blocks, Qb)
    info = np.einsum("crisb,csbj->crisj", left, blocks)
    return info.reshape(C, 2 * R, 2 * R) * w[:, None, None]


def visible(d: Decay, beta: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Modes (R,) bool whose summed signal-to-noise energy reaches :data:`VISIBLE`."""
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = np.where(sigma[:, None] > 0, np.sum(beta**2, axis=2) * d.m / 2 / sigma[:, None] ** 2, 0.0)
    return snr.sum(axis=0) >= VISIBLE


def omega_zeta_covariance(d: Decay, J: np.ndarray) -> np.ndarray:
    """Covariance (R, 2, 2) of ``(omega_r, zeta_r)`` from the information ``J``
    (2R, 2R) on ``(alpha, wd)``: ``T J^-1 T^T`` per mode. ``J`` is inverted
    equilibrated, ``J^-1 = D (D J D)^-1 D`` with ``D = diag(J)^-1/2`` (its
    entries span many decades between a slow, long-lived mode and a fast
    one)."""
    diag = np.diag(J)
    scale = np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)), 1.0)
    cov = scale[:, None] * la.inv(scale[:, None] * J * scale[None, :]) * scale[None, :]
    al, wd, w = d.alpha, d.wd, d.omega
    T = np.zeros((w.size, 2, 2))
    T[:, 0, 0], T[:, 0, 1] = al / w, wd / w
    T[:, 1, 0], T[:, 1, 1] = wd**2 / w**3, -al * wd / w**3
    R = w.size
    blocks = np.stack([cov[2 * r:2 * r + 2, 2 * r:2 * r + 2] for r in range(R)])
    return np.einsum("rij,rjk,rlk->ril", T, blocks, T)


@dataclass(frozen=True)
class Observed:
    """A free decay as the modal channels see it: its visible modes ``d``,
    the channels, their shape rows and derivative orders (C,), amplitudes
    ``beta`` (C, R, 2) and noise ``sigma`` (C,), and the frequencies (rad/s)
    of the modes left out as not visible."""

    d: Decay
    channels: list[Channel]
    rows: np.ndarray
    orders: np.ndarray
    beta: np.ndarray
    sigma: np.ndarray
    hidden: np.ndarray


def observe(model: Model, test: TestSpec) -> Observed:
    """The free decay ``test`` on ``model`` through its modal channels
    (:class:`Observed`); fails without motion sensors or sensor noise."""
    d = decay(model, test)
    chans = modal_channels(test)
    if not chans:
        raise UserError(f"test {test.group!r} has no motion sensor", field="sensors")
    rows = np.array([model.dof_index(*c.dof) for c in chans])
    orders = np.array([ORDER[c.quantity] for c in chans])
    ratio = np.array([test.noise.ratio(c.quantity) for c in chans])
    if not ratio.any():
        raise UserError("the test has no sensor noise on its motion channels: the bounds are zero", field="noise")
    beta = amplitudes(d, rows, orders)
    sigma = channel_sigma(beta, ratio, bases(d)[0])
    seen = visible(d, beta, sigma)
    kept = Decay(d.omega[seen], d.zeta[seen], d.A[seen], d.B[seen], d.shapes[:, seen], d.dt, d.m)
    return Observed(kept, chans, rows, orders, beta[:, seen], sigma, d.omega[~seen])


def free_decay_bounds(model: Model, test: TestSpec) -> dict:
    """Predicted ``modes`` (omega, zeta and their standard errors, SI) and
    the modes left out as not visible, for ``test`` on ``model``."""
    o = observe(model, test)
    _, Q = bases(o.d)
    cov = omega_zeta_covariance(o.d, channel_information(o.beta, o.sigma, Q).sum(axis=0))
    modes = [{"omega": float(w), "predicted_omega_std": float(np.sqrt(c[0, 0])), "zeta": float(z),
              "predicted_zeta_std": float(np.sqrt(c[1, 1]))} for w, z, c in zip(o.d.omega, o.d.zeta, cov)]
    return {"modes": modes, "not_visible": [float(w) for w in o.hidden], "channels": [c.name for c in o.channels]}
