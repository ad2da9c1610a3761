"""Temporal segmentation of a demonstration into primitive OACs (LfD 2009 §III-D, Fig. 8): every
frame is "object in hand" where the object segmentation found a mask (`object_masks`' `found`),
the sequence is filtered over time, and each remaining period from a
pick-up (no object -> object) to a put-down (object -> no object) is one action.

The filter: the text performs "an eroding and a dilating operation ... over time, to remove
spurious positive or negative classifications". An erosion followed by a dilation (an opening)
removes short positives but widens short gaps; a dilation followed by an erosion (a closing) fills
short gaps. Both kinds of error are named, so both are applied: a closing, then an opening, each of
`radius` frames (a run shorter than 2 radius + 1 frames of either kind goes). Then periods with an
object in hand shorter than `min_duration_s` (1 s in the paper) are removed.

Frames outside the recording count as "no object in hand" (a period cut by the end of the recording
ends there: its put-down is the last frame + 1).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from jaxtyping import ArrayLike, Bool

from lfd_common import as_array, check_int, check_real

__all__ = ["Periods", "filter_in_hand", "hold_undecided", "periods_in_hand"]


class Periods(NamedTuple):
    """The periods with an object in the hand: one primitive action each (LfD 2009 §III-D, Fig. 8).

    Attributes:
        pickup: (M,) int, the first frame with the object in hand of each period, in order.
        putdown: (M,) int, the first frame after it (the last frame + 1 for a period cut by the end of
            the recording).
        in_hand: (T,) bool, the filtered per-frame classification.
    """

    pickup: np.ndarray
    putdown: np.ndarray
    in_hand: np.ndarray


def _erode(x: np.ndarray, r: int) -> np.ndarray:
    """1-D binary erosion with a window of 2 r + 1 (outside the sequence: False)."""
    padded = np.pad(x, r, constant_values=False)
    return np.all(np.lib.stride_tricks.sliding_window_view(padded, 2 * r + 1), axis=-1)


def _dilate(x: np.ndarray, r: int) -> np.ndarray:
    padded = np.pad(x, r, constant_values=False)
    return np.any(np.lib.stride_tricks.sliding_window_view(padded, 2 * r + 1), axis=-1)


def filter_in_hand(in_hand: Bool[ArrayLike, " T"], radius: int = 1) -> np.ndarray:
    """The temporal filter of LfD 2009 §III-D: a closing, then an opening, over time.

    The text performs "an eroding and a dilating operation ... over time, to remove spurious positive
    or negative classifications". An opening removes short positives but widens short gaps; a closing
    fills short gaps; both kinds of error are named, so both are applied, each of `radius` frames (a
    run shorter than 2 radius + 1 frames of either kind goes). The sequence is padded by `radius` "no
    object" frames first, so that a period never grows beyond the recording.

    Args:
        in_hand: (T,) boolean (or 0/1) per-frame "object in hand".
        radius: the filter's radius in frames, >= 0 (0: unchanged).

    Returns:
        (T,) bool.

    Raises:
        ValueError: naming the argument for a sequence that is not 1-D or not 0/1, or radius < 0.
    """
    x = as_array(in_hand, "in_hand", ndim=1, dtype=None)
    if x.dtype != bool and not np.isin(x, (0, 1)).all():
        raise ValueError("in_hand: expected a boolean (or 0/1) sequence")
    r = check_int(radius, "radius", min_value=0)
    x = x.astype(bool)
    if r == 0:
        return x
    padded = np.pad(x, r, constant_values=False)
    closed = _erode(_dilate(padded, r), r)
    return _dilate(_erode(closed, r), r)[r:-r]


def hold_undecided(in_hand: Bool[ArrayLike, " T"], decided: Bool[ArrayLike, " T"]) -> np.ndarray:
    """Hold the last decided frame's classification where a frame cannot decide (LfD 2009 §III-B, D).

    Where the hand has not moved, eq. 1 equals the static background's likelihood (r_m = 1) and a
    frame's mask says nothing about the object (`ObjectSegmentation.hand_moved`).

    Args:
        in_hand: (T,) bool per-frame "object in hand".
        decided: (T,) bool, the frames that decide.

    Returns:
        (T,) bool: `in_hand` where `decided`, elsewhere the value of the last decided frame (False
        before the first).

    Raises:
        ValueError: naming the argument for sequences that are not 1-D or of different lengths.
    """
    x = as_array(in_hand, "in_hand", ndim=1, dtype=bool)
    d = as_array(decided, "decided", shape=x.shape, dtype=bool)
    last = np.maximum.accumulate(np.where(d, np.arange(x.size), -1))
    return np.where(last >= 0, x[np.maximum(last, 0)], False)


def periods_in_hand(in_hand: Bool[ArrayLike, " T"], fps: float, radius: int = 1,
                    min_duration_s: float = 1.0, decided: Bool[ArrayLike, " T"] | None = None) -> Periods:
    """The pick-up and put-down frames of a recording (LfD 2009 §III-D, Fig. 8).

    Every frame is "object in hand" where the object segmentation found a mask; the sequence is held
    where undecided (`hold_undecided`, when `decided` is given) and filtered (`filter_in_hand`), and
    each remaining period from a pick-up (no object -> object) to a put-down (object -> no object) at
    least `min_duration_s` long (1 s in the paper) is one action. Frames outside the recording count
    as "no object in hand".

    Args:
        in_hand: (T,) bool per-frame "object in hand" (`ObjectSegmentation.found`).
        fps: frames per second, > 0.
        radius: the filter's radius in frames (`filter_in_hand`).
        min_duration_s: the shortest period kept, seconds, >= 0.
        decided: (T,) bool, the frames whose classification counts (`hold_undecided`), or None.

    Returns:
        The `Periods`.

    Raises:
        ValueError: naming the argument for bad sequences, fps <= 0, min_duration_s < 0, or a
            recording shorter than `min_duration_s` (`in_hand`).
    """
    rate = check_real(fps, "fps", min_value=0.0, exclusive_min=True)
    shortest = check_real(min_duration_s, "min_duration_s", min_value=0.0)
    x = filter_in_hand(in_hand if decided is None else hold_undecided(in_hand, decided), radius)
    if x.size < shortest * rate:
        raise ValueError(f"in_hand: a recording of {x.size} frames is shorter than min_duration_s = {shortest} s "
                         f"at {rate} frames/s")
    edges = np.diff(np.concatenate([[False], x, [False]]).astype(np.int8))
    pickup, putdown = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    keep = (putdown - pickup) >= shortest * rate
    marks = np.zeros(x.size + 1, np.int64)
    np.add.at(marks, pickup[keep], 1)
    np.add.at(marks, putdown[keep], -1)
    return Periods(pickup[keep], putdown[keep], np.cumsum(marks)[:-1] > 0)
