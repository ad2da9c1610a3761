"""Video segmentation study (LEVELSET TR §3-5, LfD 2009 §III-A).

    python -m experiments.video_segmentation --preset quick|paper|real|real_quick --out DIR

Rendered stereo recordings (`experiments.data.video`) with MuJoCo's ground truth: skin models from
some persons; every clip of the others segmented by (a) the skin model alone, (b) the competing
level sets with the Stauffer–Grimson background model and BIC colour models (`hog_jax.video`), and
(c) (b) plus the α-β tracker (`hog_jax.tracks`). Metrics: IoU per region, hand centroid error (all
frames and frames where hand and face touch), 3-D hand error. On real data (`--real-data DIR`, the
presets `real` / `real_quick` run it alone; each set skipped, saying so, when absent): the background
model on six real sequences with per-frame truth beside OpenCV's MOG2 and KNN (`real_background`), the
whole front end's person on the SBI indoor sequences (`real_person`), face and hands tracked on the real
reach clip against hand-drawn boxes (`real_reach`), and the one skin model's IoU on real hand photos
beside the YCrCb rule (`real_skin`).

Outputs: metrics.json, report.md, contact_sheet.png (truth | ours over frames), iou_over_time.png,
tracks.png, overlay.mp4; on real data background_<sequence>.png, person_<sequence>.png,
reach_clip_sheet.png.
"""
from experiments.video_segmentation.config import PRESETS, Config
from experiments.video_segmentation.stages import main

__all__ = ["PRESETS", "Config", "main"]
