"""The held object's pixels in the hand's window from where held objects lie beside the hand, the front
end's labels and LfD 2009 §III-B's phase cues: a per-pixel logistic regression trained on the
pre-segmented clips of other persons (the renderer's object mask in their held frames), applied in the
frames the "object in hand" classifier (`in_hand`) holds an object.

Why beside the paper's masks (`hog_jax.video.segment_objects`): on the study's renders the phase cues
hardly tell the held object's pixels from the window's others (pixel AUC 0.56-0.62, `in_hand`'s
docstring), and the paper's selection of one region from them keeps a mask in a quarter of the held
frames (pooled IoU 0.13 over the held frames of three validation recordings of the quick preset; the
OpenCV peer 0.16). Where a held object lies relative to the hand's tip is much the same from one person
to the next (the object beside the fingers), and the front end's labels mark moving pixels that are
neither person nor skin. Validation (pooled IoU over the true held frames of the quick preset's seeds 1-3 /
the paper preset's seed 1, each recording with a model fitted on the other recordings): the position
prior alone 0.32 / 0.39, with the phase cues 0.32 / 0.40, with the labels 0.41 / 0.43, all three 0.41 /
0.44 (the phase cues' weights stay near 0.1 per nat). The paper's selection after the threshold (the
region nearest the hand, holes filled, opened) lowered all three to 0.32 / 0.43 and raised the prior
with the phase cues to 0.34 / 0.50 (threshold -1.5): no choice was better at both scales; the thresholded
pixels of all three, best on average, are the mask.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

import crf_jax
from experiments.lfd_demonstration.features import windows
from hog_jax.video import OBJECT, PERSON, SKIN, ObjectSegmentation
from lfd_common import as_array, check_real

# nats: a pixel is the object's where its log odds exceed this (p > 0.27); chosen on the validation recordings
# (pooled IoU 0.41 / 0.44 at -1, 0.41 / 0.43 at -1.5, 0.37 / 0.41 at -0.5, 0.29 / - at 0: an IoU rewards
# covering the object's uncertain rim)
MASK_LOG_ODDS = -1.0
CUE_CAP = 5.0  # nats: the phase cues' log ratios are clipped to +-CUE_CAP (a few pixels reach hundreds)
MAX_FIT_PIXELS = 1_000_000  # the fit sees at most this many training pixels (evenly spaced frames)
N_FEATURES = 6  # position prior, temporal cue, stereo cue, person, skin, object label


class PixelCues(NamedTuple):
    """Per window pixel (T, h, w): the temporal and stereo log ratios of LfD §III-B eqs. 1-4 (0 where not
    valid; the temporal one also 0 where the hand did not move, where eq. 1 equals the static background),
    and the front end's label (`hog_jax.video.REGIONS` index, -1 outside the image)."""

    temporal: np.ndarray
    stereo: np.ndarray
    labels: np.ndarray


class PixelFrames(NamedTuple):
    """Training windows of the pixel model: the clip's person (N,), the renderer's held-object mask (N, h, w)
    bool and the `PixelCues` (N, h, w) of held, tracked frames."""

    person: np.ndarray
    truth: np.ndarray
    cues: PixelCues

    def take(self, index) -> PixelFrames:
        """The training windows at `index` (an index array or a slice over N)."""
        return PixelFrames(self.person[index], self.truth[index], PixelCues(*(c[index] for c in self.cues)))


class ObjectPixelModel(NamedTuple):
    """A per-pixel logistic regression on `pixel_features`.

    Attributes:
        model: the `crf_jax.LinearModel` (classes: 0 not the object, 1 the held object).
        prior_log_odds: (h, w) log odds that a window pixel is the held object's, over the training windows.
    """

    model: crf_jax.LinearModel
    prior_log_odds: np.ndarray


