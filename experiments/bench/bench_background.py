"""Background model: hog_jax.video.run_background (Stauffer-Grimson, TR §3.5) beside OpenCV's
`createBackgroundSubtractorMOG2` (and `createBackgroundSubtractorKNN` for F1), same frames, same run.

    python -m experiments.bench.bench_background --preset quick --out runs/bench_background

Frames: the real CDnet "baseline/highway" video (`--cdnet-dir`, 320 x 240 RGB; `experiments.data.cdnet`).
Without the folder, synthetic frames (a smooth textured scene with sensor noise and moving boxes, labels
known) are used instead, with a printed note.

Speed (frames/s at 320 x 240, warm-up apart, median of `repeats`): ours from the numpy uint8 frames to
the foreground masks on the host side (validation, transfer, the jitted `lax.scan`), one video of
`fps_frames` frames (`fps_ours`) and `batch` videos of `batch_frames` frames in one call (vmap,
`fps_ours_batched`, frames of all videos per second). MOG2 with its default parameters (history 500,
varThreshold 16, shadow detection on), a fresh subtractor per repeat (built outside the timed region),
`apply` over the frames in a loop (its documented fast path, one frame per call; the batched ratio
compares our batch with that same serial loop). MOG2's default learning rate is automatic (1 / min(2 n,
history) after n frames); the rate changes the values, not the work per pixel and frame, so it is left
at its default for the timing and the F1; `f1_mog2_alpha` reports MOG2 with learningRate = our alpha
(0.05) beside it. On the CPU ours cuts the rows of a video into one stripe per core, each its own
compiled scan on a host thread (`run_background`'s default there), as MOG2 splits its rows over its
threads; batched, the videos go in groups of one per core, one video at a time within a group
(`run_background_batch`'s CPU default), and are vmapped on an accelerator. OpenCV's thread count is
set to `cv_threads` (default: all cores, as ours uses them) and reported.

F1 (CDnet's convention, `score_cdnet`): frames 1-469 train every model (no labels there), frames
`eval_first`..`eval_last` are scored; every model runs over frames 1..eval_last in order. Ours with
its defaults from the papers (`hog_jax.background`: Stauffer-Grimson's decision rule, `f1_ours`) and
with the TR's simpler rule (`f1_ours_matched_rule`); MOG2 and KNN with their defaults (foreground =
mask 255; shadows, 127, count as background as CDnet's hard-shadow label does). No setting was chosen
on these frames; the `ablation_*` entries are reported as ablations only: eq. 10's rho = alpha eta; no
variance floor; alpha = 1/500 (MOG2's long-run rate, 1 / its default history, so that both models learn
at one rate, as `f1_mog2_alpha` does the other way round); and GRASP's 3 x 3 median filter (three
times, `hog_jax.median3`) on the masks of ours and of MOG2 (the TR smooths the masks with the level
sets' curvature term instead).
"""
from __future__ import annotations

import dataclasses
import os

import numpy as np

from experiments.timing import time_call
from experiments.config import markdown_table, parse_config
from experiments.peers.background import f1_stage
from experiments.data.cdnet import CDNET_DIR, load_cdnet
from lfd_common import enable_compilation_cache

TRAIN_FRAMES = 469  # CDnet highway's unlabelled learning frames


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """Background model: ours vs OpenCV MOG2 (and KNN) on CDnet highway, speed and F1."""

    seed: int = 0
    cdnet_dir: str = CDNET_DIR
    eval_first: int = 470
    eval_last: int = 1700
    fps_frames: int = 300
    batch: int = 16
    batch_frames: int = 100
    repeats: int = 3
    cv_threads: int = 0  # 0: all cores
    ablations: bool = True

    def __post_init__(self):
        if not TRAIN_FRAMES < self.eval_first <= self.eval_last:
            raise ValueError(f"eval_first, eval_last: expected {TRAIN_FRAMES} < eval_first <= eval_last")
        if min(self.fps_frames, self.batch, self.batch_frames, self.repeats) < 1 or self.cv_threads < 0:
            raise ValueError("fps_frames, batch, batch_frames, repeats must be >= 1 and cv_threads >= 0")


PRESETS = {"quick": {"eval_last": 620, "fps_frames": 60, "batch": 16, "batch_frames": 10, "repeats": 1,
                     "ablations": False}, "paper": {}}


def synthetic_video(n_frames: int, seed: int = 0, shape=(240, 320)):
    """(frames (T, H, W, 3) uint8, labels (T, H, W) uint8 in {0, 255}): a smooth random scene with
    Gaussian sensor noise (sigma 2) and three boxes moving across it from frame 100 on."""
    import cv2

    rng = np.random.default_rng(seed)
    H, W = shape
    scene = cv2.GaussianBlur(rng.uniform(30, 220, (H, W, 3)).astype(np.float32), (0, 0), 6)
    scene = (scene - scene.min()) / (scene.max() - scene.min()) * 180 + 40
    frames = np.empty((n_frames, H, W, 3), np.uint8)
    labels = np.zeros((n_frames, H, W), np.uint8)
    boxes = [(rng.uniform(0, H - 40), rng.uniform(-2, 2), rng.uniform(1, 3), rng.uniform(0, 255, 3)) for _ in range(3)]
    for t in range(n_frames):
        img = scene + rng.normal(0, 2, scene.shape)
        for i, (row, drift, speed, colour) in enumerate(boxes):
            if t >= 100:
                r = int(row + drift * (t - 100)) % (H - 30)
                c = int(speed * (t - 100) + 80 * i) % (W - 40)
                img[r:r + 30, c:c + 40] = colour
                labels[t, r:r + 30, c:c + 40] = 255
        frames[t] = np.clip(img, 0, 255)
    return frames, labels


