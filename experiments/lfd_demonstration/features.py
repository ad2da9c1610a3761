"""Per-frame OAC features from what the cameras see (LfD 2009 §IV, ECCV 2008 §3, §5): the
hand position relative to the face in 2-D (left image) and 3-D (triangulated), the HOG of the
segmented hand (B = 4, L = 4 as LfD) and the HOG of the segmented object (one level, square-normalised
as ECCV §5), in the same layout as the OAC study's `experiments.data.oac.OACData`, so its CRF
protocol runs unchanged on them.

Two sources per recording, through one function (`frame_features`):
- the pipeline: the level-set labels and α-β tracks of the video front end (`hog_jax.video.segment_stereo`)
  and the phase-difference object masks (`hog_jax.video.segment_objects`);
- the renderer's masks (the ground truth of the same frames), the reference that says what the
  pipeline's segmentation costs.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

import hog_jax
from experiments.data.oac import OACData, masked_hog
from experiments.data.video import LABELS, OBJECTS, TRACKED
from hog_jax.video import HAND, held
from hog_jax.video import BACKGROUND, OBJECT, PERSON, SKIN
from lfd_common import as_array, check_int, check_real

TRUE_HAND, TRUE_FACE = TRACKED.index("hand"), TRACKED.index("face")  # the renderer's ellipses
TRUE_HAND_SKIN, TRUE_OBJECT = LABELS.index("hand skin"), LABELS.index(OBJECTS[0])  # label maps: the held object k


# The "object in hand" classifier's features (`hand_window_features`), chosen on validation recordings
# (seeds 1-3 of the quick preset): a HOG of four pyramid levels of eight bins, each cell normalised (ahead of
# three levels, of a 4 x 4 grid and of global normalisation), and the front end's labels on a 4 x 4 grid
# (frame AUC 0.92 against 0.88 without them; 3 x 3 and 6 x 6 grids 0.91 and 0.92, with more events off).
IN_HAND_HOG = hog_jax.HOGConfig(n_bins=8, n_levels=4, normalize="cell")
LABEL_GRID = 4
WINDOW_SCALE = 2.0  # the window's half size over the object window's (1.5 and 3 were worse on validation)


@dataclasses.dataclass(frozen=True)
class FeatureSpec:
    """How a frame becomes features: crop sides (px) and HOG pyramids of the hand and the object."""

    hand_px: int = 48            # side of the square hand crop (the OAC generator's image_px)
    object_px: int = 32          # side of the square-normalised object crop (ECCV §5)
    hand_levels: int = 4         # LfD 2009 §IV: B = 4, L = 4
    object_levels: int = 1       # ECCV §5: one level
    n_bins: int = 4
    hand_reach: float = 3.0      # skin pixels within this Mahalanobis radius of the tracked hand ellipse

    def __post_init__(self):
        for name, low in (("hand_px", 8), ("object_px", 8), ("hand_levels", 1), ("object_levels", 1), ("n_bins", 2)):
            check_int(getattr(self, name), name, min_value=low)
        check_real(self.hand_reach, "hand_reach", min_value=0.0, exclusive_min=True)


class FrameFeatures(NamedTuple):
    """Per frame (T,): pos2d (T, 2) px, hand - face in the left image; pos3d (T, 3) m, hand - face in the
    left camera frame (both held from the last frame they were found; `position_found` says where they
    were measured); hand_hog (T, Dh), object_hog (T, Do) (zeros where `hand_found` / `object_found` is
    False)."""

    pos2d: np.ndarray
    pos3d: np.ndarray
    hand_hog: np.ndarray
    object_hog: np.ndarray
    position_found: np.ndarray
    hand_found: np.ndarray
    object_found: np.ndarray


def windows(images: np.ndarray, centres: np.ndarray, half: tuple[int, int], fill=0) -> np.ndarray:
    """(T, 2 hh + 1, 2 hw + 1) windows of images (T, H, W) around centres (T, 2) (row, column), rounded;
    `fill` outside the image. One gather for all frames."""
    hh, hw = half
    T, H, W = images.shape
    r, c = np.rint(np.asarray(centres, np.float64)).astype(int).T
    rows = r[:, None, None] + np.arange(-hh, hh + 1)[None, :, None]
    cols = c[:, None, None] + np.arange(-hw, hw + 1)[None, None, :]
    inside = (rows >= 0) & (rows < H) & (cols >= 0) & (cols < W)
    picked = images[np.arange(T)[:, None, None], np.clip(rows, 0, H - 1), np.clip(cols, 0, W - 1)]
    return np.where(inside, picked, np.asarray(fill, images.dtype))


def ellipse_masks(shape: tuple[int, int], centres: np.ndarray, covs: np.ndarray, reach: float) -> np.ndarray:
    """(T, H, W) bool: pixels within Mahalanobis distance `reach` of each frame's ellipse, centres (T, 2)
    (x, y) px and second moments covs (T, 2, 2) px^2 (a uniform ellipse reaches distance 2); a 1 px^2
    floor keeps a degenerate ellipse a small disc."""
    H, W = shape
    inv = np.linalg.inv(np.asarray(covs, np.float64) + np.eye(2))
    dx = np.arange(W)[None, None, :] - np.asarray(centres, np.float64)[:, 0, None, None]
    dy = np.arange(H)[None, :, None] - np.asarray(centres, np.float64)[:, 1, None, None]
    a, b, c = (inv[:, i, j, None, None] for i, j in ((0, 0), (0, 1), (1, 1)))
    d2 = a * dx * dx + 2 * b * dx * dy + c * dy * dy
    return d2 <= reach * reach


def frame_features(grey: np.ndarray, hand_mask: np.ndarray, hand_rc: np.ndarray, object_grey: np.ndarray,
                   object_mask: np.ndarray, pos2d: np.ndarray, pos3d: np.ndarray, position_found: np.ndarray,
                   spec: FeatureSpec) -> FrameFeatures:
    """The features of T frames. grey (T, H, W) uint8 left view; hand_mask (T, H, W) bool the hand's
    pixels and hand_rc (T, 2) (row, column) a point on the hand (the component nearest it is the hand);
    object_grey (T, h, w) uint8 and object_mask (T, h, w) bool: the hand's window and the object in it;
    pos2d (T, 2), pos3d (T, 3), position_found (T,)."""
    hand = hog_jax.crop_components(np.asarray(grey, np.float32) / 255.0, hand_mask, hand_rc, spec.hand_px)
    obj = hog_jax.crop_components(np.asarray(object_grey, np.float32) / 255.0, object_mask, None, spec.object_px,
                                  margin=0.0)
    hand_hog = masked_hog(np.asarray(hand.images), np.asarray(hand.masks), spec.n_bins, spec.hand_levels)
    object_hog = masked_hog(np.asarray(obj.images), np.asarray(obj.masks), spec.n_bins, spec.object_levels)
    found = np.asarray(position_found, bool)
    return FrameFeatures(held(np.asarray(pos2d, np.float32), found), held(np.asarray(pos3d, np.float32), found),
                         hand_hog, object_hog, found, np.asarray(hand.found) & (hand_hog != 0).any(1),
                         np.asarray(obj.found) & (object_hog != 0).any(1))


def segment_frames(start: int, stop: int, fps: float, feature_fps: float) -> np.ndarray:
    """Frame indices of the segment [start, stop) resampled from `fps` to `feature_fps` (nearest)."""
    step = fps / feature_fps
    return np.unique(np.minimum(start + np.rint(np.arange(0.0, stop - start, step)).astype(int), stop - 1))


def as_oac_data(segments: list[FrameFeatures], action, obj, person, repetition) -> OACData:
    """N segments' features, padded to the longest, as an `OACData` (hand_true: zeros, unknown here)."""
    lengths = np.array([len(s.pos2d) for s in segments])
    T = int(lengths.max())

    def pad(field):
        rows = [getattr(s, field) for s in segments]
        out = np.zeros((len(rows), T) + rows[0].shape[1:], np.float32)
        for i, row in enumerate(rows):
            out[i, :len(row)] = row
        return out

    ints = lambda v: np.asarray(v, int)  # noqa: E731
    return OACData(action=ints(action), object=ints(obj), person=ints(person), repetition=ints(repetition),
                   lengths=lengths, pos2d=pad("pos2d"), pos3d=pad("pos3d"), hand_hog=pad("hand_hog"),
                   object_hog=pad("object_hog"), hand_true=np.zeros((len(segments), T, 3), np.float32))


