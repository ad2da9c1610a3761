"""Per-recording evaluation of the three segmentations against MuJoCo's ground truth:
(a) the skin model alone, (b) level sets with the background model, (c) (b) plus tracking.

Hand and face from a skin mask without tracking take the tracker's acquisition rule on every frame
(LfD 2009 §III-A, connected components): of the three largest skin blobs, the face is the highest,
the hand the leftmost other one (the right hand of a person facing the camera). Ground truth: label 2 is skin of both
hands and forearms, so the true hand is its connected component nearest the right hand's projected
centre; label 3 the face, 1 the person, >= 4 a held object. IoUs are pooled over the frames of the
segmentation phase (intersections and unions summed); a frame where a method finds no hand counts
its whole true hand as missed.
"""
from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

import hog_jax
from hog_jax.video import connected_blobs
from hog_jax.video import FACE, HAND

GT_PERSON, GT_HAND, GT_FACE, GT_OBJECT = 1, 2, 3, 4
SKIN_ONLY, LEVEL_SETS, TRACKED = "skin_only", "levelset_no_tracking", "full"
METHODS = (SKIN_ONLY, LEVEL_SETS, TRACKED)
MAX_BLOBS, MIN_AREA = 8, 4
RULE_BLOBS = 3  # face and two hands


class Counts(NamedTuple):
    """Pooled intersections and unions per (method, region), centroid errors and flags per frame."""

    inter: dict
    union: dict
    hand_error_px: dict          # method -> (F,) px, NaN where no hand was found
    merged: np.ndarray           # (F,) bool: the true hand touches the face
    hand_error_3d_cm: np.ndarray  # (F,) NaN where not found in 3-D
    iou_series: np.ndarray       # (F,) IoU of the full pipeline's hand per frame


def true_hand(labels: np.ndarray, centre: np.ndarray, found: np.ndarray) -> np.ndarray:
    """(T, H, W) bool: the connected component of label 2 nearest to the hand's centre (T, 2) (x, y)."""
    blobs = connected_blobs(labels == GT_HAND, MAX_BLOBS, 1)
    slot = _nearest_slot(np.asarray(blobs.centroid), np.asarray(blobs.valid), centre)
    mask = np.asarray(blobs.labels) == (slot + 1)[:, None, None]
    return mask & (found & (slot >= 0))[:, None, None]


def _nearest_slot(centroids: np.ndarray, valid: np.ndarray, point: np.ndarray) -> np.ndarray:
    d = np.linalg.norm(centroids - point[:, None, :], axis=-1)
    d = np.where(valid, d, np.inf)
    slot = np.argmin(d, axis=1)
    return np.where(np.isfinite(d[np.arange(len(d)), slot]), slot, -1)


