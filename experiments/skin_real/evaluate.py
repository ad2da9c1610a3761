"""All photos through the three segmentations, `batch_size` at a time: pixel counts, the hand-found
test and the precision/recall curve of our model over thresholds, with each method's time.

The JAX parts (our log ratio, median filter and threshold curve; the YCrCb rule) run on padded
batches of one shape, so they compile once (the last batch is filled up with copies of its last
photo, which count nowhere); GrabCut and the connected components run in OpenCV, GrabCut one photo
at a time (its only interface). Times exclude compilation, which is timed apart on the first batch.
"""
from __future__ import annotations

import time
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from experiments.config import progress
from experiments.data.hand_photos import Photo, pad_photos
from experiments.skin_real import methods
from experiments.skin_real.metrics import confusion_counts, hand_found
from hog_jax import skin_log_ratio

OURS, YCRCB, YCRCB_UNFILTERED, GRABCUT = "ours", "ycrcb", "ycrcb_unfiltered", "grabcut"
METHODS = (OURS, YCRCB, YCRCB_UNFILTERED, GRABCUT)
SHEET_METHODS = (OURS, YCRCB, GRABCUT)


class Evaluation(NamedTuple):
    """counts: method -> (N, 3) (true positive, false positive, false negative) pixels per photo;
    found / largest_iou: method -> (N,) the hand-found test and its IoU; curve (T, 3) pooled counts of
    ours at each curve threshold; sheet: (photo, {method: mask (h, w)}) of the contact-sheet photos;
    seconds: ours / ycrcb (both masks) / grabcut / curve / components / compile -> s; grabcut_not_run:
    photos whose seed was all one label."""

    names: list
    counts: dict
    found: dict
    largest_iou: dict
    curve: np.ndarray
    sheet: list
    seconds: dict
    grabcut_not_run: int


def _jax_masks(model, threshold, thresholds, batch, real, seconds: dict) -> tuple[np.ndarray, ...]:
    """(ours, ycrcb filtered, ycrcb raw) host masks (B, H, W) and the curve counts (T, 3) of one padded
    batch, whose photos marked by `real` (B,) count; each part's time is added to `seconds`."""
    t0 = time.perf_counter()
    ratio = skin_log_ratio(model, batch.rgb)
    ours = np.asarray(methods.ours_masks(ratio, threshold, batch.rows, batch.cols))
    t1 = time.perf_counter()
    raw, filt = (np.asarray(a) for a in methods.ycrcb_masks(batch.rgb, batch.rows, batch.cols))
    t2 = time.perf_counter()
    valid = batch.valid & real[:, None, None]
    curve = np.asarray(methods.curve_counts(ratio, thresholds, batch.rows, batch.cols, batch.truth & valid, valid))
    seconds[OURS] += t1 - t0
    seconds[YCRCB] += t2 - t1
    seconds["curve"] += time.perf_counter() - t2
    return ours, filt, raw, curve


def evaluate_photos(cfg, model, threshold: float, photos: list[Photo]) -> Evaluation:
    """Every photo through ours, the YCrCb rule (filtered and raw) and GrabCut from our mask."""
    shape = tuple(np.max([p.truth.shape for p in photos], axis=0))
    B = cfg.batch_size
    thr, thresholds = jnp.float32(threshold), jnp.asarray(cfg.curve_thresholds, jnp.float32)
    sheet_index = set(np.linspace(0, len(photos) - 1, min(cfg.sheet_photos, len(photos))).round().astype(int))
    counts = {m: [] for m in METHODS}
    found = {m: [] for m in METHODS}
    largest_iou = {m: [] for m in METHODS}
    seconds = dict.fromkeys((OURS, YCRCB, GRABCUT, "curve", "components"), 0.0)
    curve, sheet, not_run = np.zeros((len(cfg.curve_thresholds), 3), np.int64), [], 0

    def padded(start):
        chunk = photos[start:start + B]
        real = np.arange(B) < len(chunk)
        return chunk, pad_photos(chunk + [chunk[-1]] * (B - len(chunk)), shape), real

    warm_up = dict.fromkeys((OURS, YCRCB, "curve"), 0.0)
    _jax_masks(model, thr, thresholds, *padded(0)[1:], warm_up)  # compiles; chunk 0 is timed again below
    first_batch_s = None
    for start in progress(range(0, len(photos), B), desc="photos", total=-(-len(photos) // B)):
        chunk, batch, real = padded(start)
        before = sum(seconds[k] for k in warm_up)
        ours, filt, raw, batch_curve = _jax_masks(model, thr, thresholds, batch, real, seconds)
        curve += batch_curve
        first_batch_s = sum(seconds[k] for k in warm_up) - before if first_batch_s is None else first_batch_s
        grab = np.zeros_like(ours)
        t0 = time.perf_counter()
        for i, photo in enumerate(chunk):
            h, w = photo.truth.shape
            grab[i, :h, :w], ran = methods.grabcut(photo.bgr, ours[i, :h, :w], cfg.grabcut_iterations)
            not_run += not ran
        seconds[GRABCUT] += time.perf_counter() - t0
        masks = {OURS: ours, YCRCB: filt, YCRCB_UNFILTERED: raw, GRABCUT: grab}
        n = len(chunk)
        t0 = time.perf_counter()
        for m, mask in masks.items():
            counts[m].append(confusion_counts(mask[:n], batch.truth[:n], batch.valid[:n]))
            f, iou = hand_found(mask[:n], batch.truth[:n], batch.valid[:n], cfg.hand_iou)
            found[m].append(f)
            largest_iou[m].append(iou)
        seconds["components"] += time.perf_counter() - t0
        for i, photo in enumerate(chunk):
            if start + i in sheet_index:
                h, w = photo.truth.shape
                sheet.append((photo, {m: masks[m][i, :h, :w] for m in SHEET_METHODS}))
    seconds["compile"] = max(sum(warm_up.values()) - first_batch_s, 0.0)
    cat = lambda d: {m: np.concatenate(v) for m, v in d.items()}
    return Evaluation([p.name for p in photos], cat(counts), cat(found), cat(largest_iou), curve, sheet, seconds,
                      not_run)
