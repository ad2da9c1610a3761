"""Demo stage "lfd" of `experiments.demo`: one short long recording (two OACs, the quick preset) through
the video front end, the object in the hand, the pick-up / put-down events, and the CHCRF label and
Z(x) of each period (trained on the quick preset's clips of the other persons)."""
from __future__ import annotations

import dataclasses
import time

from experiments.config import StageResult, markdown_table
from experiments.data import video
from experiments.lfd_demonstration.clips import clip_stage
from experiments.lfd_demonstration.config import PRESETS, Config
from experiments.lfd_demonstration.features import FeatureSpec
from experiments.lfd_demonstration.stages import object_stage


def demo_stage(cfg) -> StageResult:
    """`make demo` stage (`lfd_demo_fig8.png`, `lfd_demo_object_masks.png`). cfg: the demo's config (only
    `cfg.seed` is used)."""
    start = time.perf_counter()
    lcfg = dataclasses.replace(Config(**PRESETS["quick"]), seed=int(cfg.seed), script_oacs=2)
    settings = lcfg.video_settings()
    skin_model, _ = video.fit_skin_models(settings, range(settings.n_persons - lcfg.n_skin_persons, settings.n_persons),
                                           lcfg.seed)
    clips = clip_stage(lcfg, settings, skin_model, FeatureSpec())
    metrics, result = object_stage(lcfg, settings, skin_model, clips)
    keys = ("object_mask_iou", "object_mask_iou_peer", "object_mask_iou_learned", "events_true", "events_matched",
            "events_missed", "events_spurious", "pickup_error_frames", "putdown_error_frames", "classifier_events_matched",
            "classifier_events_missed", "classifier_events_spurious", "classifier_pickup_error_frames",
            "classifier_putdown_error_frames", "oac_correct_rate",
            "true_periods_oac_correct_rate", "true_periods_z_seen", "true_periods_z_unseen")
    out = {f"lfd_demo_{k}": metrics.get(k, float("nan")) for k in keys}
    out["lfd_demo_s"] = time.perf_counter() - start
    report = "\n".join([
        "## Stage lfd: the object in the hand and pick-up / put-down events in a long recording", "",
        f"One {settings.width} x {settings.height} recording at {settings.fps:g} fps with two OACs: front end, "
        "phase-difference object segmentation (LfD 2009 §III-B) beside the held object's pixels learnt from the "
        "clips (`object_mask_iou_learned`), temporal segmentation (§III-D) of the paper's "
        "rule (`events_*`: a mask found) and of the hand-window classifier (`classifier_events_*`), each period the "
        f"classifier found labelled by the CHCRF (eqs. 9-10); both trained on {clips.n_clips} clips through the same "
        "front end.", "",
        markdown_table(["quantity", "value"],
                       [(k, out[f"lfd_demo_{k}"]) for k in keys] + [("time (s)", out["lfd_demo_s"])])])
    figures = {"lfd_demo_fig8.png": result.figures.get("fig8_object_in_hand.png"),
               "lfd_demo_object_masks.png": result.figures.get("object_masks.png")}
    return StageResult(out, figures, report)
