"""The video front end of the learning-from-demonstration study on one long recording: segmentation
and hand tracks (`hog_jax.video.front_end`), then the object in the hand's window per frame from
phase differences (`hog_jax.video.segment_objects`, LfD 2009 §III-B) beside the OpenCV peer."""
from __future__ import annotations

import cv2
import jax
import numpy as np

import hog_jax
from experiments.data import video
from experiments.lfd_demonstration.config import Config
from experiments.lfd_demonstration.evaluate import hand_width, truth_windows
from experiments.peers.object_peer import peer_object_masks
from hog_jax.video import (FACE, HAND, PERSON, SKIN, BackgroundOptions, HandFaceOptions, ObjectOptions, TrackOptions,
                           VideoOptions, front_end, stereo_camera_from_matrices)


ELONGATED = 1.5  # major over minor standard deviation of a skin blob that is a forearm with its hand
TIP_WIDTHS = 1.5  # the hand: the blob's pixels within this many blob widths of its tip


def hand_tip(skin: np.ndarray, hand: np.ndarray, face: np.ndarray, tracked: np.ndarray, reach: int) -> np.ndarray:
    """The hand's centre (T, 2) (row, column) at the free end of its skin blob.

    The tracked hand is the centroid of its skin blob, which takes in a bare forearm: on a
    validation recording (paper preset, seed 1, two OACs) it lay a median 10.4 px (at 320 x 240)
    from the renderer's hand, half the window the object is looked for in (LfD 2009 §III-B,
    assumption 1), and the window missed the object held beyond the fingers. Per tracked frame: the
    8-connected skin component within `reach` px (max norm) nearest the tracked position; where it
    is elongated (`ELONGATED`), the centroid of its pixels within `TIP_WIDTHS` widths (4 sqrt(smallest
    eigenvalue), as `hand_width`) of the end of its major axis nearer the face's column. The forearm
    runs from the elbow, outside, to the hand, nearer the body's midline: the nearer end was the
    hand in 90 % of the elongated blobs of that recording, and the window's centre moved to a
    median 5.4 px from the renderer's hand. Elsewhere (a compact blob, no skin near, not tracked)
    the tracked position.

    Args:
        skin: (T, H, W) bool, the front end's skin pixels of the left view.
        hand: (T, 2) the tracked hand (row, column).
        face: (T, 2) the tracked face (row, column).
        tracked: (T,) bool, the frames whose hand is tracked.
        reach: px, >= 1, the crop around the tracked hand searched for its blob.

    Returns:
        (T, 2) float64 positions.
    """
    out = np.asarray(hand, np.float64).copy()
    for t in np.flatnonzero(tracked):  # OpenCV's components are per image
        r0, c0 = (int(round(v)) for v in out[t])
        top, left = max(r0 - reach, 0), max(c0 - reach, 0)
        crop = skin[t, top:r0 + reach + 1, left:c0 + reach + 1].astype(np.uint8)
        _, labels = cv2.connectedComponents(crop, connectivity=8)
        rows, cols = np.nonzero(labels)
        if rows.size < 3:
            continue
        nearest = np.argmin(np.hypot(rows + top - r0, cols + left - c0))
        own = labels[rows, cols] == labels[rows[nearest], cols[nearest]]
        pts = np.stack([rows[own] + top, cols[own] + left], axis=1).astype(np.float64)
        if len(pts) < 3:
            continue
        centre = pts.mean(axis=0)
        variances, axes = np.linalg.eigh(np.cov((pts - centre).T))  # ascending
        if variances[1] <= ELONGATED ** 2 * max(variances[0], 1e-12):
            continue
        axis = axes[:, 1]
        along = (pts - centre) @ axis
        ends = centre + np.outer([along.max(), along.min()], axis)
        sign = 1.0 if abs(ends[0, 1] - face[t][1]) <= abs(ends[1, 1] - face[t][1]) else -1.0
        tip = along.max() if sign > 0 else along.min()
        width = 4.0 * np.sqrt(max(variances[0], 0.0))
        out[t] = pts[sign * (along - tip) >= -TIP_WIDTHS * width].mean(axis=0)
    return out


def recording_objects(cfg: Config, settings, rec, skin_model, index: int, peer: bool = True) -> dict | None:
    """One long recording through the front end, then the object in the hand's window per frame, ours
    and the peer's, the window centred on the hand's tip (`hand_tip`; "hand" (T, 2)): {"ours" / "peer":
    (masks (T, h, w), found (T,)), "truth", "tracked", "decided",
    "labels" and "positions" of the front end, ...} ("peer" None without `peer`: the clips need only
    ours); None when the hand is never found (a flagged recording)."""
    scale = cfg.scale(settings)
    half = (round(cfg.half_window * scale),) * 2
    start = video.segmentation_start(settings)
    camera = stereo_camera_from_matrices(rec.P_left, rec.P_right, *rec.left.shape[1:3])
    out = front_end(jax.random.key(cfg.seed + index), skin_model, rec.left, rec.right, start, camera,
                    VideoOptions(background=BackgroundOptions.for_fps(settings.fps)),
                    HandFaceOptions(tracking=TrackOptions(min_init=3)), pad_multiple=cfg.pad_frames)
    labels, positions, tracked = out.labels, out.positions, out.tracked
    observed = np.asarray(positions.skin_left.observed)[:, HAND] & tracked
    if not observed.any():
        return None
    sigma = hand_width(np.asarray(positions.skin_left.cov)[:, HAND], observed)
    face = np.asarray(positions.skin_left.position)[:, FACE, ::-1]
    hand_l = hand_tip(labels == SKIN, out.hand_left, face, tracked, 2 * half[0])
    hand_r = out.hand_right + (hand_l - out.hand_left)  # the tip at the blob's disparity: rectified views
    gl, gr = video.grey(rec.left), video.grey(rec.right)
    removed = (labels == SKIN) | ((labels == PERSON) if cfg.remove_person else False)  # not the object
    ours = hog_jax.video.segment_objects(
        jax.random.key(cfg.seed + 1000 + index), gl, gr, hand_l, hand_r, removed,
        ObjectOptions(half, sigma, max_offset=half[1], blur_sigma=cfg.blur_sigma * scale, n_samples=cfg.n_samples,
                      threshold=cfg.threshold, min_hand_motion=cfg.min_hand_motion * scale))
    gate = lambda masks, found: (masks & tracked[:, None, None], found & tracked)
    return {"ours": gate(np.asarray(ours.masks), np.asarray(ours.found)),
            "peer": gate(*peer_object_masks(gl, gr, hand_l, hand_r, removed, half)) if peer else None,
            "truth": truth_windows(rec.left_labels, hand_l, half), "tracked": tracked,
            "decided": np.asarray(ours.hand_moved) & tracked, "objects": ours, "sigma_px": sigma, "start": start,
            "grey": gl, "half": half, "hand": hand_l, "hand_right": hand_r, "labels": labels, "positions": positions}