def pipeline_features(out: dict, spec: FeatureSpec) -> FrameFeatures:
    """The features of every frame of a recording from the video front end and our object masks
    (`stages.recording_objects`'s dict): the hand is the skin-labelled pixels near the tracked hand
    ellipse (`hand_reach`), in frames where it is tracked in both views."""
    positions, labels = out["positions"], out["labels"]
    tracks = positions.skin_left
    near = ellipse_masks(labels.shape[1:], np.asarray(tracks.position)[:, HAND], np.asarray(tracks.cov)[:, HAND],
                         spec.hand_reach)
    hand_mask = (labels == SKIN) & near & out["tracked"][:, None, None]
    return frame_features(out["grey"], hand_mask, out["hand"], windows(out["grey"], out["hand"], out["half"]),
                          out["ours"][0], np.asarray(positions.xy_left), np.asarray(positions.xyz),
                          np.asarray(positions.found_3d), spec)


def renderer_features(rec, grey: np.ndarray, half: tuple[int, int], spec: FeatureSpec) -> FrameFeatures:
    """The same features from the renderer's ground truth of the recording (`experiments.data.video.
    Recording`): its hand-skin label near the true right-hand ellipse, the held object's label in the
    window around the true hand, the true mask centroids and 3-D centres."""
    centre, cov, found = rec.ellipse_centre[:, 0], rec.ellipse_cov[:, 0], rec.ellipse_found[:, 0]
    hand_rc = centre[:, TRUE_HAND, ::-1]
    near = ellipse_masks(grey.shape[1:], centre[:, TRUE_HAND], cov[:, TRUE_HAND], spec.hand_reach)
    hand_mask = (rec.left_labels == TRUE_HAND_SKIN) & near & found[:, TRUE_HAND, None, None]
    return frame_features(grey, hand_mask, hand_rc, windows(grey, hand_rc, half),
                          windows(rec.left_labels >= TRUE_OBJECT, hand_rc, half, fill=False),
                          centre[:, TRUE_HAND] - centre[:, TRUE_FACE], rec.hand_cam - rec.face_cam,
                          found[:, TRUE_HAND] & found[:, TRUE_FACE], spec)


