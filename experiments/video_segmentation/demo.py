"""Demo stage "video" of `experiments.demo`: one rendered stereo clip through the video front end
(the quick preset, one clip, no real video)."""
from __future__ import annotations

import dataclasses
import time

from experiments.config import StageResult, markdown_table
from experiments.video_segmentation.config import PRESETS, Config
from experiments.video_segmentation.stages import clips_stage, skin_stage


def demo_config(seed: int) -> Config:
    """The quick preset on one clip of the evaluated person."""
    return dataclasses.replace(Config(**PRESETS["quick"]), seed=seed, max_clips=1)


def demo_stage(cfg) -> StageResult:
    """`make demo` stage: skin models from one rendered person, then one clip of another person
    through the background model, the level sets and the tracker (`video_demo_sheet.png`).

    cfg: the demo's config (only `cfg.seed` is used)."""
    start = time.perf_counter()
    vcfg = demo_config(int(cfg.seed))
    settings = vcfg.video_settings()
    skin, _ = skin_stage(vcfg, settings)
    metrics, result, _ = clips_stage(vcfg, settings, skin)
    elapsed = time.perf_counter() - start
    keys = ("iou_hand", "iou_face", "iou_person", "iou_hand_skin_only", "hand_centroid_error_px", "hand_error_3d_cm")
    out = {f"video_demo_{k}": float(metrics[k]) for k in keys}
    out["video_demo_s"] = elapsed
    report = "\n".join([
        "## Stage video: masks and tracks from a rendered stereo clip", "",
        f"One {settings.width} x {settings.height} clip at {settings.fps:g} fps: Stauffer-Grimson background, "
        "BIC colour models, competing level sets, alpha-beta tracking (LEVELSET TR §3-5).", "",
        markdown_table(["quantity", "value"], [(k, out[f"video_demo_{k}"]) for k in keys] + [("time (s)", elapsed)])])
    return StageResult(out, {"video_demo_sheet.png": result.figures["contact_sheet.png"]}, report)
