"""The real-video part of the study, person, face and hands: the front end on the real reach clip
(`experiments.data.video.reach_clip`), its face and hand tracks scored against the project's own boxes
on eight frames, and a contact sheet of the labels, the tracks and the boxes."""
from __future__ import annotations

from pathlib import Path

import jax
import numpy as np

from experiments.config import StageResult
from experiments.data.video import reach_clip
from hog_jax.video import (FACE, HAND, OTHER_HAND, REGIONS, HandFaceOptions, VideoOptions, fit_video_models,
                           track_mono)
from lfd_jax import fit_real_skin_model, load_video

TRACKED_PARTS = {"face": FACE, "right_hand": HAND, "left_hand": OTHER_HAND}
MIN_AREA_SHARE = 1e-3  # skin blobs smaller than this share of the frame are not tracked (specks of the wall)


def track_clip(cfg, frames: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray], int]:
    """(labels (T, H, W) in `REGIONS` order, part -> (T, 2) tracked (x, y), NaN where not tracked, the
    first segmented frame): the
    mono front end for real video (`VideoOptions.real_video()`, the one skin model fitted on real pixels
    and adapted to the person, `track_mono` with the hands at the far end of the arm)."""
    skin = fit_real_skin_model(cfg.real_data, seed=cfg.seed)
    options = VideoOptions.real_video()
    start = max(options.person_frames + 1, len(frames) // 3)
    models, _ = fit_video_models(jax.random.key(cfg.seed + 1), skin, frames, start, options)
    height, width = frames.shape[1:3]
    tracking = HandFaceOptions(min_area=max(4, round(MIN_AREA_SHARE * height * width)))
    out = track_mono(models, frames, start, options, tracking)
    position = np.asarray(out.tracks.position, float)
    position[:, [HAND, OTHER_HAND]] = out.hands
    return out.labels, {part: np.where(out.tracked[:, k, None], position[:, k], np.nan)
                        for part, k in TRACKED_PARTS.items()}, start


def reach_stage(cfg, plots) -> StageResult:
    """Face and hand tracks on the real reach clip against the boxes; skipped, saying so, without the clip."""
    path = Path(cfg.real_data) / reach_clip.CLIP
    if not path.is_file():
        print(f"note: {path} not found; the reach clip is skipped")
        return StageResult({"reach_scored": False})
    frames = load_video(path).frames
    labels, positions, start = track_clip(cfg, frames)
    boxes = reach_clip.clip_boxes()
    scores = reach_clip.score_tracks(positions, boxes)
    metrics = {"reach_scored": True, "reach_frames": len(frames), "reach_start": start,
               "reach_annotated_before_start": int(np.sum(boxes.frames < start))}
    for part, s in scores.items():
        metrics[f"reach_{part}_on_part"] = s["on_part"]
        metrics[f"reach_{part}_centre_distance_px"] = s["centre_distance_px"]
    metrics["reach_skin_fraction"] = float(np.mean(labels == REGIONS.index("skin")))
    figure = plots.reach_sheet(frames, labels, positions, boxes)
    return StageResult(metrics, {"reach_clip_sheet.png": figure})
