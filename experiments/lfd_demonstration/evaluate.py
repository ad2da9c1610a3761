"""Per-recording evaluation of the object in the hand and of the pick-up / put-down events against
MuJoCo's ground truth: object-mask IoU in the hand's window, and found periods matched to
the true ones.

Ground truth: label >= 4 is the held object, from its pick-up frame to its put-down frame (the last
frame it is held, `Recording.putdown_frames`); a found period's put-down is the first frame after it
(`hog_jax.events.Periods`), so the true one is compared as putdown + 1.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from experiments.lfd_demonstration.features import TRUE_OBJECT as GT_OBJECT, windows


class EventMatch(NamedTuple):
    """Errors in frames (found - true) of the matched periods' pick-ups and put-downs, (M,) each, the
    number of true periods no found period matched (missed) and of found periods that matched no
    true one (spurious), and the matched pairs' indices (M,) into the true and the found periods."""

    pickup_error: np.ndarray
    putdown_error: np.ndarray
    missed: int
    spurious: int
    true_index: np.ndarray = np.zeros(0, int)
    found_index: np.ndarray = np.zeros(0, int)


def truth_windows(labels: np.ndarray, centres: np.ndarray, half: tuple[int, int]) -> np.ndarray:
    """(T, h, w) bool: the held object (label >= 4) in the window around each centre (T, 2) (row,
    column) of the labels (T, H, W); outside the image: not the object."""
    return windows(np.asarray(labels) >= GT_OBJECT, centres, half, fill=False)


def pooled_iou(ours: np.ndarray, truth: np.ndarray) -> tuple[int, int]:
    """(intersection, union) pixel counts summed over the frames of two (T, h, w) masks."""
    return int((ours & truth).sum()), int((ours | truth).sum())


def match_events(true_pickup, true_putdown_last, pickup, putdown) -> EventMatch:
    """Each true period [pick-up, put-down] (put-down the last held frame) is matched to the found
    period [pickup, putdown) (putdown exclusive) that overlaps it most and no other true period has
    taken (greedy, in order of overlap); unmatched ones are missed or spurious."""
    t0, t1 = np.asarray(true_pickup, int), np.asarray(true_putdown_last, int) + 1
    f0, f1 = np.asarray(pickup, int), np.asarray(putdown, int)
    overlap = np.clip(np.minimum(t1[:, None], f1[None]) - np.maximum(t0[:, None], f0[None]), 0, None)
    pairs = []
    free_t, free_f = np.ones(len(t0), bool), np.ones(len(f0), bool)
    for i, j in zip(*np.unravel_index(np.argsort(-overlap, axis=None), overlap.shape)):
        if overlap[i, j] > 0 and free_t[i] and free_f[j]:
            pairs.append((i, j))
            free_t[i] = free_f[j] = False
    i, j = (np.array(v, int) for v in zip(*pairs)) if pairs else (np.zeros(0, int), np.zeros(0, int))
    return EventMatch(f0[j] - t0[i], f1[j] - t1[i], int(free_t.sum()), int(free_f.sum()), i, j)


def hand_width(cov: np.ndarray, observed: np.ndarray) -> float:
    """The hand's width in px (LfD §III-B's sigma_m): the median over the observed frames of the
    tracked blob's minor axis, 4 sqrt(lambda_min) of its second moments (T, 2, 2) (a uniform ellipse's
    full width). ValueError if the hand was never observed."""
    if not np.any(observed):
        raise ValueError("tracks: the hand was never observed, so its width (sigma_m) is unknown")
    smallest = np.linalg.eigvalsh(np.asarray(cov, np.float64)[np.asarray(observed, bool)])[:, 0]
    return float(np.median(4.0 * np.sqrt(np.maximum(smallest, 0.0))))


def held_object_motion(rec) -> tuple[np.ndarray, np.ndarray]:
    """(depth offset (T,) cm, rotation (T,) degrees per frame) of the held object, NaN where none is
    held: the object's centre minus the hand's along the left camera's z (LfD §III-B's failure case: an
    object not at the hand's depth), and the change since the previous frame of the orientation of the
    object's left-view mask ellipse (its major axis, modulo 180 degrees; in-plane rotation, the case
    where the object does not move with the hand's translation)."""
    T = len(rec.object)
    held = np.asarray(rec.object) >= 0
    k = np.where(held, rec.object, 0)
    t = np.arange(T)
    depth = 100.0 * (rec.object_cam[t, k, 2] - rec.hand_cam[:, 2])
    cov = rec.ellipse_cov[t, 0, 2 + k]  # TRACKED: hand, face, then the objects
    angle = np.degrees(0.5 * np.arctan2(2 * cov[:, 0, 1], cov[:, 0, 0] - cov[:, 1, 1]))
    seen = held & rec.ellipse_found[t, 0, 2 + k]
    turn = np.abs((np.diff(angle, prepend=angle[:1]) + 90.0) % 180.0 - 90.0)
    same = np.concatenate([[False], (k[1:] == k[:-1]) & seen[1:] & seen[:-1]])
    return np.where(held, depth, np.nan), np.where(same, turn, np.nan)


def iou_by_bin(ours: np.ndarray, truth: np.ndarray, values: np.ndarray, edges) -> dict[str, float]:
    """Pooled IoU of the (T, h, w) masks over the frames whose value (T,) falls in each [edges[i],
    edges[i + 1]) (NaN frames left out), keyed "lo-hi"; NaN for an empty bin."""
    out = {}
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = np.isfinite(values) & (values >= lo) & (values < hi)
        inter, union = pooled_iou(ours[sel], truth[sel])
        out[f"{lo:g}-{hi:g}"] = inter / union if union else float("nan")
    return out
