"""The video front end of the learning-from-demonstration study on one long recording: segmentation
and hand tracks (`hog_jax.video.segment_stereo`), then the object in the hand's window per frame from
phase differences (`hog_jax.video.segment_objects`, LfD 2009 §III-B) beside the OpenCV peer."""
from __future__ import annotations

import jax
import numpy as np

import hog_jax
from experiments.data import video
from experiments.lfd_demonstration.config import Config
from experiments.lfd_demonstration.evaluate import hand_width, truth_windows
from experiments.peers.object_peer import peer_object_masks
from experiments.video_segmentation.stages import background_options, camera_of, pad, segmentation_start
from hog_jax.video import (HAND, PERSON, SKIN, HandFaceOptions, ObjectOptions, TrackOptions, VideoOptions,
                           fit_video_models, segment_stereo)


def front_end(rec, rgb_skin, settings, key, pad_frames: int, coarse_scale: bool = True, min_area: int = 4):
    """The video front end of issue 18 on one recording: (labels of the left view (T, H, W),
    `HandFacePositions`, segmentation start). coarse_scale: `VideoOptions.coarse_scale`; min_area: the
    smallest blob tracked (`hand_face_positions`), pixels."""
    options = VideoOptions(background=background_options(settings), coarse_scale=coarse_scale)
    start = segmentation_start(settings)
    left, right, T = pad(rec, pad_frames)
    models, _ = fit_video_models(key, rgb_skin, left, start, options)
    tracking = HandFaceOptions(min_area=min_area, tracking=TrackOptions(min_init=3))
    seg = segment_stereo(models, left, right, start, camera_of(rec), options, tracking)
    cut = lambda a: np.asarray(a)[:T] if np.ndim(a) and np.shape(a)[0] == left.shape[0] else a
    return cut(seg.left.labels), jax.tree.map(cut, seg.positions), start


def hand_tracks(positions, start: int):
    """(left (T, 2), right (T, 2) hand positions (row, column), tracked (T,) bool): the tracked right
    hand in both views (before `start` and where either view lost it: not tracked, positions held)."""
    rows = lambda tracks: np.asarray(tracks.position)[:, HAND, ::-1].astype(np.float64)
    tracked = ~np.asarray(positions.skin_left.lost)[:, HAND] & ~np.asarray(positions.skin_right.lost)[:, HAND]
    tracked[:start] = False
    return rows(positions.skin_left), rows(positions.skin_right), tracked


def recording_objects(cfg: Config, settings, rec, rgb_skin, index: int, peer: bool = True) -> dict | None:
    """One long recording through the front end, then the object in the hand's window per frame, ours
    and the peer's: {"ours" / "peer": (masks (T, h, w), found (T,)), "truth", "tracked", "decided",
    "labels" and "positions" of the front end, ...} ("peer" None without `peer`: the clips need only
    ours); None when the hand is never found (a flagged recording)."""
    scale = cfg.scale(settings)
    half = (round(cfg.half_window * scale),) * 2
    labels, positions, start = front_end(rec, rgb_skin, settings, jax.random.key(cfg.seed + index), cfg.pad_frames)
    hand_l, hand_r, tracked = hand_tracks(positions, start)
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
