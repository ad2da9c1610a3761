"""The video front end of the learning-from-demonstration study on one long recording: segmentation
and hand tracks (`hog_jax.video.front_end`), then the object in the hand's window per frame from
phase differences (`hog_jax.video.segment_objects`, LfD 2009 §III-B) beside the OpenCV peer."""
from __future__ import annotations

import jax
import numpy as np

import hog_jax
from experiments.data import video
from experiments.lfd_demonstration.config import Config
from experiments.lfd_demonstration.evaluate import hand_width, truth_windows
from experiments.peers.object_peer import peer_object_masks
from hog_jax.video import (HAND, PERSON, SKIN, BackgroundOptions, HandFaceOptions, ObjectOptions, TrackOptions,
                           VideoOptions, front_end, stereo_camera_from_matrices)


def recording_objects(cfg: Config, settings, rec, skin_model, index: int, peer: bool = True) -> dict | None:
    """One long recording through the front end, then the object in the hand's window per frame, ours
    and the peer's: {"ours" / "peer": (masks (T, h, w), found (T,)), "truth", "tracked", "decided",
    "labels" and "positions" of the front end, ...} ("peer" None without `peer`: the clips need only
    ours); None when the hand is never found (a flagged recording)."""
    scale = cfg.scale(settings)
    half = (round(cfg.half_window * scale),) * 2
    start = video.segmentation_start(settings)
    camera = stereo_camera_from_matrices(rec.P_left, rec.P_right, *rec.left.shape[1:3])
    out = front_end(jax.random.key(cfg.seed + index), skin_model, rec.left, rec.right, start, camera,
                    VideoOptions(background=BackgroundOptions.for_fps(settings.fps)),
                    HandFaceOptions(tracking=TrackOptions(min_init=3)), pad_multiple=cfg.pad_frames)
    labels, positions, hand_l, hand_r, tracked = out.labels, out.positions, out.hand_left, out.hand_right, out.tracked
    observed = np.asarray(positions.skin_left.observed)[:, HAND] & tracked
    if not observed.any():
        return None
    sigma = hand_width(np.asarray(positions.skin_left.cov)[:, HAND], observed)
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
            "grey": gl, "half": half, "hand": hand_l, "labels": labels, "positions": positions}