def rule_hand_face(skin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hand and face masks (T, H, W) from skin masks by the acquisition rule, frame by frame."""
    blobs = connected_blobs(skin, MAX_BLOBS, MIN_AREA)
    valid, centroid = np.asarray(blobs.valid).copy(), np.asarray(blobs.centroid)
    valid[:, RULE_BLOBS:] = False  # slots are largest first: face and hands are the largest skin blobs
    face = np.argmin(np.where(valid, centroid[..., 1], np.inf), axis=1)
    others = valid.copy()
    others[np.arange(len(face)), face] = False
    hand = np.argmin(np.where(others, centroid[..., 0], np.inf), axis=1)
    labels = np.asarray(blobs.labels)
    face_mask = (labels == (face + 1)[:, None, None]) & valid.any(1)[:, None, None]
    hand_mask = (labels == (hand + 1)[:, None, None]) & others.any(1)[:, None, None]
    return hand_mask, face_mask


def tracked_hand_face(skin: np.ndarray, tracks) -> tuple[np.ndarray, np.ndarray]:
    """Hand and face masks (T, H, W): the blobs the tracker assigned (its `blob` slots) in the same
    connected components as `tracks.hand_face_positions` computes."""
    labels = np.asarray(connected_blobs(skin, MAX_BLOBS, MIN_AREA).labels)
    slots = np.asarray(tracks.blob)
    return tuple((labels == (slots[:, k] + 1)[:, None, None]) & (slots[:, k] >= 0)[:, None, None]
                 for k in (HAND, FACE))


def _centroid(mask: np.ndarray) -> np.ndarray:
    """(T, 2) (x, y) centroids, NaN for an empty mask."""
    e = hog_jax.video.mask_ellipse(mask)
    return np.where(np.asarray(e.found)[:, None], np.asarray(e.centroid, float), np.nan)


def touching(hand: np.ndarray, face: np.ndarray) -> np.ndarray:
    """(T,) the hand mask, grown by one pixel, meets the face mask."""
    kernel = np.ones((3, 3), np.uint8)
    grown = np.stack([cv2.dilate(h.astype(np.uint8), kernel) for h in hand]).astype(bool)
    return (grown & face).any(axis=(1, 2))


def evaluate_clip(rec, skin_mask: np.ndarray, seg, start: int, camera) -> Counts:
    """Counts of one recording from frame `start` on: `skin_mask` (T, H, W) of method (a), `seg` the
    `hog_jax.video.StereoSegmentation` of (b) and (c)."""
    sl = slice(start, rec.left.shape[0])
    gt = rec.left_labels[sl]
    centre = rec.ellipse_centre[sl, 0, 0]
    hand_gt = true_hand(gt, centre, rec.ellipse_found[sl, 0, 0])
    face_gt = gt == GT_FACE
    labels = np.asarray(seg.left.labels)[sl]
    skin_ls = labels == hog_jax.video.SKIN
    tracks = _slice_tracks(seg.positions.skin_left, sl)
    masks = {SKIN_ONLY: rule_hand_face(skin_mask[sl]), LEVEL_SETS: rule_hand_face(skin_ls),
             TRACKED: tracked_hand_face(skin_ls, tracks)}
    truth = {"hand": hand_gt, "face": face_gt, "person": gt == GT_PERSON, "object": gt >= GT_OBJECT}
    ours_full = {"hand": masks[TRACKED][0], "face": masks[TRACKED][1], "person": labels == hog_jax.video.PERSON,
                 "object": labels == hog_jax.video.OBJECT}
    inter, union = {}, {}
    for method in METHODS:
        for region in ("hand", "face"):
            inter[method, region] = int((masks[method][region == "face"] & truth[region]).sum())
            union[method, region] = int((masks[method][region == "face"] | truth[region]).sum())
    for region in ("person", "object"):
        inter[TRACKED, region] = int((ours_full[region] & truth[region]).sum())
        union[TRACKED, region] = int((ours_full[region] | truth[region]).sum())
    has_hand = hand_gt.any(axis=(1, 2))
    errors = {m: np.where(has_hand, np.linalg.norm(_centroid(masks[m][0]) - centre, axis=1), np.nan)[has_hand]
              for m in METHODS}
    per_frame = (masks[TRACKED][0] & hand_gt).sum((1, 2)) / np.maximum((masks[TRACKED][0] | hand_gt).sum((1, 2)), 1)
    return Counts(inter, union, errors, touching(hand_gt, face_gt)[has_hand],
                  _hand_error_3d(rec, seg, sl, camera)[has_hand], per_frame)


def _slice_tracks(tracks, sl):
    return type(tracks)(*(np.asarray(v)[sl] for v in tracks))


def _hand_error_3d(rec, seg, sl, camera) -> np.ndarray:
    """(F,) cm: the triangulated tracked hand centroid against the true hand centre (left camera
    frame); NaN where the hand is not tracked in both views."""
    left = np.asarray(seg.positions.skin_left.position)[sl, HAND]
    right = np.asarray(seg.positions.skin_right.position)[sl, HAND]
    tracked = ~np.asarray(seg.positions.skin_left.lost)[sl, HAND] & ~np.asarray(seg.positions.skin_right.lost)[sl, HAND]
    points = hog_jax.video.triangulate(camera, left.astype(float), right.astype(float))
    ok = tracked & np.asarray(points.valid)
    err = 100.0 * np.linalg.norm(np.asarray(points.xyz) - rec.hand_cam[sl], axis=1)
    return np.where(ok, err, np.nan)
