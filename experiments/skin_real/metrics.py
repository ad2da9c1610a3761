"""Pixel scores of skin masks against the true masks, and the "hand found" test (the threshold choice is
`lfd_jax.best_iou_threshold`).

Pixel scores count only real pixels (`valid`): true positives (skin called skin), false positives
and false negatives, per photo. Pooled scores sum the counts over the photos first (so large photos
weigh more); the mean per photo averages each photo's IoU.

Hand found: the largest 8-connected component of a method's mask has IoU >= `min_iou` (0.5 by
default) with the photo's true skin mask (hand and forearm, all of it). A photo where the method
finds no skin counts as not found. The test asks that one blob, the one a "largest component"
pipeline such as `hog_jax.segment` would crop, covers most of the true hand and little else.
"""
from __future__ import annotations

import numpy as np

from hog_jax.video import connected_blobs

TRUE_POSITIVE, FALSE_POSITIVE, FALSE_NEGATIVE = 0, 1, 2


def confusion_counts(pred: np.ndarray, truth: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(B, 3) int64 (true positive, false positive, false negative) pixels of bool masks (B, H, W)
    over the `valid` pixels."""
    pred, truth = np.asarray(pred, bool) & valid, np.asarray(truth, bool) & valid
    return np.stack([(pred & truth).sum((1, 2)), (pred & ~truth).sum((1, 2)), (~pred & truth).sum((1, 2))],
                    axis=1).astype(np.int64)


def _ratio(numerator, denominator, empty: float) -> np.ndarray:
    """numerator / denominator elementwise, `empty` where the denominator is 0."""
    numerator, denominator = np.asarray(numerator, np.float64), np.asarray(denominator, np.float64)
    return np.where(denominator > 0, numerator / np.maximum(denominator, 1), empty)


def pooled_scores(counts: np.ndarray) -> dict[str, float]:
    """Precision, recall and IoU of counts (..., 3) summed over every leading axis; precision is NaN
    when nothing was called skin, recall NaN when there is no true skin, IoU 1 when both are empty."""
    tp, fp, fn = np.asarray(counts).reshape(-1, 3).sum(0)
    return {"precision": float(_ratio(tp, tp + fp, np.nan)), "recall": float(_ratio(tp, tp + fn, np.nan)),
            "iou": float(_ratio(tp, tp + fp + fn, 1.0))}


def per_photo_iou(counts: np.ndarray) -> np.ndarray:
    """(B,) IoU of each photo's counts (B, 3); 1 where mask and truth are both empty."""
    counts = np.asarray(counts)
    tp = counts[:, TRUE_POSITIVE]
    return _ratio(tp, counts.sum(1), 1.0)


def largest_components(masks: np.ndarray) -> np.ndarray:
    """(B, H, W) bool: the largest 8-connected component of each mask (OpenCV, through
    `hog_jax.video.connected_blobs`; ties as OpenCV orders them); all False for an empty mask."""
    return np.asarray(connected_blobs(np.asarray(masks, bool), max_blobs=1).labels) == 1


def hand_found(masks: np.ndarray, truth: np.ndarray, valid: np.ndarray,
               min_iou: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """(found (B,) bool, iou (B,)): the IoU of each mask's largest component with the true mask, and
    whether it reaches `min_iou` (the module docstring's definition)."""
    largest = largest_components(np.asarray(masks, bool) & valid)
    iou = per_photo_iou(confusion_counts(largest, truth, valid))
    return iou >= min_iou, iou


def threshold_counts(log_ratio: np.ndarray, is_skin: np.ndarray, thresholds) -> np.ndarray:
    """(T, 3) (true positive, false positive, false negative) counts of "skin where log_ratio >
    t" on labelled pixels (N,), one row per threshold t."""
    pred = np.asarray(log_ratio)[None, :] > np.asarray(thresholds, np.float64)[:, None]
    is_skin = np.asarray(is_skin, bool)[None, :]
    return np.stack([(pred & is_skin).sum(1), (pred & ~is_skin).sum(1), (~pred & is_skin).sum(1)], axis=1)


def curve_scores(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(precision (T,), recall (T,), IoU (T,)) of pooled counts (T, 3), one row per threshold."""
    tp, fp, fn = (np.asarray(counts, np.float64)[:, i] for i in range(3))
    return _ratio(tp, tp + fp, np.nan), _ratio(tp, tp + fn, np.nan), _ratio(tp, tp + fp + fn, 1.0)
