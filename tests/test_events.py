"""hog_jax.events (LfD 2009 §III-D): the temporal filter and the pick-up / put-down events on
hand-made "object in hand" sequences whose events are known, and a brute-force check of the filter."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hog_jax.video import filter_in_hand, hold_undecided, periods_in_hand


def _runs(*pairs):
    """A sequence from (value, length) runs."""
    return np.concatenate([np.full(n, bool(v)) for v, n in pairs])


def test_known_events_survive_dropouts_and_spikes():
    """Two actions at 25 fps, the second with a one-frame dropout; a two-frame spurious detection; a
    short (0.6 s) period: two events of each kind, at the true frames."""
    seq = _runs((0, 10), (1, 40), (0, 8), (1, 1), (0, 12), (1, 20), (0, 1), (1, 25), (0, 10), (1, 15), (0, 9))
    res = periods_in_hand(seq, fps=25.0)
    assert list(res.pickup) == [10, 71] and list(res.putdown) == [50, 117]
    assert res.in_hand.sum() == 40 + 46 and res.in_hand.shape == seq.shape


def test_a_period_cut_by_the_end_of_the_recording_ends_there():
    res = periods_in_hand(_runs((0, 5), (1, 30)), fps=25.0)
    assert list(res.pickup) == [5] and list(res.putdown) == [35]


def test_undecided_frames_keep_the_last_decision():
    """A still hand (undecided frames) inside an action keeps it in hand, and one before the first
    decision is "no object"; spurious detections while the hand is still are ignored."""
    found = _runs((1, 3), (0, 10), (1, 30), (0, 5), (1, 15), (0, 12))
    decided = _runs((0, 3), (1, 12), (0, 6), (1, 20), (0, 10), (1, 24))
    res = periods_in_hand(found, fps=25.0, decided=decided)
    assert list(res.pickup) == [13] and list(res.putdown) == [63]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.booleans()), min_size=1, max_size=40))
def test_hold_undecided_equals_a_loop(pairs):
    found, decided = np.array(pairs).T
    want, last = [], False
    for f, d in zip(found, decided):
        last = f if d else last
        want.append(last)
    np.testing.assert_array_equal(hold_undecided(found, decided), np.array(want, bool))


def _brute_close_open(x, r):
    """The closing then opening with explicit min / max over windows, outside = False."""
    def erode(a):
        return np.array([all(a[j] if 0 <= j < len(a) else False for j in range(i - r, i + r + 1)) for i in range(len(a))])

    def dilate(a):
        return np.array([any(a[j] if 0 <= j < len(a) else False for j in range(i - r, i + r + 1)) for i in range(len(a))])

    padded = np.concatenate([np.zeros(r, bool), x, np.zeros(r, bool)])
    return dilate(erode(erode(dilate(padded))))[r:len(padded) - r]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=60), st.integers(0, 3))
def test_filter_equals_brute_force(seq, radius):
    x = np.array(seq)
    np.testing.assert_array_equal(filter_in_hand(x, radius), _brute_close_open(x, radius) if radius else x)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="in_hand: a recording of 10 frames is shorter"):
        periods_in_hand(np.ones(10, bool), fps=25.0)
    with pytest.raises(ValueError, match="in_hand: expected a boolean"):
        filter_in_hand(np.array([0, 2, 1]))
    with pytest.raises(ValueError, match="fps: must be > 0"):
        periods_in_hand(np.ones(30, bool), fps=0.0)
    with pytest.raises(ValueError, match="radius: must be >= 0"):
        filter_in_hand(np.ones(3, bool), radius=-1)
