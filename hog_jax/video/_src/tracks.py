"""From per-frame segmentation labels of a stereo pair to the hand-minus-face position (LfD 2009
§III-A and Fig. 1a: "the 2D position of the centroid of the right hand segment relative to the
centroid of the face segment"; with stereo, the same in 3-D): skin blobs of each view -> `track`
(target 0 the face, 1 the right hand, 2 the other hand) -> the left image's hand - face (2-D) and
the triangulated hand - face (3-D, left camera frame). Moving objects (at most `n_objects`, one per
hand, LEVELSET TR §3.7) are tracked the same way from the object label; which of them the hand
holds is not decided here.

Stereo association: the same target id in both views (each view is tracked on its own with the same
`init` rules, both views in one batched call); a frame where a target's rows differ between the views
by more than `max_row_diff_px` (a rectified pair puts a point on one row) is not found in 3-D.

Shapes: B videos (optional), T frames, H x W pixels; results keep the input's leading axes.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from hog_jax.video._src.blobs import connected_blobs
from hog_jax.video._src.stereo import StereoCamera, triangulate
from hog_jax.video._src.tracking import INIT_RULES, TrackOptions, Tracks, TrackState, track_chunk
from lfd_common import as_array, check_choice, check_int, check_real

__all__ = ["FACE", "HAND", "OTHER_HAND", "HandFaceOptions", "HandFacePositions", "HandFaceState", "hand_face_chunk",
           "hand_face_positions", "held"]

FACE, HAND, OTHER_HAND = 0, 1, 2  # target ids of the skin tracks


@dataclasses.dataclass(frozen=True)
class HandFaceOptions:
    """The options of `hand_face_positions` (LfD 2009 §III-A), validated on construction.

    Attributes:
        init: the skin targets' acquisition rules (`track`, from `INIT_RULES`; at least the face
            and the hand). The default takes the face as the highest skin blob, the hand as the
            leftmost blob left of the face's extent and the other hand as the rightmost right of it,
            so that neither a piece of the other arm, the neck nor the other hand is taken for the
            hand.
        n_objects: moving objects tracked from the object label (at most one per hand, LEVELSET TR
            §3.7), 0 <= n_objects <= max_blobs.
        max_blobs: connected components kept per frame (the largest), 1..255.
        min_area: the smallest component kept, pixels, >= 1 (smaller ones are noise).
        max_row_diff_px: the largest row difference of a target between the views (a rectified
            pair puts a point on one row), >= 0; None: 5 % of the image height.
        tracking: the α-β tracker's options for the skin targets (`TrackOptions`); its min_init
            (default 2: face and hand; 3 where both hands are in view once the person is there, so
            that a frame showing the face and only the other hand does not start the hand's track
            on it) is the blobs a frame needs before the first acquisition. The objects use the same
            options with min_init 1.

    Raises:
        ValueError: naming the field for a value out of range, an unknown rule, fewer than two
            skin targets, or tracking options that are not a `TrackOptions`.
    """

    init: tuple[str, ...] = ("top", "left_of_first", "right_of_first")
    n_objects: int = 2
    max_blobs: int = 8
    min_area: int = 4
    max_row_diff_px: float | None = None
    tracking: TrackOptions = TrackOptions(min_init=2)

    def __post_init__(self):
        init = (self.init,) if isinstance(self.init, str) else tuple(self.init)
        if len(init) < 2:
            raise ValueError(f"init: expected the rules of the face, the hand (and more skin targets), got {init!r}")
        for i, rule in enumerate(init):
            check_choice(rule, f"init[{i}]", INIT_RULES)
        object.__setattr__(self, "init", init)
        check_int(self.max_blobs, "max_blobs", min_value=1, max_value=255)
        check_int(self.min_area, "min_area", min_value=1)
        check_int(self.n_objects, "n_objects", min_value=0, max_value=self.max_blobs)
        if self.max_row_diff_px is not None:
            check_real(self.max_row_diff_px, "max_row_diff_px", min_value=0.0)
        if not isinstance(self.tracking, TrackOptions):
            raise ValueError(f"tracking: expected a TrackOptions, got {type(self.tracking).__name__}")


class HandFacePositions(NamedTuple):
    """Hand-minus-face positions of a stereo video, with the tracks they come from (LfD 2009 Fig. 1a).

    Leading axes (.., T): (T,) or (B, T) as the input. Where a flag is False its position is 0.

    Attributes:
        xy_left: (.., T, 2) px, hand - face centroid in the left image.
        xyz: (.., T, 3) m, the triangulated hand - face in the left camera frame.
        found: (.., T) hand and face tracked (observed or coasting, not lost) in the left view.
        found_3d: (.., T) also tracked in the right view, with positive disparities and matching
            rows.
        observed: (.., T) hand and face both measured in both views this frame (not predictions).
        skin_left: the left view's skin `Tracks`, M = len(init) targets (FACE, HAND, OTHER_HAND).
        skin_right: the right view's skin `Tracks`.
        objects_left: the left view's object `Tracks`, M = n_objects (None if 0 or the input is
            boolean).
        objects_right: the right view's object `Tracks` (None likewise).
    """

    xy_left: Float[Array, "*T 2"]
    xyz: Float[Array, "*T 3"]
    found: Bool[Array, "*T"]
    found_3d: Bool[Array, "*T"]
    observed: Bool[Array, "*T"]
    skin_left: Tracks
    skin_right: Tracks
    objects_left: Tracks | None
    objects_right: Tracks | None


class HandFaceState(NamedTuple):
    """The trackers' state between chunks of a stereo video (`hand_face_chunk`).

    Attributes:
        skin: the skin targets' `TrackState`, the left view's and the right view's stacked on a
            leading axis (2, ...) or (2 B, ...) (left first).
        objects: the objects' `TrackState` likewise (None if no object is tracked).
    """

    skin: TrackState
    objects: TrackState | None


def _masks(labels: np.ndarray, label: int) -> np.ndarray:
    return labels if labels.dtype == bool else labels == label


def _views(tracks: Tracks, batch: int) -> tuple[Tracks, Tracks]:
    """Split the tracks of the stacked views (left first; 2 * batch videos, or 2 without a batch)."""
    if batch:
        return jax.tree.map(lambda x: x[:batch], tracks), jax.tree.map(lambda x: x[batch:], tracks)
    return jax.tree.map(lambda x: x[0], tracks), jax.tree.map(lambda x: x[1], tracks)


def _combine(camera: StereoCamera, left: Tracks, right: Tracks, max_row_diff: float):
    """Hand - face in 2-D and 3-D with their flags, in float64 NumPy (a few numbers per frame)."""
    pair = [FACE, HAND]
    lost_left, lost_right = np.asarray(left.lost)[..., pair], np.asarray(right.lost)[..., pair]
    pos_left = np.asarray(left.position, np.float64)[..., pair, :]
    pos_right = np.asarray(right.position, np.float64)[..., pair, :]
    tracked_left, tracked_right = ~lost_left.any(-1), ~lost_right.any(-1)
    points = triangulate(camera, pos_left, pos_right)  # (.., T, 2, 3)
    rows_agree = np.all(np.abs(pos_left[..., 1] - pos_right[..., 1]) <= max_row_diff, axis=-1)
    found_3d = tracked_left & tracked_right & np.all(points.valid, axis=-1) & rows_agree
    observed = np.all(np.asarray(left.observed)[..., pair], -1) & np.all(np.asarray(right.observed)[..., pair], -1)
    xy = pos_left[..., 1, :] - pos_left[..., 0, :]
    xyz = points.xyz[..., 1, :] - points.xyz[..., 0, :]
    return (jnp.asarray(np.where(tracked_left[..., None], xy, 0.0), jnp.float32),
            jnp.asarray(np.where(found_3d[..., None], xyz, 0.0), jnp.float32), jnp.asarray(tracked_left),
            jnp.asarray(found_3d), jnp.asarray(observed))


def hand_face_positions(left: Int[ArrayLike, "*T H W"] | Bool[ArrayLike, "*T H W"],
                        right: Int[ArrayLike, "*T H W"] | Bool[ArrayLike, "*T H W"], camera: StereoCamera, *,
                        skin_label: int = 2, object_label: int = 3,
                        options: HandFaceOptions = HandFaceOptions()) -> HandFacePositions:
    """The hand-minus-face position of a stereo video, in 2-D and 3-D (LfD 2009 §III-A, Fig. 1a).

    "The 2D position of the centroid of the right hand segment relative to the centroid of the face
    segment"; with stereo, the same in 3-D. The skin blobs of each view are tracked (`track`: target
    0 the face, 1 the right hand, 2 the other hand), both views in one batched call with the same
    `init` rules, and the same target id in both views is one point: the left image's hand - face
    (2-D) and the triangulated hand - face (3-D, left camera frame). A frame where a target's rows
    differ between the views by more than `max_row_diff_px` is not found in 3-D. Moving objects are
    tracked the same way from the object label; which of them the hand holds is not decided here.

    Args:
        left: (T, H, W) or (B, T, H, W) per-frame segmentation labels of the left view (integers:
            the level sets' -1 none, 0 background, 1 person, 2 skin, 3 object, or any labelling with
            `skin_label` and `object_label`), or boolean skin masks (then no object is tracked).
        right: the right view, of the shape and dtype of `left`.
        camera: the rectified pair (`StereoCamera`); its image size must be H x W.
        skin_label: the label of skin pixels.
        object_label: the label of object pixels.
        options: blobs, acquisition and tracker options (`HandFaceOptions`).

    Returns:
        `HandFacePositions` with the input's leading axes.

    Raises:
        ValueError: naming the argument for a camera that is not a `StereoCamera` or of another
            image size, labels that are neither integers nor booleans, views of other shapes or
            dtypes (`right`), or options that are not a `HandFaceOptions`.
    """
    return hand_face_chunk(left, right, camera, None, skin_label=skin_label, object_label=object_label,
                           options=options)[1]


def hand_face_chunk(left: Int[ArrayLike, "*T H W"] | Bool[ArrayLike, "*T H W"],
                    right: Int[ArrayLike, "*T H W"] | Bool[ArrayLike, "*T H W"], camera: StereoCamera,
                    state: HandFaceState | None = None, *, skin_label: int = 2, object_label: int = 3,
                    options: HandFaceOptions = HandFaceOptions()) -> tuple[HandFaceState, HandFacePositions]:
    """`hand_face_positions` on a chunk of frames, from the trackers' state after the previous chunk.

    The chunks of a video in order, each from the state the previous one returned (the first from
    None), give the `HandFacePositions` of `hand_face_positions` on the whole video.

    Args:
        left: (T, H, W) or (B, T, H, W) the chunk's labels of the left view (`hand_face_positions`).
        right: the right view, of the shape and dtype of `left`.
        camera: the rectified pair (`StereoCamera`); its image size must be H x W.
        state: the `HandFaceState` after the previous chunk, or None before the first frame.
        skin_label: the label of skin pixels.
        object_label: the label of object pixels.
        options: blobs, acquisition and tracker options (`HandFaceOptions`).

    Returns:
        (the `HandFaceState` after the chunk, the chunk's `HandFacePositions`).

    Raises:
        ValueError: as `hand_face_positions`, and naming `state` for one that is not a
            `HandFaceState` of these targets and views.
    """
    if state is not None and not isinstance(state, HandFaceState):
        raise ValueError(f"state: expected a HandFaceState or None, got {type(state).__name__}")
    if not isinstance(camera, StereoCamera):
        raise ValueError(f"camera: expected a hog_jax.video.StereoCamera, got {type(camera).__name__}")
    views = {}
    for name, value in (("left", left), ("right", right)):
        arr = as_array(value, name, ndim=(3, 4), dtype=None)
        if arr.dtype != bool and not np.issubdtype(arr.dtype, np.integer):
            raise ValueError(f"{name}: expected integer labels or boolean skin masks, got dtype {arr.dtype}")
        views[name] = arr
    if views["right"].shape != views["left"].shape:
        raise ValueError(f"right: expected the shape of left {views['left'].shape}, got {views['right'].shape}")
    if views["right"].dtype != views["left"].dtype:
        raise ValueError(f"right: expected the dtype of left ({views['left'].dtype}), got {views['right'].dtype}")
    H, W = views["left"].shape[-2:]
    if (camera.height, camera.width) != (H, W):
        raise ValueError(f"camera: its image is {camera.height} x {camera.width}, the frames are {H} x {W}")
    if not isinstance(options, HandFaceOptions):
        raise ValueError(f"options: expected a HandFaceOptions, got {type(options).__name__}")
    skin_label = check_int(skin_label, "skin_label")
    object_label = check_int(object_label, "object_label")
    o = options
    row_tol = 0.05 * H if o.max_row_diff_px is None else float(o.max_row_diff_px)
    batch = views["left"].shape[0] if views["left"].ndim == 4 else 0
    both = np.concatenate([views["left"], views["right"]]) if batch else np.stack([views["left"], views["right"]])
    skin_state, skin = track_chunk(connected_blobs(_masks(both, skin_label), o.max_blobs, o.min_area),
                                   None if state is None else state.skin, o.init, o.tracking)
    skin_left, skin_right = _views(skin, batch)
    objects_left = objects_right = object_state = None
    if o.n_objects and both.dtype != bool:
        object_state, objects = track_chunk(connected_blobs(both == object_label, o.max_blobs, o.min_area),
                                            None if state is None else state.objects, ("largest",) * o.n_objects,
                                            dataclasses.replace(o.tracking, min_init=1))
        objects_left, objects_right = _views(objects, batch)
    xy, xyz, found, found_3d, observed = _combine(camera, skin_left, skin_right, row_tol)
    return HandFaceState(skin_state, object_state), HandFacePositions(
        xy, xyz, found, found_3d, observed, skin_left, skin_right, objects_left, objects_right)


def held(values: np.ndarray, found: np.ndarray) -> np.ndarray:
    """Hold a lost target at its last found position, as a tracker reports it (LfD 2009 §III-A).

    Args:
        values: (T, D) per-frame positions (or any per-frame values).
        found: (T,) bool, whether each frame's value was measured.

    Returns:
        (T, D) `values` with each frame where `found` is False replaced by the last found one before
        it (by the first found one where none precedes it); zeros where no frame is found.
    """
    found = np.asarray(found, bool)
    if not found.any():
        return np.zeros_like(values)
    last = np.maximum.accumulate(np.where(found, np.arange(len(found)), -1))
    return values[np.where(last >= 0, last, np.argmax(found))]
