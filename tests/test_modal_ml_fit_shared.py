"""The free-decay fits' shared work (identifier/modal/ml_fit.py): a basis
sliced from a larger one, a caller's VarPro and the in-place solver give
the same numbers, bit for bit, as computing each afresh."""
from __future__ import annotations

import numpy as np

from structbench.identifier.modal.close_pairs.free_decay_fit import basis
from structbench.identifier.modal.ml_fit import Solver, VarPro, fit_poles, noise_levels, select
from structbench.identifier.modal.refine import pole_bounds

DT = 0.01
POLES = np.array([-0.3 + 9.0j, -0.5 + 14.0j, -0.2 + 23.0j, -0.8 + 31.0j])  # 1/s


def _record(seed: int, n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    """Times (n,) s and three channels (n, 3) of a free decay of POLES in 1 % noise, in units of their noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    y = basis(t, POLES)[:, 2:] @ rng.standard_normal((2 * POLES.size, 3))
    y += 0.01 * np.std(y, axis=0) * rng.standard_normal(y.shape)
    return t, y / noise_levels(t, y, basis(t, POLES))


def test_select_is_the_basis_of_the_chosen_poles():
    t = np.arange(5000) * DT
    whole = basis(t, POLES)
    for idx in ([2], [0, 3], [3, 1, 2], []):
        assert np.array_equal(select(whole, np.array(idx)), basis(t, POLES[idx]))
    assert np.array_equal(whole[:1234], basis(t[:1234], POLES))  # a stretch's rows of a longer basis


def test_solver_in_place_gives_the_same_numbers():
    t, z = _record(0)
    b = basis(t, POLES)
    c, r = Solver(b).coefficients(z)
    work = b.copy()
    solver = Solver(work, overwrite=True)
    c2, r2 = solver.coefficients(z)
    assert np.array_equal(c, c2) and np.array_equal(r, r2)
    assert solver.b is work and np.array_equal(work, b / solver.scale)  # scaled in place, no copy


def test_a_shared_varpro_fits_the_same_and_remembers_the_cost():
    t, z = _record(1)
    free, fixed = POLES[1:3] * (1 + 0.01j), POLES[[0, 3]]
    lower, upper = pole_bounds(free, fixed, DT)
    alone = fit_poles([t], [z], fixed, free, lower, upper)
    fit = VarPro([t], [z], fixed, [select(basis(t, POLES), np.array([0, 3]))])
    shared = fit_poles([t], [z], fixed, free, lower, upper, fit=fit)
    for a, b in zip(alone, shared):
        assert np.array_equal(a, b, equal_nan=True)
    assert alone[2]  # converged
    end = np.column_stack([shared[0].real, shared[0].imag]).ravel()
    evaluated = len(fit.costs)
    assert fit.cost(end) == VarPro([t], [z], fixed).state(end)[0]  # the same f as a fresh evaluation
    assert len(fit.costs) == evaluated  # from memory: no state computed again
    assert abs(shared[0] - POLES[1:3]).max() < 0.01