def load_frames(cfg: BenchConfig):
    """(frames 1..eval_last (T, 240, 320, 3) uint8 RGB, labels (T, 240, 320), roi, source name)."""
    try:
        video = load_cdnet(cfg.cdnet_dir, 1, cfg.eval_last)
    except FileNotFoundError as err:
        print(f"note: {err}; using synthetic frames instead (F1 on synthetic labels)")
        frames, labels = synthetic_video(cfg.eval_last, cfg.seed)
        return frames, labels, np.ones(frames.shape[1:3], bool), "synthetic"
    return video.frames, video.groundtruth, video.roi, "cdnet_highway"


def _mog2_loop(frames_bgr: np.ndarray):
    import cv2

    sub = cv2.createBackgroundSubtractorMOG2()

    def run(_=None):
        for frame in frames_bgr:
            sub.apply(frame)
    return run


def speed_stage(cfg: BenchConfig, frames) -> dict:
    """Frames/s of ours (one video, and `batch` videos at once) and of MOG2's apply loop."""
    from hog_jax.video import run_background, run_background_batch

    one = np.ascontiguousarray(frames[:cfg.fps_frames])
    starts = np.linspace(0, len(frames) - cfg.batch_frames, cfg.batch).astype(int)  # 16 windows of the video
    many = np.stack([frames[s:s + cfg.batch_frames] for s in starts])
    ours = time_call(lambda: run_background(one)[1], cfg.repeats)
    batched = time_call(lambda: run_background_batch(many)[1], cfg.repeats)
    bgr = np.ascontiguousarray(one[..., ::-1])
    mog2 = time_call(lambda run: run(), cfg.repeats, warmup=lambda _: _mog2_loop(bgr[:10])(),
                     setup=lambda: _mog2_loop(bgr), block=False)
    fps = {"fps_ours": len(one) / ours.median_s, "fps_ours_batched": many.shape[0] * many.shape[1] / batched.median_s,
           "fps_mog2": len(one) / mog2.median_s}
    fps["ratio_vs_mog2"] = fps["fps_ours"] / fps["fps_mog2"]
    fps["ratio_batched_vs_mog2"] = fps["fps_ours_batched"] / fps["fps_mog2"]
    fps["compile_s"] = ours.compile_s
    fps["compile_batched_s"] = batched.compile_s
    print(f"ours {fps['fps_ours']:.0f} frames/s (batch of {cfg.batch}: {fps['fps_ours_batched']:.0f}), "
          f"MOG2 {fps['fps_mog2']:.0f}; ratio {fps['ratio_vs_mog2']:.2f}x "
          f"(batched {fps['ratio_batched_vs_mog2']:.2f}x); compile {fps['compile_s']:.1f} s", flush=True)
    return fps


def main(argv=None):
    enable_compilation_cache()
    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_background", argv=argv)
    import cv2
    import jax

    n_threads = cfg.cv_threads or os.cpu_count() or 1
    cv2.setNumThreads(n_threads)
    frames, labels, roi, source = load_frames(cfg)
    print(f"{source}: {len(frames)} frames of {frames.shape[2]} x {frames.shape[1]}; OpenCV threads "
          f"{cv2.getNumThreads()}", flush=True)
    speed = speed_stage(cfg, frames)
    f1 = f1_stage(frames, labels, roi, cfg.eval_first, cfg.ablations)
    out = {**speed, "f1_ours": f1["ours"]["f1"], "f1_ours_matched_rule": f1["ours_matched_rule"]["f1"],
           "f1_mog2": f1["mog2"]["f1"], "f1_mog2_alpha": f1["mog2_alpha"]["f1"], "f1_knn": f1["knn"]["f1"],
           "data": source, "eval_frames": [cfg.eval_first, cfg.eval_last], "fps_frames": cfg.fps_frames,
           "batch": cfg.batch, "batch_frames": cfg.batch_frames, "cv_threads": cv2.getNumThreads(),
           "cpu_count": os.cpu_count(), "device": str(jax.devices()[0]), "scores": f1}
    rows = [[name, r["precision"], r["recall"], r["f1"]] for name, r in f1.items()]
    report = (f"# Background model benchmark ({source}, frames {cfg.eval_first}-{cfg.eval_last} scored)\n\n"
              + markdown_table(["frames/s", "ours", f"ours (batch of {cfg.batch})", "MOG2", "ratio", "ratio batched"],
                               [["", speed["fps_ours"], speed["fps_ours_batched"], speed["fps_mog2"],
                                 speed["ratio_vs_mog2"], speed["ratio_batched_vs_mog2"]]])
              + "\n\n" + markdown_table(["model", "precision", "recall", "F1"], rows))
    run.write(out, report, filename="bench.json", flat=False)
    print(f"wrote {run.file('bench.json')}")


if __name__ == "__main__":
    main()
