"""The tracked stream of one recording: the video front end's hand - face positions in world axes,
cleaned of the tracker's outliers for the online recogniser (LFD §III-A, §III-C: the triangulated hand
relative to the face; PHMM (Herzog et al. 2008, BMVC §5.4) recognises movements from it)."""
from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

from hog_jax.video import held


class Tracked(NamedTuple):
    """The video front end's output for one recording (LFD §III-A).

    Attributes:
        diff: (T, 3) hand - face in world axes (m; 0 where not found).
        found: (T,) bool, tracked in both views.
        hand_rc: (T, 2) the tracked hand in the left view (row, column).
        start: the first segmented frame.
    """

    diff: np.ndarray
    found: np.ndarray
    hand_rc: np.ndarray
    start: int


def camera_rotation(P_left: np.ndarray) -> np.ndarray:
    """The world -> left camera rotation of a camera matrix (LFD §III-A, stereo triangulation).

    Args:
        P_left: (3, 4) camera matrix of the left view.

    Returns:
        (3, 3) rotation, camera axes x right, y down, z forward.

    Raises:
        ValueError: `P_left` is not a finite (3, 4) matrix.
    """
    P_left = np.asarray(P_left, np.float64)
    if P_left.shape != (3, 4) or not np.isfinite(P_left).all():
        raise ValueError(f"P_left: expected a finite (3, 4) camera matrix, got {P_left.shape}")
    return cv2.decomposeProjectionMatrix(P_left)[1]


def median_filter(x: np.ndarray, width: int) -> np.ndarray:
    """Running median over `width` frames, edges repeated (removes the tracker's spikes).

    Args:
        x: (T, D) per-frame values.
        width: odd window length in frames (1: no filter).

    Returns:
        (T, D) filtered values.

    Raises:
        ValueError: `width` is not a positive odd integer.
    """
    if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1 or width % 2 == 0:
        raise ValueError(f"width: expected a positive odd integer, got {width!r}")
    if width == 1:
        return x
    h = width // 2
    padded = np.concatenate([np.repeat(x[:1], h, 0), x, np.repeat(x[-1:], h, 0)])
    return np.median(np.lib.stride_tricks.sliding_window_view(padded, width, axis=0), axis=-1)


def plausible(t: Tracked, median_frames: int, reach_m: float = 1.0, jump_m: float = 0.15) -> np.ndarray:
    """The tracked frames kept for recognition (LFD §III-A tracks, outliers removed).

    A frame is kept where the hand is within `reach_m` of the face and below it by less than an arm (a
    wrong stereo match triangulates metres away), and within `jump_m` of the running median of the
    kept frames around it (single-frame swaps of hand and face blobs).

    Args:
        t: the tracked recording.
        median_frames: the running median's window (frames; at least 5 is used).
        reach_m: the largest hand - face distance kept (m).
        jump_m: the largest distance from the running median kept (m).

    Returns:
        (T,) bool, the frames kept.
    """
    d = t.diff.astype(np.float64)
    keep = t.found & (np.linalg.norm(d, axis=1) < reach_m) & (d[:, 2] < 0.3)
    if not keep.any():
        return keep
    smooth = median_filter(held(d, keep), max(median_frames, 5) | 1)
    return keep & (np.linalg.norm(d - smooth, axis=1) < jump_m)


def stream_of(t: Tracked, offset: np.ndarray, median_frames: int) -> np.ndarray:
    """The recogniser's input from a tracked recording (PHMM observations, BMVC §5.4).

    Args:
        t: the tracked recording.
        offset: (3,) the tracker's offset from the kinematic features the PHMMs were trained on (m).
        median_frames: the spike filter's window (odd frames; 1: none).

    Returns:
        (T, 3) the tracked hand - face of the `plausible` frames, held where lost or rejected,
        spike-filtered, minus `offset`.
    """
    return median_filter(held(t.diff.astype(np.float64), plausible(t, median_frames)), median_frames) - offset
