"""Two unresolved modes whose shapes agree within the shapes' standard
errors are one mode seen twice (identifier/modal/support.py,
``same_shape``): the chi-square of the difference of two noisy estimates
of one real shape, after fitting their scale, follows chi-square(m - 1)
(Monte Carlo here); two different shapes known this well exceed it."""
from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from structbench.identifier.modal.support import SAME_SHAPE, judge, same_shape


def _estimates(rng: np.random.Generator, shape: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """A noisy complex estimate (m,) of a real ``shape`` with a random complex scale."""
    return (shape + noise * rng.standard_normal(shape.size)) * 3.0 * np.exp(2j * np.pi * rng.random())


def test_two_estimates_of_one_shape_are_told_apart_at_the_chi_square_rate():
    """800 pairs of estimates of one 8-entry shape, per-entry errors 0.02-0.1
    (known), with random complex scales: told apart in SAME_SHAPE (1 %) of
    the pairs (measured 1.0 % and 0.6 % on two streams); the binomial 99.9 %
    upper bound for 800 draws is 2.5 %; none told apart would mean a test
    looser than its chi-square."""
    rng = np.random.default_rng(7)
    m, draws = 8, 800
    shape = np.array([1.0, 0.8, -0.6, 0.4, 0.9, -0.3, 0.5, -0.7])
    noise = np.linspace(0.02, 0.1, m)
    apart = 0
    for _ in range(draws):
        shapes = np.column_stack([_estimates(rng, shape, noise), _estimates(rng, shape, noise)])
        apart += not same_shape(shapes, np.column_stack([noise, noise]))[0, 1]
    assert apart / draws < 0.025
    assert apart > 0  # the bound is the chi-square's 1 % point, not a blanket pass
    assert np.isclose(chi2.isf(SAME_SHAPE, m - 1), 18.48, rtol=1e-3)


def test_two_different_shapes_known_well_are_not_one():
    """Shapes of MAC 0.6 with errors 0.02 per entry differ by chi-square in the
    hundreds: not one; with errors 0.5 per entry they are within the noise."""
    a = np.array([1.0, 0.8, -0.6, 0.4, 0.9, -0.3], dtype=complex)
    b = np.array([1.0, -0.2, 0.5, 0.9, 0.1, 0.6], dtype=complex)
    shapes = np.column_stack([a, b])
    assert not same_shape(shapes, np.full((6, 2), 0.02))[0, 1]
    assert same_shape(shapes, np.full((6, 2), 0.5))[0, 1]
    assert not same_shape(shapes, np.full((6, 2), np.nan))[0, 1]  # errors unknown: no verdict
    assert not same_shape(shapes[:1], np.full((1, 2), 0.5))[0, 1]  # one sensor: nothing to compare


def test_a_noisy_second_estimate_of_a_mode_is_a_duplicate():
    """Two poles 0.03 rad/s apart at 82.9 rad/s (zeta 0.0025: half-bandwidths
    0.2 rad/s, unresolved), the second's shape a noisy estimate of the
    first's with MAC under 0.8 (the MAC test alone keeps both): with the
    shapes' errors stated, the second is a duplicate in a random response;
    in a free response the close-pair fit decides (both kept here)."""
    rng = np.random.default_rng(3)
    shape = np.array([1.0, 0.5, -0.4, 0.3, -0.2])
    noise = np.full(5, 0.35)
    noisy = shape + noise * rng.standard_normal(5)
    shapes = np.column_stack([shape, noisy]).astype(complex)
    mac = abs(np.vdot(shape, noisy)) ** 2 / (np.vdot(shape, shape).real * np.vdot(noisy, noisy).real)
    assert mac < 0.8
    args = (np.array([82.90, 82.87]), np.array([0.0025, 0.0024]), np.array([0.03, 0.05]), np.array([1e-4, 2e-4]),
            np.zeros(2), np.array([15, 13]), np.array([0.6, 0.6]), shapes, 971.0, False, 8)
    assert judge(*args).keep.tolist() == [True, True]
    v = judge(*args, shape_std=np.column_stack([np.full(5, 0.02), noise]))
    assert v.keep.tolist() == [True, False]
    assert "duplicate" in v.reasons[1]
    free = args[:9] + (True,) + args[10:]  # a free response: the pair is left to the close-pair fit
    assert judge(*free, shape_std=np.column_stack([np.full(5, 0.02), noise])).keep.tolist() == [True, True]
