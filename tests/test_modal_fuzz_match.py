"""The held-out profile's scorer (benchmarks/modal_fuzz.py ``match``):
reported modes matched one to one to the true ones, as many admissible
pairs as there can be, then the nearest."""
from __future__ import annotations

import modal_fuzz
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st


def test_two_reported_modes_over_two_true_ones_are_both_matched():
    """Held-out seed 1,006,080 (random response, 12 sensors): true modes at
    7.323 and 7.766 rad/s, reported 7.360 +- 0.198 and 7.481 +- 0.057. The
    nearest-first matching gave 7.323 to 7.360 and found 7.481 nearest to a
    taken mode: invented, although 7.766 is within 5 % of it."""
    w, se = np.array([7.3602, 7.4808, 35.4745]), np.array([0.1979, 0.0568, 0.1331])
    omega = np.array([3.5147, 7.3226, 7.7658, 35.0925])
    assert modal_fuzz.match(w, se, omega) == {1: 0, 2: 1, 3: 2}
    assert modal_fuzz.match_nearest(w, se, omega) == {1: 0, 3: 2}


def test_a_mode_far_from_every_true_one_or_a_second_on_one_is_invented():
    """1,006,369: 4.223 +- 0.077 rad/s between true 3.814 and 4.650 (over
    5 % and 4 se from both); and two reported modes near one lone true
    mode: one of them is left out."""
    assert modal_fuzz.match(np.array([4.223]), np.array([0.077]), np.array([3.814, 4.650, 8.724])) == {}
    assert len(modal_fuzz.match(np.array([10.0, 10.2]), np.array([0.01, 0.01]), np.array([10.1, 30.0]))) == 1


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_matching_is_one_to_one_admissible_and_never_smaller_than_the_greedy_one(seed: int) -> None:
    """Random reported and true modes: every pair is within ``max(5 %, 4
    se)``, no mode is used twice, and the assignment matches at least as
    many as the nearest-first rule (a maximum matching)."""
    rng = np.random.default_rng(seed)
    omega = np.sort(rng.uniform(1.0, 2.0, rng.integers(1, 6)))
    w = rng.uniform(0.9, 2.1, rng.integers(0, 6))
    se = rng.uniform(0.0, 0.05, w.size)
    taken = modal_fuzz.match(w, se, omega)
    assert len(set(taken.values())) == len(taken)
    for j, i in taken.items():
        assert abs(w[i] - omega[j]) <= max(0.05 * omega[j], 4 * se[i])
    assert len(taken) >= len(modal_fuzz.match_nearest(w, se, omega))
