"""The video front end as one call: a stereo recording -> the left view's region labels, the tracked
hand and face, and the right hand's pixel tracks in both views (LEVELSET TR §3-5; LfD 2009 §III-A).

`front_end` fits the recording's colour models at its start (`fit_video_models`), segments both views
and tracks hand and face (`segment_stereo`), then reads the right hand's tracks (`hand_tracks`). The
frames are padded to a multiple of `pad_multiple` first (`pad_frames`) so that recordings of similar
length share one compilation; every scan is causal, so the padding changes no earlier frame, and the
outputs are cut back to the recording's length. `stream_front_end` does the same chunk by chunk
(the segmentation's and the trackers' states carried from one chunk to the next), so that memory
holds one chunk of frames, not the recording; `front_end` is its one-chunk case.
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import NamedTuple

import jax
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int, Key, Real

from hog_jax._src.segment import SkinModel
from hog_jax.video._src.pipeline import VideoOptions, fit_video_models, stereo_chunks
from hog_jax.video._src.stereo import StereoCamera
from hog_jax.video._src.tracks import HAND, HandFaceOptions, HandFacePositions
from lfd_common import as_array, check_int, progress

__all__ = ["FrontEndResult", "front_end", "hand_tracks", "pad_frames", "stream_front_end"]


class FrontEndResult(NamedTuple):
    """What the video front end gives for one stereo recording (`front_end`).

    Attributes:
        labels: (T, H, W) int8 region labels of the left view in `REGIONS` order (-1: boundary).
        positions: the `HandFacePositions` of `hand_face_positions`, every per-frame array (T, ...).
        hand_left: (T, 2) float64 the tracked right hand in the left view, (row, column) pixels.
        hand_right: (T, 2) float64 the same in the right view.
        tracked: (T,) bool the hand tracked (not lost) in both views, False before `start`; where it is
            False the positions hold the tracker's last value.
    """

    labels: Int[Array, "T H W"]
    positions: HandFacePositions
    hand_left: Float[np.ndarray, "T 2"]
    hand_right: Float[np.ndarray, "T 2"]
    tracked: Bool[np.ndarray, "T"]


def pad_frames(frames: Real[ArrayLike, "T *rest"], multiple: int) -> np.ndarray:
    """The frames padded to a multiple of `multiple` by repeating the last one.

    Recordings of similar length then share one compilation of the segmentation; its scans are causal,
    so the frames before the padding come out unchanged.

    Args:
        frames: (T, ...) frames, T >= 1.
        multiple: the padded length's divisor, >= 1.

    Returns:
        (T + (-T mod multiple), ...) the frames, then copies of the last one.

    Raises:
        ValueError: naming the argument for a multiple < 1 or frames without a frame.
    """
    multiple = check_int(multiple, "multiple", min_value=1)
    a = np.asarray(frames)
    if a.ndim < 1 or a.shape[0] < 1:
        raise ValueError(f"frames: expected (T, ...) with T >= 1, got shape {a.shape}")
    extra = -a.shape[0] % multiple
    return np.concatenate([a, np.repeat(a[-1:], extra, axis=0)])


def hand_tracks(positions: HandFacePositions, start: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The right hand's pixel tracks in both views (LfD 2009 §III-A: the hand the object moves with).

    Args:
        positions: the `HandFacePositions` of one recording (leading axis T).
        start: the first segmented frame; earlier frames count as not tracked, >= 0.

    Returns:
        (hand_left (T, 2), hand_right (T, 2) float64 (row, column) pixels, tracked (T,) bool): the
        `HAND` track of each view, and whether it is tracked (not lost) in both views and at or after
        `start` (where not, the positions hold the tracker's last value).

    Raises:
        ValueError: naming `start` for a negative one.
    """
    start = check_int(start, "start", min_value=0)
    rows = lambda tracks: np.asarray(tracks.position)[:, HAND, ::-1].astype(np.float64)  # noqa: E731
    tracked = ~np.asarray(positions.skin_left.lost)[:, HAND] & ~np.asarray(positions.skin_right.lost)[:, HAND]
    tracked[:start] = False
    return rows(positions.skin_left), rows(positions.skin_right), tracked


def _front_end_chunks(key, skin, chunks: Iterable, start: int, camera: StereoCamera, options: VideoOptions,
                      tracking: HandFaceOptions, bar=None) -> Iterator[FrontEndResult]:
    """`stream_front_end`'s generator: the chunks up to `start` are held to fit the colour models,
    then every chunk is segmented and tracked in order and its `FrontEndResult` yielded."""
    chunks = iter(chunks)
    held = []
    while sum(len(c[0]) for c in held) < start:
        pair = next(chunks, None)
        if pair is None:
            break
        a = as_array(pair[0], "left", ndim=4, dtype=None)
        b = as_array(pair[1], "right", ndim=4, dtype=None)
        if a.shape != b.shape:
            raise ValueError(f"right: expected the shape of left {a.shape}, got {b.shape}")
        held.append((a, b))
    if not held:
        raise ValueError("left: expected at least one frame, got none")
    first = np.concatenate([c[0] for c in held])[:start]
    models, _ = fit_video_models(key, skin, first, start, options)
    del first

    def ordered():
        while held:
            yield held.pop(0)
        yield from chunks

    offset = 0
    for seg in stereo_chunks(models, ordered(), start, camera, options, tracking, bar):
        hand_left, hand_right, tracked = hand_tracks(seg.positions, max(start - offset, 0))
        n = len(hand_left)
        offset += n
        yield FrontEndResult(seg.left.labels, seg.positions, hand_left, hand_right, tracked)


