"""Noise-free responses of one campaign test, simulated from the planning model.

A plan is made before the test: the responses come from the model the user
postulates (the campaign's structure with its ``[parameters]``), not from
the FMU. Finite-element structures are simulated exactly (zero-order hold on
the test's communication step, as the FMU does); the sensor noise of each
channel follows the campaign's noise spec: ``rms`` mode
``sigma = ratio x RMS(clean channel)`` (constant in time), ``proportional``
``sigma_k = ratio x |x_k|``.

Fails (:class:`UserError`) for external FMUs (no model to plan with) and for
recorded or ground excitations of a modal model.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from structbench.harness.excitation import Impulse, Initial, force_dofs, forces
from structbench.harness.test_entries import TestSpec
from structbench.models import ModalModel, Model, Structure
from structbench.models.errors import UserError


@dataclass(frozen=True)
class Response:
    """Clean channels of one test: ``time`` (m,) s, ``signals`` channel name ->
    (m,) SI, ``sigma`` channel name -> (m,) noise standard deviation, and the
    channels themselves (``structbench.models.channels.Channel``) in order."""

    time: np.ndarray
    signals: dict[str, np.ndarray]
    sigma: dict[str, np.ndarray]
    channels: tuple


def noise_sigma(test: TestSpec, quantity: str, clean: np.ndarray) -> np.ndarray:
    """Noise standard deviation per sample (m,) of a channel of ``quantity``
    whose noise-free samples are ``clean`` (m,)."""
    ratio = test.noise.ratio(quantity)
    if test.noise.mode == "proportional":
        return ratio * np.abs(clean)
    return np.full(clean.shape, ratio * np.sqrt(np.mean(clean**2)))


def initial_state(model: Structure, items: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Initial displacement and velocity (n,) of a finite-element model from
    ``initial`` items and ``initial-velocity`` impulses (``v0 = M^-1 I e``)."""
    u0, v0 = np.zeros(model.n_dof), np.zeros(model.n_dof)
    impulse = np.zeros(model.n_dof)
    for item in items:
        if isinstance(item, Initial):
            j = model.dof_index(item.node, item.direction)
            u0[j] += item.displacement
            v0[j] += item.velocity
        elif isinstance(item, Impulse) and item.method == "initial-velocity":
            impulse[model.dof_index(item.node, item.direction)] += item.impulse
    if impulse.any():
        v0 += la.solve(model.mass().toarray(), impulse, assume_a="pos")
    return u0, v0


def simulate_test(model: Model, test: TestSpec, repetition: int = 0) -> Response:
    """Noise-free channels of ``test`` on ``model`` (exact ZOH; load cells see
    the applied force). Dense state space: for models of up to a few hundred DOF."""
    if not isinstance(model, (Structure, ModalModel)):
        raise UserError("planning needs the structure's model; an external FMU has none", field="structure")
    items = test.commanded_excitation(repetition)
    dofs = force_dofs(items)
    n_steps = (test.n_samples - 1) * test.substeps + 1
    grid = np.arange(n_steps) * test.step
    f_dofs = forces(items, dofs, grid, test.dt) if dofs else np.zeros((n_steps, 0))
    f = np.zeros((n_steps, model.n_dof))
    for j, d in enumerate(dofs):
        f[:, model.dof_index(*d)] += f_dofs[:, j]
    ss = model.state_space()
    if isinstance(model, ModalModel):
        x0 = np.zeros(ss.n_state)
        for item in items:
            if isinstance(item, Impulse) and item.method == "initial-velocity":
                x0[model.n_modes:] += item.impulse * model.shapes[model.dof_index(item.node, item.direction)]
            elif isinstance(item, Initial):
                raise UserError("initial conditions are not supported on a modal model", field="excitation")
    else:
        x0 = np.concatenate(initial_state(model, items))
    out = ss.simulate(f, test.step, x0)
    sub = slice(None, None, test.substeps)
    signals, sigma = {}, {}
    for c in test.channels:
        if c.quantity == "force":
            x = f[sub, model.dof_index(*c.dof)]
        else:
            x = out[c.quantity][sub, model.dof_index(*c.dof)]
        signals[c.name] = x
        sigma[c.name] = noise_sigma(test, c.quantity, x)
    return Response(np.arange(test.n_samples) * test.dt, signals, sigma, tuple(test.channels))