def window_cues(objects: ObjectSegmentation, labels: np.ndarray, centres: np.ndarray,
                half: tuple[int, int]) -> PixelCues:
    """The `PixelCues` of a recording's T frames from its `segment_objects` result (cues of frames 1..T-1;
    frame 0 gets 0) and the front end's labels (T, H, W) in the same windows: half sizes `half` around
    centres (T, 2) (row, column), -1 outside the image."""
    moved = np.asarray(objects.hand_moved, bool)
    frames = as_array(labels, "labels", ndim=3, dtype=np.int32)
    if frames.shape[0] != moved.size:
        raise ValueError(f"labels: expected {moved.size} frames, got {frames.shape[0]}")
    regions = windows(frames, as_array(centres, "centres", shape=(moved.size, 2)), half, fill=-1)

    def cue(ratio, where):
        out = np.zeros(regions.shape, np.float16)
        out[1:] = np.where(where & np.asarray(ratio.valid), np.clip(np.asarray(ratio.log_ratio), -CUE_CAP, CUE_CAP), 0)
        return out

    return PixelCues(cue(objects.temporal, moved[1:, None, None]), cue(objects.stereo, True),
                     regions.astype(np.int8))


def position_prior(truth: np.ndarray) -> np.ndarray:
    """(h, w) log odds that each window pixel is the held object's: the frequency over the training windows
    (N, h, w) bool, with one object and one other pixel added (no pixel is certain)."""
    masks = as_array(truth, "truth", ndim=3, dtype=bool)
    p = (masks.sum(axis=0) + 1.0) / (masks.shape[0] + 2.0)
    return np.log(p / (1.0 - p))


def pixel_features(prior_log_odds: np.ndarray, cues: PixelCues) -> np.ndarray:
    """(T, h, w, `N_FEATURES`) float32: the position prior's log odds (h, w), the temporal and stereo cues,
    and the person / skin / object label indicators of every window pixel."""
    shape = np.shape(cues.labels)
    prior = as_array(prior_log_odds, "prior_log_odds", shape=shape[1:])
    columns = (np.broadcast_to(prior, shape), cues.temporal, cues.stereo,
               *(cues.labels == region for region in (PERSON, SKIN, OBJECT)))
    return np.stack([np.asarray(c, np.float32) for c in columns], axis=-1)


def fit_object_pixels(frames: PixelFrames, l2: float = 1.0) -> ObjectPixelModel:
    """Fit the model to training windows: the position prior over all of them, then the logistic regression
    (`crf_jax.fit_linear`) on the pixels of evenly spaced frames, at most `MAX_FIT_PIXELS`. ValueError
    (naming the argument) without training windows or where every pixel is of one class."""
    prior = position_prior(frames.truth)
    n, h, w = frames.truth.shape
    if frames.truth.all() or not frames.truth.any():
        raise ValueError(f"frames: the training pixels need both classes, got {int(frames.truth.sum())} object "
                         f"pixels of {frames.truth.size}")
    step = -(-n * h * w // MAX_FIT_PIXELS)
    picked = frames.take(slice(None, None, step))
    X = pixel_features(prior, picked.cues).reshape(-1, N_FEATURES)
    y = np.asarray(picked.truth, np.int32).reshape(-1)
    fitted = crf_jax.fit_linear(X, y, l2=check_real(l2, "l2", min_value=0.0))
    return ObjectPixelModel(fitted.model, prior)


def object_pixel_log_odds(model: ObjectPixelModel, cues: PixelCues) -> np.ndarray:
    """(T, h, w) log P(object) / P(other) of every window pixel."""
    features = pixel_features(model.prior_log_odds, cues)
    log_p = np.asarray(crf_jax.linear_log_proba(model.model, features.reshape(-1, N_FEATURES)), np.float64)
    return (log_p[:, 1] - log_p[:, 0]).reshape(features.shape[:-1])


def object_pixel_masks(model: ObjectPixelModel, cues: PixelCues, held: np.ndarray) -> np.ndarray:
    """(T, h, w) bool: the pixels whose log odds exceed `MASK_LOG_ODDS` in the frames held (T,) says hold an
    object; empty elsewhere."""
    in_hand = as_array(held, "held", shape=(np.shape(cues.labels)[0],), dtype=bool)
    return (object_pixel_log_odds(model, cues) > MASK_LOG_ODDS) & in_hand[:, None, None]

