"""Video segmentation study (LEVELSET TR §3-5, LfD 2009 §III-A).

    python -m experiments.video_segmentation --preset quick|paper --out DIR

Rendered stereo recordings (`experiments.data.video`) with MuJoCo's ground truth: skin models from
some persons; every clip of the others segmented by (a) the skin model alone, (b) the competing
level sets with the Stauffer–Grimson background model and BIC colour models (`hog_jax.video`), and
(c) (b) plus the α-β tracker (`hog_jax.tracks`). Metrics: IoU per region, hand centroid error (all
frames and frames where hand and face touch), 3-D hand error. The background model also runs on
the real CDnet highway video beside OpenCV's MOG2 and KNN (`--cdnet-dir`; skipped when absent).

Outputs: metrics.json, report.md, contact_sheet.png (truth | ours over frames), iou_over_time.png,
tracks.png, overlay.mp4.
"""
from experiments.video_segmentation.config import PRESETS, Config
from experiments.video_segmentation.stages import main

__all__ = ["PRESETS", "Config", "main"]
