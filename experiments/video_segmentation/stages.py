"""The stages of the video segmentation study and its `main`: skin models from some persons,
every clip of the others through (a) skin alone, (b) level sets with the background model and (c)
tracking; the real-video part (`real_background`, `real_person`, `real_reach`) and real skin photos (`real_skin`); figures; one writer."""
from __future__ import annotations

import time

import jax
import numpy as np

import hog_jax
import sim
from experiments.config import StageResult, parse_config
from experiments.data import video
from experiments.video_segmentation import plots
from experiments.video_segmentation.config import PRESETS, Config
from experiments.video_segmentation.evaluate import METHODS, SKIN_ONLY, TRACKED, evaluate_clip
from experiments.video_segmentation.real_background import background_stage
from experiments.video_segmentation.real_person import person_stage
from experiments.video_segmentation.real_reach import reach_stage
from experiments.video_segmentation.real_skin import photo_skin_stage
from experiments.video_segmentation.report import report
from hog_jax.video import (BackgroundOptions, HandFaceOptions, TrackOptions, VideoOptions, fit_video_models, pad_frames,
                           segment_stereo, stereo_camera_from_matrices)
from lfd_common import enable_compilation_cache


def skin_stage(cfg: Config, settings: video.VideoSettings):
    """The skin model of (a) and (b) from the clips of the first `cfg.n_skin_persons`
    (`video.fit_skin_models`), and the pixel counts."""
    return video.fit_skin_models(settings, range(cfg.n_skin_persons), cfg.seed)


def clips_stage(cfg: Config, settings, skin) -> tuple[dict, StageResult, dict]:
    """Every clip of the evaluated persons: the three methods' pooled IoUs and centroid errors."""
    options = VideoOptions(motion_penalty=cfg.motion_penalty, object_margin=cfg.object_margin,
                           person_frames=cfg.person_frames, background=BackgroundOptions.for_fps(settings.fps))
    start = video.segmentation_start(settings)
    inter, union, errors, merged, err3d, series = {}, {}, {m: [] for m in METHODS}, [], [], []
    first = None
    n = 0
    def evaluated(person, cls, rep):
        return person >= cfg.n_skin_persons and (not cfg.eval_repetitions or rep < cfg.eval_repetitions)

    for person, cls, rep, rec in video.selected_clips(settings, evaluated):
        if cfg.max_clips and n >= cfg.max_clips:
            break
        left, right, T = pad_frames(rec.left, cfg.pad_frames), pad_frames(rec.right, cfg.pad_frames), len(rec.left)
        camera = stereo_camera_from_matrices(rec.P_left, rec.P_right, *rec.left.shape[1:3])
        models, _ = fit_video_models(jax.random.key(cfg.seed + n), skin, left, start, options)
        seg = segment_stereo(models, left, right, start, camera, options,
                             HandFaceOptions(tracking=TrackOptions(min_init=3)))
        seg = jax.tree.map(lambda a: np.asarray(a)[:T] if np.ndim(a) and np.shape(a)[0] == left.shape[0] else a, seg)
        skin_mask = np.asarray(hog_jax.segment(skin, rec.left).skin)
        counts = evaluate_clip(rec, skin_mask, seg, start, camera)
        for key in counts.inter:
            inter[key] = inter.get(key, 0) + counts.inter[key]
            union[key] = union.get(key, 0) + counts.union[key]
        for m in METHODS:
            errors[m].append(counts.hand_error_px[m])
        merged.append(counts.merged)
        err3d.append(counts.hand_error_3d_cm)
        series.append(counts.iou_series)
        if first is None:
            first = (rec, seg, start)
        n += 1
    if not n:
        raise ValueError("n_skin_persons: no clip of another person is left to evaluate")
    iou = {f"{m}_{r}": inter[m, r] / max(union[m, r], 1) for (m, r) in inter}
    err = {m: np.concatenate(errors[m]) for m in METHODS}
    merged, err3d = np.concatenate(merged), np.concatenate(err3d)
    metrics = {
        "iou_hand": iou[f"{TRACKED}_hand"], "iou_face": iou[f"{TRACKED}_face"],
        "iou_person": iou[f"{TRACKED}_person"], "iou_object": iou[f"{TRACKED}_object"],
        "iou_hand_skin_only": iou[f"{SKIN_ONLY}_hand"], "iou_hand_levelset_no_tracking": iou["levelset_no_tracking_hand"],
        "iou_face_skin_only": iou[f"{SKIN_ONLY}_face"], "iou_face_levelset_no_tracking": iou["levelset_no_tracking_face"],
        "hand_centroid_error_px": float(np.nanmedian(err[TRACKED])),
        "hand_centroid_error_px_merged": float(np.nanmedian(err[TRACKED][merged])) if merged.any() else float("nan"),
        "hand_error_3d_cm": float(np.nanmedian(err3d)), "n_clips": n, "n_hand_frames": int(len(merged)),
        "n_merged_frames": int(merged.sum()), "hand_found_3d_rate": float(np.mean(np.isfinite(err3d))),
    }
    for m in METHODS:
        metrics[f"hand_centroid_error_px_{m}"] = float(np.nanmedian(err[m]))
        metrics[f"hand_centroid_error_px_merged_{m}"] = float(np.nanmedian(err[m][merged])) if merged.any() else float("nan")
        metrics[f"hand_found_rate_{m}"] = float(np.mean(np.isfinite(err[m])))
    figures = {"iou_over_time.png": plots.iou_over_time(series), "tracks.png": plots.tracks(*first),
               "contact_sheet.png": plots.contact_sheet(*first, cfg.sheet_frames)}
    return metrics, StageResult(metrics, figures), {"first": first}


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, name="video_segmentation", argv=argv)
    enable_compilation_cache()
    start_s = time.perf_counter()
    results, metrics, skin_metrics = [], {}, {}
    if cfg.rendered:
        sim.setup_rendering()
        settings = cfg.video_settings()
        skin, skin_metrics = skin_stage(cfg, settings)
        rendered, clips_result, extra = clips_stage(cfg, settings, skin)
        results.append(clips_result)
        metrics.update(rendered)
        rec, seg, _ = extra["first"]
        video.write_video(plots.overlay_frames(rec, seg), run.file("overlay.mp4"), fps=settings.fps)
    if cfg.real:
        for stage in (background_stage, person_stage, reach_stage, photo_skin_stage):
            result = stage(cfg, plots)
            results.append(result)
            metrics.update(result.metrics)
        metrics["real_skipped"] = not (metrics.get("real_sequences_scored") or metrics.get("reach_scored")
                                       or metrics.get("skin_photos_scored"))
    runtime = time.perf_counter() - start_s
    written = run.write_stages(results, header=report(cfg, metrics, runtime), runtime_s=runtime,
                               real_skipped=metrics.get("real_skipped", True), **skin_metrics)
    print(f"wrote {run.path}/ in {runtime:.0f} s")
    return written
