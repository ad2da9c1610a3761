"""experiments.lfd_demonstration.boundaries: the hand's speed against a loop written out, boundaries moved to
known slow frames, the promises of the move on random periods (hypothesis), and the frames of periods against
a loop."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from experiments.lfd_demonstration.boundaries import hand_speed, in_periods, snap_to_slowest
from hog_jax.video import Periods


def test_hand_speed_is_the_windowed_mean_of_tracked_steps():
    rng = np.random.default_rng(0)
    hand = rng.normal(size=(12, 2)) * 5
    tracked = np.ones(12, bool)
    tracked[[4, 5, 6, 7]] = False
    got = hand_speed(hand, tracked, 3)
    for t in range(12):
        steps = [np.linalg.norm(hand[s] - hand[s - 1]) for s in range(t - 1, t + 2)
                 if 1 <= s < 12 and tracked[s] and tracked[s - 1]]
        expected = np.mean(steps) if len(steps) >= 1.5 else np.inf
        assert got[t] == pytest.approx(expected, rel=1e-12), t
    with pytest.raises(ValueError, match="tracked"):
        hand_speed(hand, tracked[:5], 3)


def test_boundaries_move_to_the_slowest_frames_in_their_windows():
    speed = np.full(60, 5.0)
    speed[[12, 27, 43, 52]] = [1.0, 0.3, 0.4, 0.2]  # one slow frame in each boundary's window
    speed[[20, 30, 38]] = 0.1  # slower, but outside every window: [10, 17], [22, 29], [40, 47], [47, 54]
    periods = Periods(np.array([15, 45]), np.array([25, 50]), np.zeros(60, bool))
    got = snap_to_slowest(periods, speed, before=5, after=2)
    np.testing.assert_array_equal(got.pickup, [12, 43])
    np.testing.assert_array_equal(got.putdown, [28, 53])  # the last held frames 27 and 52
    np.testing.assert_array_equal(np.flatnonzero(got.in_hand), np.r_[12:28, 43:53])


def test_a_window_without_a_speed_keeps_its_boundary():
    speed = np.full(30, np.inf)
    periods = Periods(np.array([10]), np.array([20]), np.zeros(30, bool))
    got = snap_to_slowest(periods, speed, before=4, after=1)
    assert (got.pickup[0], got.putdown[0]) == (10, 20)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 4), st.integers(0, 8), st.integers(0, 3))
def test_moved_periods_stay_ordered_inside_their_share_and_no_faster(seed, n, before, after):
    rng = np.random.default_rng(seed)
    T = 120
    cuts = np.sort(rng.choice(np.arange(1, T), size=2 * n, replace=False))
    starts, stops = cuts[0::2], cuts[1::2]
    speed = np.where(rng.random(T) < 0.1, np.inf, rng.random(T))
    got = snap_to_slowest(Periods(starts, stops, np.zeros(T, bool)), speed, before, after)
    assert np.all(got.pickup < got.putdown)
    assert np.all(got.putdown[:-1] <= got.pickup[1:])
    for k in range(n):
        assert starts[k] - before <= got.pickup[k] <= starts[k] + after
        assert stops[k] - 1 - after <= got.putdown[k] - 1 <= stops[k] - 1 + before
        if np.isfinite(speed[starts[k]]) and got.pickup[k] != starts[k]:
            assert speed[got.pickup[k]] <= speed[starts[k]]


def test_in_periods_marks_the_frames_of_each_period():
    pickup, putdown = np.array([2, 7]), np.array([5, 8])
    expected = np.zeros(10, bool)
    for a, b in zip(pickup, putdown):
        for t in range(a, b):
            expected[t] = True
    np.testing.assert_array_equal(in_periods(pickup, putdown, 10), expected)
    assert not in_periods(np.zeros(0, int), np.zeros(0, int), 4).any()