def stream_front_end(key: Key[Array, ""], skin: SkinModel, chunks: Iterable[tuple[Real[ArrayLike, "T H W 3"],
                                                                             Real[ArrayLike, "T H W 3"]]],
                     start: int, camera: StereoCamera, options: VideoOptions = VideoOptions(),
                     tracking: HandFaceOptions = HandFaceOptions(), total: int | None = None
                     ) -> Iterator[FrontEndResult]:
    """`front_end` chunk by chunk, for a stereo recording that does not fit in memory.

    The chunks before `start` are held until the colour models are fitted on them
    (`fit_video_models`, LEVELSET TR §3.4-3.5); then every chunk is segmented and tracked from the
    state the previous one left (`stream_stereo`: the background model, the level sets and the
    trackers, TR §3-5 and LfD 2009 §III-A) and its result yielded before the next is read: memory
    holds the first `start` frames and one chunk, never the recording. Chunks shorter than the first
    (the last one) are padded to its length (one compilation). A progress bar counts the frames on
    stderr (silent when the environment variable `LFD_NO_PROGRESS` is set).

    Args:
        key: a `jax.random` key (the colour models' fits).
        skin: the skin model (`hog_jax.SkinModel`, e.g. `lfd_jax.fit_real_skin_model`).
        chunks: an iterable of (left (T_k, H, W, 3), right (T_k, H, W, 3)) RGB frame pairs in
            [0, 255], rectified, e.g. `lfd_jax.iter_stereo_videos`.
        start: the first segmented frame (see `fit_video_models`).
        camera: the rectified pair (`StereoCamera`), its image H x W.
        options: the segmentation options (`VideoOptions`).
        tracking: the blob and tracker options (`HandFaceOptions`).
        total: the recording's number of frames, for the progress bar (None: unknown).

    Returns:
        An iterator of each chunk's `FrontEndResult` (per-frame arrays of the chunk's length;
        `tracked` is False before `start`).

    Raises:
        ValueError: as `front_end`, when the chunk that raises is reached.
    """
    if not isinstance(camera, StereoCamera):
        raise ValueError(f"camera: expected a StereoCamera, got {type(camera).__name__}")
    start = check_int(start, "start", min_value=1)
    with progress(desc="front end", total=total, unit="frame") as bar:
        yield from _front_end_chunks(key, skin, chunks, start, camera, options, tracking, bar)


def front_end(key: Key[Array, ""], skin: SkinModel, left: Real[ArrayLike, "T H W 3"], right: Real[ArrayLike, "T H W 3"],
              start: int, camera: StereoCamera, options: VideoOptions = VideoOptions(),
              tracking: HandFaceOptions = HandFaceOptions(), pad_multiple: int = 1) -> FrontEndResult:
    """The video front end on one stereo recording: region labels, hand and face, the hand's tracks.

    The whole recording is one chunk of `stream_front_end`. Pads both views (`pad_frames`), learns
    the recording's colour models from the frames before `start` (`fit_video_models`, LEVELSET TR
    §3.4-3.5), segments both views and tracks hand and face
    (`segment_stereo`, TR §3-5 and LfD 2009 §III-A), cuts every per-frame output back to T frames and
    reads the right hand's tracks (`hand_tracks`).

    Args:
        key: a `jax.random` key (the colour models' fits).
        skin: the skin model (`hog_jax.SkinModel`, e.g. `lfd_jax.fit_real_skin_model`).
        left: (T, H, W, 3) RGB frames of the left view in [0, 255]: the empty scene, the person
            entering, then the segmented frames from `start` on.
        right: (T, H, W, 3) RGB frames of the right view, rectified.
        start: the first segmented frame (see `fit_video_models`).
        camera: the rectified pair (`StereoCamera`, e.g. from `stereo_camera_from_matrices`), its
            image H x W.
        options: the segmentation options (`VideoOptions`; `BackgroundOptions.for_fps` scales the
            background model's learning rate to the frame rate).
        tracking: the blob and tracker options (`HandFaceOptions`).
        pad_multiple: the frames are padded to a multiple of this, >= 1 (1: no padding).

    Returns:
        A `FrontEndResult`.

    Raises:
        ValueError: naming the argument for views of other shapes (`right`), a `pad_multiple` < 1, a
            camera that is not a `StereoCamera`, and as `fit_video_models` and `segment_stereo`.
    """
    pad_multiple = check_int(pad_multiple, "pad_multiple", min_value=1)
    a = as_array(left, "left", ndim=4, dtype=None)
    b = as_array(right, "right", ndim=4, dtype=None)
    if a.shape != b.shape:
        raise ValueError(f"right: expected the shape of left {a.shape}, got {b.shape}")
    if not isinstance(camera, StereoCamera):
        raise ValueError(f"camera: expected a StereoCamera, got {type(camera).__name__}")
    T = a.shape[0]
    a, b = pad_frames(a, pad_multiple), pad_frames(b, pad_multiple)
    out = next(_front_end_chunks(key, skin, [(a, b)], start, camera, options, tracking))
    cut = lambda x: np.asarray(x)[:T] if np.ndim(x) and np.shape(x)[0] == a.shape[0] else x  # noqa: E731
    return jax.tree.map(cut, out)