def hand_window_features(grey: np.ndarray, labels: np.ndarray, centres: np.ndarray,
                         half: tuple[int, int]) -> np.ndarray:
    """(T, D) features of the "object in hand" classifier (`in_hand`) in the windows of `WINDOW_SCALE`
    times the half size `half` around the hand positions centres (T, 2) (row, column): the HOG
    (`IN_HAND_HOG`) of the grey frames (T, H, W), then, per cell of a `LABEL_GRID` x `LABEL_GRID` grid,
    the fractions of its pixels the front end's labels (T, H, W) call person, skin and object (the held
    object's extent beside the hand, whatever it looks like). Outside the image: grey 0, background.
    One is added to every grey pixel: a window wholly outside the image is then not an all-zero image
    (which `hog_jax.hog` refuses), and no gradient changes."""
    images = as_array(grey, "grey", ndim=3)
    regions = as_array(labels, "labels", shape=images.shape, dtype=np.int32)
    at = as_array(centres, "centres", shape=(len(images), 2))
    big = tuple(round(WINDOW_SCALE * h) for h in half)
    hog = np.asarray(hog_jax.hog(windows(images, at, big, fill=0).astype(np.float32) + 1.0, IN_HAND_HOG))
    around = windows(regions, at, big, fill=BACKGROUND)
    rows, cols = (np.linspace(0, n, LABEL_GRID + 1).astype(int) for n in around.shape[1:])
    fractions = [np.mean(around[:, r0:r1, c0:c1] == region, axis=(1, 2)) for r0, r1 in zip(rows[:-1], rows[1:])
                 for c0, c1 in zip(cols[:-1], cols[1:]) for region in (PERSON, SKIN, OBJECT)]
    return np.concatenate([hog, np.stack(fractions, axis=1)], axis=1)
