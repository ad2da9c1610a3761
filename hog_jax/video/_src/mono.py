"""Face and hands in one camera's video, chunk by chunk (LEVELSET TR §3-5, §3.7; LfD 2009 §III-A): the
segmentation (`stream_recording`), the skin label's connected components (`connected_blobs`), the α-β
tracker carried from chunk to chunk (`track_chunk`) and the hands at the far end of bare-forearm blobs
(`hand_ends`). The mono counterpart of the stereo `stream_front_end`; memory holds one chunk.

Shapes: T frames (t per chunk), H x W pixels, M skin targets (face, hand, other hand by default).
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import NamedTuple

import numpy as np
from jaxtyping import ArrayLike, Bool, Float, Int, Real

from hog_jax.video._src.arm import HandEndOptions, hand_ends
from hog_jax.video._src.blobs import connected_blobs
from hog_jax.video._src.pipeline import SKIN, VideoModels, VideoOptions, stream_recording
from hog_jax.video._src.tracking import Tracks, track_chunk
from hog_jax.video._src.tracks import FACE, HAND, OTHER_HAND, HandFaceOptions
from lfd_common import check_int

__all__ = ["MonoTracks", "stream_mono", "track_mono"]


class MonoTracks(NamedTuple):
    """A chunk of one camera's video: its labels, the skin targets' tracks and where the hands are.

    Attributes:
        labels: (t, H, W) int8 region labels in `REGIONS` order (-1: boundary).
        tracks: the skin targets' `Tracks` (leading axis t; targets in `HandFaceOptions.init` order:
            face, hand, other hand).
        hands: (t, 2, 2) float32 (x, y) of the hand and the other hand (`hand_ends`: the far end of an
            arm blob, else the tracked position).
        tracked: (t, M) bool, each target tracked (not lost) on a segmented frame (at or after `start`).
    """

    labels: Int[np.ndarray, "t H W"]
    tracks: Tracks
    hands: Float[np.ndarray, "t 2 2"]
    tracked: Bool[np.ndarray, "t M"]


def stream_mono(models: VideoModels, chunks: Iterable[Real[ArrayLike, "t H W 3"]], start: int,
                options: VideoOptions = VideoOptions(), tracking: HandFaceOptions = HandFaceOptions(),
                ends: HandEndOptions | None = HandEndOptions(), total: int | None = None) -> Iterator[MonoTracks]:
    """Face and hands of a mono recording, chunk by chunk (module docstring).

    Args:
        models: the `VideoModels` (`fit_video_models`).
        chunks: an iterable of (t, H, W, 3) frames in [0, 255] (e.g. `lfd_jax.iter_video`), the whole
            recording from its first frame.
        start: the first segmented frame (`segment_recording`), >= 1.
        options: the `VideoOptions`.
        tracking: the blob and tracker options (`HandFaceOptions`: `init`, `max_blobs`, `min_area`,
            `tracking`); the first three targets are the face, the hand and the other hand.
        ends: where an arm blob's hand is (`HandEndOptions`), or None for the tracked positions.
        total: the recording's frames, for the progress bar (None: unknown).

    Returns:
        An iterator of each chunk's `MonoTracks`.

    Raises:
        ValueError: naming the argument for fewer than three skin targets or tracking options that are
            not a `HandFaceOptions`, and as `stream_recording` and `track_chunk`.
    """
    if not isinstance(tracking, HandFaceOptions):
        raise ValueError(f"tracking: expected a HandFaceOptions, got {type(tracking).__name__}")
    if len(tracking.init) < 3:
        raise ValueError(f"tracking: expected the rules of the face, the hand and the other hand, got {tracking.init}")
    state, seen = None, 0
    for seg in stream_recording(models, chunks, start, options, total):
        labels = np.asarray(seg.labels)
        blobs = connected_blobs(labels == SKIN, tracking.max_blobs, tracking.min_area)
        state, tracks = track_chunk(blobs, state, tracking.init, tracking.tracking)
        segmented = (seen + np.arange(len(labels)) >= start)[:, None]
        tracked = ~np.asarray(tracks.lost) & segmented
        if ends is None:
            hands = np.asarray(tracks.position)[:, [HAND, OTHER_HAND]]
        else:
            hands = np.asarray(hand_ends(blobs.labels, tracks, [HAND, OTHER_HAND], FACE, ends))
        seen += len(labels)
        yield MonoTracks(labels, tracks, hands.astype(np.float32), tracked)


def track_mono(models: VideoModels, frames: Real[ArrayLike, "T H W 3"], start: int,
               options: VideoOptions = VideoOptions(), tracking: HandFaceOptions = HandFaceOptions(),
               ends: HandEndOptions | None = HandEndOptions(), chunk: int = 64) -> MonoTracks:
    """`stream_mono` on a recording in memory, its chunks joined.

    Args:
        models: the `VideoModels`.
        frames: (T, H, W, 3) frames in [0, 255].
        start: the first segmented frame, >= 1.
        options: the `VideoOptions`.
        tracking: the `HandFaceOptions`.
        ends: the `HandEndOptions`, or None.
        chunk: frames per chunk, >= 1 (the result does not depend on it).

    Returns:
        The whole recording's `MonoTracks` (leading axis T).

    Raises:
        ValueError: as `stream_mono`, and naming `frames` for an array that is not (T, H, W, 3) or
            `chunk` for one < 1.
    """
    arr = np.asarray(frames)
    if arr.ndim != 4 or arr.shape[-1] != 3 or not len(arr):
        raise ValueError(f"frames: expected (T, H, W, 3) frames with T >= 1, got shape {arr.shape}")
    chunk = check_int(chunk, "chunk", min_value=1)
    parts = list(stream_mono(models, (arr[i:i + chunk] for i in range(0, len(arr), chunk)), start, options, tracking,
                             ends, total=len(arr)))
    join = lambda *xs: np.concatenate([np.asarray(x) for x in xs])  # noqa: E731
    return MonoTracks(join(*(p.labels for p in parts)), Tracks(*(join(*f) for f in zip(*(p.tracks for p in parts)))),
                      join(*(p.hands for p in parts)), join(*(p.tracked for p in parts)))
