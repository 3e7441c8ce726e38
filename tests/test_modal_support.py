"""The modal method's support tests (identifier/modal/support.py) on
candidates whose verdict follows from closed forms: a true mode's frequency
error over ``N`` decay times of a random response is about ``1 / sqrt(N)``
of its half-power half-bandwidth ``zeta omega``; a noise pole scatters over
more than its own bandwidth. In a free response a pole must carry more
energy than the sensor noise's largest chance fit (identifier/modal/decay_snr.py):
its matched-filter statistic is chi-square on noise alone, the mode's
energy per noise sample otherwise."""
from __future__ import annotations

import numpy as np
import pytest

from structbench.identifier.modal.decay_snr import screen, statistics
from structbench.identifier.modal.support import Verdict, judge


def _verdict(omega, zeta, omega_std, stable, length=2000.0):
    k = len(omega)
    shapes = np.eye(max(k, 2), k, dtype=complex)  # orthogonal shapes: no duplicates
    omega, zeta, omega_std = (np.asarray(v, dtype=float) for v in (omega, zeta, omega_std))
    return judge(omega, zeta, omega_std, 0.1 * zeta, np.zeros(k), np.full(k, 20), np.asarray(stable, float),
                 shapes, length, False, 8)


def test_a_heavily_damped_mode_stable_at_few_orders_is_judged_within_its_bandwidth():
    """zeta 0.06 at 10 rad/s over 2000 s: N = 1200 decay times, so a true
    mode's omega_std is about zeta omega / sqrt(N) = 0.0017 zeta omega;
    the jackknife and order scatter of a random response give it 0.012
    omega = 0.2 zeta omega (100,125 of the tuning seeds: 0.011-0.016
    omega at zeta 0.06-0.08, stable at 31-38 % of the orders). Over 0.5 %
    of omega, but a fifth of its bandwidth: reported. A noise pole of the
    same scatter and stability with zeta 0.005 scatters over 2.4 of its
    bandwidths: rejected. Stable at most orders, both are judged by the
    other tests only."""
    v = _verdict([10.0, 20.0], [0.06, 0.005], [0.12, 0.24], [0.4, 0.4])
    assert v.keep.tolist() == [True, False]
    assert "stable at 40%" in v.reasons[1]
    v = _verdict([10.0, 20.0], [0.06, 0.005], [0.12, 0.24], [0.6, 0.6])
    assert v.keep.tolist() == [True, True]


def test_the_absolute_floor_still_admits_precise_light_modes():
    """zeta 0.002 (bandwidth share 0.001 omega) but omega_std 0.003 omega,
    under the 0.005 floor: a weak aliased mode in a long record, kept."""
    v = _verdict([10.0], [0.002], [0.03], [0.35])
    assert v.keep.tolist() == [True]


def test_matched_filter_statistic_of_a_noise_pole_is_chi_square():
    """White noise alone (3 channels, 2000 samples), a pole fitted at an
    arbitrary frequency: over 300 draws the statistic's mean and variance
    are chi-square(6)'s, 6 and 12 (within 4 standard errors of each)."""
    rng = np.random.default_rng(5)
    values = np.array([statistics([rng.standard_normal((3, 2000))], 0.01, np.array([7.3]), np.array([0.002]))[0][0]
                       for _ in range(300)])
    assert abs(values.mean() - 6.0) < 4 * np.sqrt(12.0 / 300)
    assert abs(values.var() - 12.0) < 4 * np.sqrt((12 * 6 * 10 - 12.0**2) / 300)  # chi2(6): mu_4 = 12 k (k + 4)


def test_matched_filter_statistic_of_a_mode_is_its_energy_over_the_noise():
    """A decay ``A e^(-sigma t) cos(omega_d t)`` on one channel with noise s:
    the statistic is ``A^2 / (4 sigma dt s^2)`` (its energy per noise
    sample) within 3 %, mean over 20 draws; with the true mode beside it, a
    noise pole is refused (free response) and the mode kept."""
    dt, n, omega, zeta, A, s = 0.01, 20000, 12.0, 0.01, 1.0, 0.05
    t = np.arange(n) * dt
    clean = A * np.exp(-zeta * omega * t) * np.cos(omega * np.sqrt(1 - zeta**2) * t)
    rng = np.random.default_rng(6)
    draws = [statistics([(clean + s * rng.standard_normal(n))[None]], dt, np.array([omega]), np.array([zeta]))
             for _ in range(20)]
    expected = A**2 / (4 * zeta * omega * dt * s**2)
    assert np.mean([d[0][0] for d in draws]) == pytest.approx(expected, rel=0.03)
    y = [(clean + s * rng.standard_normal(n))[None]]
    v = screen(y, dt, np.array([omega, 31.7]), np.array([zeta, 0.001]),
               Verdict(np.array([True, True]), ["", ""]), [])
    assert v.keep.tolist() == [True, False]
    assert "matched-filter" in v.reasons[1]



def test_a_close_pair_the_record_does_not_resolve_is_left_to_the_pair_tests():
    """Two modes 0.01 % apart (1.09144 and 1.09154 rad/s, the membrane's
    pair) in 100 s of a free decay: their columns are nearly one, so
    each alone explains almost nothing beyond the other; both are kept
    (their separation is under 2 pi / T), while a noise pole elsewhere is
    still refused."""
    dt, n = 0.01, 10001
    t = np.arange(n) * dt
    w, z = np.array([1.09144, 1.09154]), np.array([0.001, 0.001])
    y = (np.exp(-0.001 * 1.09144 * t) * np.cos(1.09144 * t) + np.exp(-0.001 * 1.09154 * t) * np.sin(1.09154 * t)
         + 0.1 * np.random.default_rng(8).standard_normal(n))[None]
    v = screen([y], dt, np.r_[w, 3.3], np.r_[z, 0.001], Verdict(np.ones(3, bool), ["", "", ""]), [])
    assert v.keep.tolist() == [True, True, False]
