"""Object in the hand (LfD 2009 §III-B): `hog_jax.video.segment_objects` (gradient phase, eqs. 1-4, Fig. 3h-j)
beside the OpenCV peer (`object_peer`: StereoSGBM disparity + DIS optical flow, then the same
selection), on the same windows of one rendered stereo clip, object-mask IoU in the same run.

    python -m experiments.bench.bench_object_segmentation --preset quick --out runs/bench_object_segmentation

Input, the same for all: grey uint8 stereo frames (T, H, W) of one clip of `experiments.data.video`
(validation seed 1, so no test recording is looked at), the true right-hand centre in each view and
the true skin pixels (the hand's pixels removed), a (2 h + 1)^2 window around the hand; frames where
the hand is visible in both views. Output, the same for all: (T, h, w) masks and (T,) found flags on
the host, from the same selection (`hog_jax.video.object_masks`). What each computes before it:
- ours, one call for all frames (vmapped): the blurred gradient phase only on crops around the
  windows its cues read (the full frames' values: the left window at the hand in frames t and
  t - 1, the left window of t - 1 at the hand of t, the right window widened by `max_offset` = h
  for eq. 4's random disparities), then eqs. 1-4;
- peer (the headline): per frame, SGBM (3-way mode) on crops of both views around the window
  (grown by the block's half width, and by numDisparities = 64 more on the left) and DIS (MEDIUM
  preset) on crops of frames t and t - 1 grown by `peer_margin` px (28: the smallest margin tried
  whose mask IoU on this clip is within 0.002 of the full-frame peer's; README);
- peer_full: the same per-frame calls on the full frames, as OpenCV's API is used by default.
OpenCV runs on its own thread pool (`cv2_threads` in bench.json), ours on XLA's. Timed round-robin
(`time_interleaved`: one warm-up pass of each, then one pass of each side in turn per repeat, so
that a load that drifts reaches all alike), median of `repeats`; ours' compilation is its warm-up
beyond a warm pass. windows/s = (T - 1) / median seconds (frame 0 has no previous frame).
"""
from __future__ import annotations

import dataclasses

import cv2
import jax
import numpy as np

from experiments.peers.object_peer import peer_object_masks
from experiments.timing import time_interleaved
from experiments.config import markdown_table, parse_config
from lfd_common import enable_compilation_cache


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """Object segmentation: ours vs StereoSGBM + DIS (on crops and on full frames) on the windows of one
    rendered clip."""

    seed: int = 1
    video_preset: str = "paper"
    person: int = 2
    oac: int = 0
    half_window: int = 20  # px at 320 x 240, scaled with the width
    sigma: float = 12.0    # the hand's width, px at 320 x 240 (LfD §III-B's sigma_m)
    repeats: int = 5
    peer_margin: int = 28  # px at 320 x 240 around the window for the cropped peer's DIS (chosen on this clip, README)

    def __post_init__(self):
        if min(self.repeats, self.half_window) < 1 or self.sigma <= 0 or self.peer_margin < 0:
            raise ValueError("repeats, half_window >= 1; sigma > 0; peer_margin >= 0")


PRESETS = {"quick": {"video_preset": "quick", "person": 1, "repeats": 3}, "paper": {}}


def load_clip(cfg: BenchConfig):
    """(grey left, grey right (T, H, W) uint8, hand left, hand right (T, 2) (row, column), skin (T, H, W),
    the true labels (T, H, W), scale) of the frames where the hand is seen in both views."""
    import sim
    from experiments.data import video

    sim.setup_rendering()
    settings = video.preset(cfg.video_preset, seed=cfg.seed)
    script = next(s for p, c, r, s in video.clip_scripts(settings) if (p, c, r) == (cfg.person, cfg.oac, 0))
    rec = video.render_recording(settings, script)
    seen = rec.ellipse_found[:, 0, 0] & rec.ellipse_found[:, 1, 0]
    first, last = np.flatnonzero(seen)[[0, -1]]
    sl = slice(first, last + 1)
    hand = rec.ellipse_centre[sl, :, 0, ::-1].astype(np.float64)  # (T, view, (row, column))
    hand = np.where(seen[sl, None, None], hand, np.nan)
    hand = _fill(hand)
    return (video.grey(rec.left[sl]), video.grey(rec.right[sl]), hand[:, 0], hand[:, 1], rec.left_labels[sl] == 2,
            rec.left_labels[sl], settings.width / 320.0)


