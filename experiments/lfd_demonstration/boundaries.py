"""Pick-up and put-down moved to the hand's slowest moment near the boundaries the "object in hand"
classifier found (LfD 2009 §III-D's events, refined by the hand's motion).

Why: a hand grasps an object where it has slowed to a stop at it, and lets it go where it stops again
before it withdraws. The hand-window classifier (`in_hand`) calls a frame "held" only once the held
object looks held, after it has left the table, and "empty" once it stands on it again: on the validation
recordings of the paper preset (seed 1) the object had moved 2 px only 4-13 frames (25 fps) after the
renderer's pick-up and was within 2 px of its final place 3-10 frames before the put-down, and the
classifier's pick-ups came up to 27 frames late, its put-downs early. Each pick-up therefore moves to the
frame where the tracked hand is slowest from `SEARCH_BEFORE_S` before it to `SEARCH_AFTER_S` after it,
and each put-down (its last held frame) likewise from `SEARCH_AFTER_S` before to `SEARCH_BEFORE_S` after;
a boundary never crosses the midpoint between two periods. Chosen on the validation recordings (quick
preset seeds 1-3, 15 events at 10 fps / paper preset seed 1, 10 events at 25 fps; mean |error|, frames,
pick-up / put-down): without 2.8 / 3.9 and 8.9 / 14.0; with 1.7 / 2.3 and 3.5 / 9.4 (the rest of the
paper preset's put-down error is one put-down 90 frames early, a period the classifier lost); searching
0.6-1.2 s back and 0.1 s forward with a smoothing of 0.08-0.12 s gave 1.6-1.9 / 2.3-2.7 and 3.5-4.4 /
9.1-10.0, a forward search of 0.2-0.3 s or a smoothing of 0.2 s worse put-downs.
"""
from __future__ import annotations

import numpy as np

from hog_jax.video import Periods
from lfd_common import as_array, check_int

SEARCH_BEFORE_S = 0.8  # s: how far before a pick-up (after a put-down) the slowest frame is looked for
SEARCH_AFTER_S = 0.1   # s: and how far after a pick-up (before a put-down)
SPEED_SMOOTH_S = 0.12  # s: the hand's speed is averaged over this long a window (at least one frame)


def hand_speed(hand: np.ndarray, tracked: np.ndarray, window: int) -> np.ndarray:
    """(T,) the hand's speed, px per frame: |hand[t] - hand[t - 1]| where both frames are tracked, averaged
    over the `window` (>= 1) frames centred on t; inf where fewer than half of them have a speed (frame 0
    has none). hand (T, 2), tracked (T,) bool."""
    positions = as_array(hand, "hand", shape=("T", 2))
    measured = as_array(tracked, "tracked", shape=(positions.shape[0],), dtype=bool)
    width = check_int(window, "window", min_value=1)
    step = np.zeros(positions.shape[0])
    step[1:] = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    valid = np.zeros(positions.shape[0], bool)
    valid[1:] = measured[1:] & measured[:-1]
    kernel = np.ones(width)
    total = np.convolve(np.where(valid, step, 0.0), kernel, "same")
    count = np.convolve(valid.astype(float), kernel, "same")
    return np.where(count >= 0.5 * width, total / np.maximum(count, 1.0), np.inf)


def _slowest(speed: np.ndarray, lo: int, hi: int, keep: int) -> int:
    """The frame of the lowest speed in [lo, hi] (inclusive); `keep` where the range is empty or all inf."""
    if hi < lo or not np.isfinite(speed[lo:hi + 1]).any():
        return keep
    return lo + int(np.argmin(speed[lo:hi + 1]))


def snap_to_slowest(periods: Periods, speed: np.ndarray, before: int, after: int) -> Periods:
    """Each period's pick-up moved to the slowest frame (`speed` (T,), `hand_speed`) in [pickup - before,
    pickup + after], its last held frame to the slowest in [last - after, last + before], both within the
    period's share of the frames (up to the midpoints to its neighbours; the pick-up before the last held
    frame, the put-down after the pick-up). before, after >= 0 frames. The returned `Periods` has the moved
    frames and its `in_hand` marks them."""
    rate = as_array(speed, "speed", ndim=1, finite=False)
    back, ahead = check_int(before, "before", min_value=0), check_int(after, "after", min_value=0)
    starts, stops = np.asarray(periods.pickup, int), np.asarray(periods.putdown, int)
    T, n = rate.size, starts.size
    pickup, putdown = starts.copy(), stops.copy()
    for k in range(n):  # a handful of periods per recording
        first = 0 if k == 0 else (stops[k - 1] + starts[k]) // 2
        end = T if k == n - 1 else (stops[k] + starts[k + 1]) // 2
        pickup[k] = _slowest(rate, max(starts[k] - back, first), min(starts[k] + ahead, stops[k] - 1), starts[k])
        last = stops[k] - 1
        putdown[k] = _slowest(rate, max(last - ahead, pickup[k]), min(last + back, end - 1), last) + 1
    return Periods(pickup, putdown, in_periods(pickup, putdown, T))


def in_periods(pickup: np.ndarray, putdown: np.ndarray, n_frames: int) -> np.ndarray:
    """(n_frames,) bool: the frames of the periods [pickup, putdown) (`hog_jax.video.Periods`)."""
    t = np.arange(check_int(n_frames, "n_frames", min_value=0))
    starts, stops = np.asarray(pickup, int), np.asarray(putdown, int)
    return ((t[None] >= starts[:, None]) & (t[None] < stops[:, None])).any(axis=0)