def _fill(x: np.ndarray) -> np.ndarray:
    """Positions (T, ...) with NaN frames taken from the last seen frame (the first is seen)."""
    seen = np.isfinite(x).all(axis=tuple(range(1, x.ndim)))
    last = np.maximum.accumulate(np.where(seen, np.arange(len(x)), 0))
    return x[last]


def main(argv=None):
    enable_compilation_cache()
    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_object_segmentation", argv=argv)
    import hog_jax
    from experiments.lfd_demonstration.evaluate import pooled_iou, truth_windows

    gl, gr, hand_l, hand_r, skin, labels, scale = load_clip(cfg)
    half = (round(cfg.half_window * scale),) * 2
    sigma = cfg.sigma * scale

    def ours():
        seg = hog_jax.video.segment_objects(jax.random.key(cfg.seed), gl, gr, hand_l, hand_r, skin,
                                            hog_jax.video.ObjectOptions(half, sigma, max_offset=half[1],
                                                                        blur_sigma=2.0 * scale))
        return np.asarray(seg.masks), np.asarray(seg.found)

    def peer(margin):
        return lambda: peer_object_masks(gl, gr, hand_l, hand_r, skin, half, crop_margin=margin)

    margin = round(cfg.peer_margin * scale)
    sides = {"ours": ours, "peer": peer(margin), "peer_full": peer(None)}
    timings = time_interleaved(sides, cfg.repeats, block=False)
    truth = truth_windows(labels, hand_l, half)
    n = len(gl) - 1
    out = {"n_windows": n, "window": 2 * half[0] + 1, "frame_shape": list(gl.shape[1:]), "peer_margin_px": margin,
           "device": str(jax.devices()[0]), "cv2_threads": cv2.getNumThreads(),
           "compile_s": timings["ours"].compile_s}
    rows = []
    names = {"ours": "ours", "peer": f"peer on crops (DIS margin {margin} px)", "peer_full": "peer on full frames"}
    for name, t in timings.items():
        inter, union = pooled_iou(t.result[0], truth)
        key = "" if name == "ours" else f"_{name}"
        out[f"windows_per_s{key}"] = n / t.median_s
        out[f"iou{key}"] = inter / max(union, 1)
        out[f"found_rate{key}"] = float(np.mean(t.result[1][1:]))
        rows.append([names[name], out[f"windows_per_s{key}"], out[f"iou{key}"], out[f"found_rate{key}"],
                     f"{min(t.times_s):.3f}-{max(t.times_s):.3f}"])
    out["ratio_vs_peer"] = out["windows_per_s"] / out["windows_per_s_peer"]
    out["ratio_vs_peer_full"] = out["windows_per_s"] / out["windows_per_s_peer_full"]
    table = markdown_table(["method", "windows/s", "object IoU (pooled)", "found rate", "seconds per pass (min-max)"],
                           rows)
    header = (f"# Object-segmentation benchmark\n\n{n} windows of {out['window']}x{out['window']} px around the true "
              f"hand in {gl.shape[2]}x{gl.shape[1]} stereo frames ({cfg.video_preset} preset, seed {cfg.seed}, "
              f"person {cfg.person}, OAC {cfg.oac}); ratio {out['ratio_vs_peer']:.2f}x the peer on crops, "
              f"{out['ratio_vs_peer_full']:.2f}x on full frames.\n\n")
    run.write(out, header + table, filename="bench.json", flat=False)
    print(table)
    print(f"ratio_vs_peer = {out['ratio_vs_peer']:.3g}, ratio_vs_peer_full = {out['ratio_vs_peer_full']:.3g}")
    print(f"wrote {run.file('bench.json')}")


if __name__ == "__main__":
    main()
