"""Real time at 320 x 240 on real frames: the video front end beside OpenCV's background subtractors
and MediaPipe Hands, in one process, round-robin; and MediaPipe's hands against true hand boxes.

    make peers   # once: .venv-peers, with mediapipe beside this project
    .venv-peers/bin/python -m experiments.bench.bench_video_realtime --preset quick --out runs/bench_video_realtime

Clips (`--clips`, frames/s measured on the first `--frames` frames of each, all at 320 x 240 RGB):
- `reach`: the real reach clip `reach_grasp/teaser_movement.gif` (58 frames of 260 x 238, 10 fps).
  `--fit pad` (default) scales it by 240 / 238 to 262 x 240, keeping its aspect, and pads it with black
  columns to 320 x 240 (29 left, 29 right); `--fit stretch` resizes it to 320 x 240 (x by 1.23).
- `sbi_human_body2`: the real SBI `HumanBody2` frames (320 x 240 as stored; people walking round desks).

Sides (`SIDES`; each one function of the frames, one call per repeat, the sides in turn, after one
warm-up call of each timed apart; median of `--repeats`):
- `ours_front_end`: `hog_jax.video` mono, as `lfd-jax video` runs it: `track_mono` with
  `VideoOptions.real_video()` (the background model, the colour models' scores and the level sets,
  one scan, every frame from the second on segmented; `connected_blobs` of the skin label; `track`
  of face, hand and other hand; `hand_ends`). The skin model (`lfd_jax.fit_real_skin_model`) and the
  recording's colour models (`fit_video_models`, its first third the learning phase) are fitted
  before and timed apart (`fit_models_s`). To time another front end, replace `ours_front_end`.
- `ours_segmentation`: the same scan alone (`segment_recording` with the same models and options:
  background model, colour scores, level sets), so that the front end's time splits into the
  segmentation and what follows it (blobs, tracking, hand ends).
- `ours_background`: `hog_jax.video.run_background` alone, the setting for real video
  (`BackgroundOptions.real_video()`, K = 5, with its 3 x 3 median).
- `mog2`, `knn`: OpenCV `createBackgroundSubtractorMOG2` / `KNN` with their defaults, `apply` per frame
  (BGR frames, converted before the timing); a fresh subtractor per repeat, built untimed.
- `mediapipe_hands`: MediaPipe Hands 0.10.21 in video mode (`experiments.peers.mediapipe_hands`,
  palm detector + full landmark model, two hands, detection and tracking confidence 0.5), a fresh
  graph per repeat, built untimed and fed one black frame untimed (its model loading and first call
  reported as `mediapipe_init_s`; a black frame has no hand, so nothing is tracked into the video).
The JAX sides' warm-up call compiles (reported as `compile_s`); the frames/s exclude it. The frames
are in memory before the timing (decoding is not timed on any side). OpenCV uses `--cv-threads`
(default: all cores); XLA and MediaPipe's TFLite choose their own thread counts. The report gives the
machine's one-minute load average as each clip's timing starts: other processes on the same cores
slow every side, the JAX ones most.

Hands against truth (`experiments.peers.mediapipe_hands.score_boxes`: greedy one-to-one matching by box
IoU, a hand found at IoU >= 0.5): MediaPipe's boxes (the bounding box of its 21 landmarks) on
- `gtea_grasps`: the 33 real egocentric frames (640 x 480, stills: static mode) against `labels.csv`'s
  52 hand boxes. The upstream frames have the annotation boxes and labels drawn into the pixels; a
  detector sees them too (a box outline around each true hand), so the figures are indicative.
- the reach clip: the project's boxes of both hands on 8 frames (`--annotations`, the columns frame,
  part, x0, y0, x1, y1, inclusive pixels of the 260 x 238 frames, mapped to the 320 x 240 frames
  MediaPipe sees), MediaPipe in video mode over the whole clip and in static mode on the annotated frames.
Landmark boxes are tight around the joints, annotated boxes around the whole hand; `mean_best_iou`
shows how far apart they are. Nothing is tuned on these frames.
"""
from __future__ import annotations

import csv
import dataclasses
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from experiments.config import markdown_table, parse_config
from experiments.peers.mediapipe_hands import HandsOptions, MediaPipeHands, inclusive_to_edges, score_boxes
from experiments.timing import Timing
from lfd_common import enable_compilation_cache

SIZE = (240, 320)  # H, W
REACH_CLIP = "reach_grasp/teaser_movement.gif"
SBI_FOLDER = "sbi_indoor/HumanBody2/input"
GTEA_FOLDER = "gtea_grasps"
HAND_PARTS = ("right_hand", "left_hand")
REAL_TIME_FPS = 25.0
IOU_LABEL = {"iou50": ">= 0.5", "iou30": ">= 0.3"}


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """Frames/s at 320 x 240 on real clips (ours, MOG2, KNN, MediaPipe Hands) and MediaPipe's hand boxes."""

    seed: int = 0
    data_dir: str = "../shared/data"
    clips: tuple[str, ...] = ("reach", "sbi_human_body2")
    frames: int = 58
    repeats: int = 5
    fit: str = "pad"
    cv_threads: int = 0  # 0: all cores
    sides: tuple[str, ...] = ("ours_front_end", "ours_segmentation", "ours_background", "mog2", "knn",
                              "mediapipe_hands")
    annotations: str = "experiments/data/video/reach_clip_boxes.csv"
    gtea: bool = True

    def __post_init__(self):
        if self.frames < 12 or self.repeats < 1 or self.cv_threads < 0:
            raise ValueError("frames must be >= 12 (the front end's learning phase), repeats >= 1, cv_threads >= 0")
        if self.fit not in ("pad", "stretch"):
            raise ValueError(f"fit: expected 'pad' or 'stretch', got {self.fit!r}")
        if unknown := set(self.clips) - {"reach", "sbi_human_body2"}:
            raise ValueError(f"clips: unknown {sorted(unknown)}; expected reach, sbi_human_body2")
        if unknown := set(self.sides) - set(SIDES):
            raise ValueError(f"sides: unknown {sorted(unknown)}; expected some of {sorted(SIDES)}")


PRESETS = {"quick": {"frames": 24, "repeats": 3}, "paper": {}}


class Side(NamedTuple):
    """One timed side: `prepare(frames)` builds its per-repeat state untimed (a fresh subtractor, a fresh
    MediaPipe graph), `run(state, frames)` is timed; `what` says what it computes (the report prints it);
    `jax` whether its result is blocked on with `jax.block_until_ready`."""

    what: str
    prepare: Callable[[np.ndarray], Any]
    run: Callable[[Any, np.ndarray], Any]
    jax: bool = False


# ------------------------------------------------------------------ frames
def fit_frame(frame: np.ndarray, fit: str) -> tuple[np.ndarray, float, float, float]:
    """(the frame at 320 x 240, scale, x offset, y offset): pixel (x, y) of `frame` lands at (x s + dx, y s + dy)."""
    import cv2

    H, W = SIZE
    h, w = frame.shape[:2]
    if fit == "stretch":
        return cv2.resize(frame, (W, H), interpolation=cv2.INTER_AREA), W / w, 0.0, 0.0  # anisotropic: see scale_y
    s = min(W / w, H / h)
    nw, nh = round(w * s), round(h * s)
    out = np.zeros((H, W, 3), np.uint8)
    dx, dy = (W - nw) // 2, (H - nh) // 2
    method = cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR
    out[dy:dy + nh, dx:dx + nw] = cv2.resize(frame, (nw, nh), interpolation=method)
    return out, s, float(dx), float(dy)


def load_reach(cfg: BenchConfig) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]]:
    """(the reach clip at 320 x 240 (T, 240, 320, 3) uint8 RGB, a map of its boxes (..., 4) to those frames)."""
    from lfd_jax import load_video

    clip = load_video(Path(cfg.data_dir) / REACH_CLIP)
    fitted = [fit_frame(f, cfg.fit) for f in clip.frames]
    _, s, dx, dy = fitted[0]
    sy = SIZE[0] / clip.frames.shape[1] if cfg.fit == "stretch" else s
    scale = np.array([s, sy, s, sy])
    return np.stack([f[0] for f in fitted]), lambda boxes: np.asarray(boxes, float) * scale + [dx, dy, dx, dy]


def load_sbi(cfg: BenchConfig, n: int) -> np.ndarray:
    """The first `n` SBI HumanBody2 frames (n, 240, 320, 3) uint8 RGB."""
    import cv2

    folder = Path(cfg.data_dir) / SBI_FOLDER
    paths = sorted(folder.glob("in*.jpg"))[:n]
    if not paths:
        raise FileNotFoundError(f"no frames in {folder}")
    frames = np.stack([cv2.imread(str(p), cv2.IMREAD_COLOR)[..., ::-1] for p in paths])
    if frames.shape[1:3] != SIZE:
        frames = np.stack([fit_frame(f, cfg.fit)[0] for f in frames])
    return np.ascontiguousarray(frames)


# ------------------------------------------------------------------ sides
def real_video_models(cfg: BenchConfig, frames: np.ndarray, info: dict):
    """(`VideoOptions.real_video()`, the recording's `VideoModels`), fitted once per clip and kept in
    `info` (their time in `info["fit_models_s"]`)."""
    import jax

    import hog_jax.video as hv
    from lfd_jax import fit_real_skin_model

    if "models" not in info:
        options = hv.VideoOptions.real_video()
        began = time.perf_counter()
        skin = fit_real_skin_model(cfg.data_dir, seed=cfg.seed)
        start = max(options.person_frames + 1, len(frames) // 3)
        models, _ = hv.fit_video_models(jax.random.key(cfg.seed), skin, frames, start, options)
        info["models"] = options, jax.block_until_ready(models)
        info["fit_models_s"] = time.perf_counter() - began
    return info["models"]


def ours_front_end(cfg: BenchConfig, frames: np.ndarray, info: dict) -> Side:
    """Ours: the mono front end for real video (`track_mono`), the recording's models fitted before."""
    import hog_jax.video as hv

    options, models = real_video_models(cfg, frames, info)
    tracking = hv.HandFaceOptions(min_area=max(4, round(1e-3 * frames.shape[1] * frames.shape[2])))
    return Side("track_mono with VideoOptions.real_video() (background K = 5 with warm-up, shadows; colour "
                "scores; level sets; frames 1..T-1 segmented) -> connected_blobs (skin) -> track (face, hand, "
                "other hand) -> hand_ends; the skin model (fit_real_skin_model) and the recording's colour "
                "models fitted before, apart", lambda _: None,
                lambda _, x: hv.track_mono(models, x, 1, options, tracking, chunk=len(x)), True)


def ours_segmentation(cfg: BenchConfig, frames: np.ndarray, info: dict) -> Side:
    """Ours: `ours_front_end`'s segmentation scan alone (`segment_recording`), the same models."""
    import hog_jax.video as hv

    options, models = real_video_models(cfg, frames, info)
    return Side("segment_recording with VideoOptions.real_video() (ours_front_end's scan: background, colour "
                "scores, level sets; no blobs, tracking or hand ends)", lambda _: None,
                lambda _, x: hv.segment_recording(models, x, 1, options).labels, True)


def ours_background(cfg: BenchConfig, frames: np.ndarray, info: dict) -> Side:
    """Ours: the background model alone (`run_background`) with the setting for real video."""
    from hog_jax.video import BackgroundOptions, BackgroundStructure, run_background

    structure, options = BackgroundStructure.real_video(), BackgroundOptions.real_video()
    return Side("run_background (BackgroundOptions.real_video(), K = 5, 3 x 3 median), foreground masks",
                lambda _: None, lambda _, x: run_background(x, structure=structure, options=options)[1], True)


def _opencv(make_name: str) -> Callable[[BenchConfig, np.ndarray, dict], Side]:
    def side(cfg: BenchConfig, frames: np.ndarray, info: dict) -> Side:
        import cv2

        bgr = np.ascontiguousarray(frames[..., ::-1])  # OpenCV's order, converted untimed

        def run(sub, _):
            for frame in bgr:
                sub.apply(frame)
        return Side(f"cv2.{make_name}() defaults, apply per frame (BGR)", lambda _: getattr(cv2, make_name)(), run)
    return side


def mediapipe_hands(cfg: BenchConfig, frames: np.ndarray, info: dict) -> Side:
    """MediaPipe Hands in video mode, a fresh graph per repeat (built untimed)."""
    holder = []

    def prepare(_):
        while holder:
            holder.pop().close()
        began = time.perf_counter()
        holder.append(MediaPipeHands(HandsOptions(static_image_mode=False)))
        holder[-1](np.zeros_like(frames[0]))  # a black frame: any lazy set-up, and no hand to track
        info.setdefault("mediapipe_init_s", []).append(time.perf_counter() - began)
        return holder[-1]

    return Side("MediaPipe Hands 0.10.21 video mode (palm detector + full landmarks, tracking), 2 hands",
                prepare, lambda hands, x: [hands(f) for f in x])


SIDES: dict[str, Callable[[BenchConfig, np.ndarray, dict], Side]] = {
    "ours_front_end": ours_front_end, "ours_segmentation": ours_segmentation, "ours_background": ours_background,
    "mog2": _opencv("createBackgroundSubtractorMOG2"), "knn": _opencv("createBackgroundSubtractorKNN"),
    "mediapipe_hands": mediapipe_hands}


def round_robin(sides: dict[str, Side], frames: np.ndarray, repeats: int) -> dict[str, Timing]:
    """One warm-up call of each side, then `repeats` rounds of one call of each in turn; each call's
    `prepare` untimed (`experiments.timing.time_interleaved` with a per-call setup)."""
    import jax

    def call(side: Side):
        state = side.prepare(frames)
        began = time.perf_counter()
        out = side.run(state, frames)
        if side.jax:
            out = jax.block_until_ready(out)
        return time.perf_counter() - began, out

    first = {}
    for name, side in sides.items():
        first[name] = call(side)[0]
        print(f"  warm-up {name}: {first[name]:.2f} s", flush=True)
    times = {name: [] for name in sides}
    last = {}
    for r in range(repeats):
        for name, side in sides.items():
            seconds, last[name] = call(side)
            times[name].append(seconds)
        print(f"  round {r + 1}/{repeats}: " + ", ".join(f"{n} {times[n][-1]:.2f} s" for n in sides), flush=True)
    return {name: Timing(tuple(times[name]), first[name], last[name]) for name in sides}


def speed_stage(cfg: BenchConfig, clip: str, frames: np.ndarray) -> dict:
    """Frames/s of every side on one clip (see the module docstring)."""
    frames = np.ascontiguousarray(frames[:cfg.frames])
    info: dict = {}
    sides = {name: SIDES[name](cfg, frames, info) for name in cfg.sides}
    load = os.getloadavg()[0]
    print(f"{clip}: {len(frames)} frames of {frames.shape[2]} x {frames.shape[1]}; load average {load:.2f}", flush=True)
    timings = round_robin(sides, frames, cfg.repeats)
    out = {"frames": len(frames), "load_average_1min": load, "what": {n: s.what for n, s in sides.items()}}
    for name, t in timings.items():
        out[f"fps_{name}"] = len(frames) / t.median_s
        out[f"ms_per_frame_{name}"] = 1000 * t.median_s / len(frames)
        out[f"times_s_{name}"] = list(t.times_s)
        out[f"warmup_s_{name}"] = t.first_s
        if sides[name].jax:
            out[f"compile_s_{name}"] = t.compile_s
    if "fit_models_s" in info:
        out["fit_models_s"] = info["fit_models_s"]
    if "mediapipe_init_s" in info:
        out["mediapipe_init_s"] = float(np.median(info["mediapipe_init_s"]))
        hands = timings["mediapipe_hands"].result
        out["mediapipe_hands_per_frame"] = float(np.mean([len(h.boxes) for h in hands]))
    return out


# ------------------------------------------------------------------ hand boxes
def gtea_truth(cfg: BenchConfig) -> tuple[list[Path], list[np.ndarray], list[list[str]]]:
    """(image paths, per image the true hand boxes (M, 4) as pixel edges, per image the hands' sides)."""
    folder = Path(cfg.data_dir) / GTEA_FOLDER
    boxes: dict[str, list] = {}
    sides: dict[str, list] = {}
    with open(folder / "labels.csv", newline="") as f:
        for r in csv.DictReader(f):
            box = [int(r[k]) for k in ("hand_xmin", "hand_ymin", "hand_xmax", "hand_ymax")]
            boxes.setdefault(r["image"], []).append(box)
            sides.setdefault(r["image"], []).append(r["hand"])
    names = sorted(boxes)
    return [folder / n for n in names], [inclusive_to_edges(boxes[n]) for n in names], [sides[n] for n in names]


def handedness_agreement(found, truth, sides, threshold=0.5) -> float:
    """Share of matched hands whose MediaPipe label, swapped for an unmirrored camera, is the true side."""
    from experiments.peers.mediapipe_hands import match_boxes

    swap = {"Left": "right", "Right": "left"}
    agree = [swap.get(f.handedness[i]) == s[j] for f, g, s in zip(found, truth, sides)
             for i, j, _ in match_boxes(f.boxes, g, threshold)]
    return float(np.mean(agree)) if agree else float("nan")


def gtea_stage(cfg: BenchConfig) -> dict:
    """MediaPipe (static mode) on the GTEA frames: hands found at IoU >= 0.5 (and 0.3), false boxes, time per frame."""
    import cv2

    paths, truth, sides = gtea_truth(cfg)
    images = [np.ascontiguousarray(cv2.imread(str(p), cv2.IMREAD_COLOR)[..., ::-1]) for p in paths]
    began = time.perf_counter()
    hands = MediaPipeHands(HandsOptions(static_image_mode=True))
    init_s = time.perf_counter() - began
    found = [hands(im) for im in images]  # warm-up pass
    times = []
    for _ in range(cfg.repeats):
        began = time.perf_counter()
        found = [hands(im) for im in images]
        times.append(time.perf_counter() - began)
    hands.close()
    boxes = [f.boxes for f in found]
    out = {"images": len(images), "size": f"{images[0].shape[1]} x {images[0].shape[0]}", "mediapipe_init_s": init_s,
           "ms_per_frame": 1000 * float(np.median(times)) / len(images),
           "iou50": score_boxes(boxes, truth, 0.5), "iou30": score_boxes(boxes, truth, 0.3),
           "handedness_agreement_iou30": handedness_agreement(found, truth, sides, 0.3)}
    print(f"gtea: MediaPipe found {out['iou50']['matched']}/{out['iou50']['true_boxes']} hands at IoU >= 0.5 "
          f"({out['iou30']['matched']} at 0.3), {out['iou50']['false_boxes']} false boxes in {len(images)} frames, "
          f"{out['ms_per_frame']:.1f} ms/frame", flush=True)
    return out


def reach_truth(path: Path) -> tuple[list[int], list[np.ndarray]]:
    """(annotated frames, per frame the hand boxes (M, 4) as pixel edges of the 260 x 238 frames)."""
    boxes: dict[int, list] = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            if r["part"] in HAND_PARTS:
                boxes.setdefault(int(r["frame"]), []).append([float(r[k]) for k in ("x0", "y0", "x1", "y1")])
    frames = sorted(boxes)
    return frames, [inclusive_to_edges(boxes[t]) for t in frames]


def reach_stage(cfg: BenchConfig, frames: np.ndarray, to_frames: Callable) -> dict:
    """MediaPipe on the reach clip's annotated frames, video mode over the clip and static mode."""
    path = Path(cfg.annotations)
    if not path.is_file():
        print(f"note: no reach annotations at {path}; reach scoring skipped", flush=True)
        return {}
    annotated, truth = reach_truth(path)
    truth = [to_frames(b) for b in truth]
    out = {"annotated_frames": annotated}
    with MediaPipeHands(HandsOptions(static_image_mode=False)) as hands:
        video = [hands(f) for f in frames]
    with MediaPipeHands(HandsOptions(static_image_mode=True)) as hands:
        still = [hands(frames[t]) for t in annotated]
    for mode, found in (("video", [video[t] for t in annotated]), ("static", still)):
        boxes = [f.boxes for f in found]
        out[mode] = {"iou50": score_boxes(boxes, truth, 0.5), "iou30": score_boxes(boxes, truth, 0.3)}
        s = out[mode]["iou50"]
        print(f"reach ({mode} mode): {s['matched']}/{s['true_boxes']} hands at IoU >= 0.5, "
              f"{s['false_boxes']} false boxes in {s['frames']} frames", flush=True)
    out["video_hands_per_frame_all"] = float(np.mean([len(f.boxes) for f in video]))
    return out


# ------------------------------------------------------------------ report
def _fmt(x: float) -> str:
    return "-" if x != x else f"{x:.3g}"


def report(cfg: BenchConfig, speed: dict, gtea: dict, reach: dict, meta: dict) -> str:
    lines = ["# Real time at 320 x 240: ours, OpenCV MOG2 / KNN, MediaPipe Hands (one process, round-robin)", "",
             f"Median of {cfg.repeats} runs after a warm-up; frames in memory; compile and model loading apart. "
             f"CPU: {meta['cpu_count']} cores, OpenCV threads {meta['cv_threads']}, JAX device {meta['device']}, "
             f"mediapipe {meta['mediapipe']}. Reach clip to 320 x 240 by `{cfg.fit}`.", ""]
    rows = []
    for name in cfg.sides:
        row = [name]
        for clip in speed:
            s = speed[clip]
            row += [_fmt(s[f"fps_{name}"]), _fmt(s[f"ms_per_frame_{name}"])]
        comp = [speed[c].get(f"compile_s_{name}") for c in speed]
        row.append(", ".join(_fmt(c) for c in comp) if any(c is not None for c in comp) else "-")
        rows.append(row)
    head = ["side"] + [h for clip in speed for h in (f"{clip} ({speed[clip]['frames']} fr) frames/s", "ms/frame")]
    lines += [markdown_table(head + ["compile s (per clip)"], rows), ""]
    if "ours_front_end" in cfg.sides:
        fps = {clip: s["fps_ours_front_end"] for clip, s in speed.items()}
        met = all(v >= REAL_TIME_FPS for v in fps.values())
        lines += [f"Real time (>= {REAL_TIME_FPS} frames/s through the whole front end): "
                  + ("met" if met else "not met") + " (" + ", ".join(f"{c} {v:.1f}" for c, v in fps.items()) + ")", ""]
    for clip, s in speed.items():
        keys = ("load_average_1min", "fit_models_s", "mediapipe_init_s", "mediapipe_hands_per_frame")
        extra = [f"{k} {_fmt(s[k])}" for k in keys if k in s]
        lines.append(f"- {clip}: " + "; ".join(extra))
    first = next(iter(speed.values()), {})
    lines += ["", "What each side computes:", ""] + [f"- `{n}`: {w}" for n, w in first.get("what", {}).items()]
    if gtea:
        lines += ["", f"## MediaPipe Hands on gtea_grasps ({gtea['images']} frames {gtea['size']}, static mode)", "",
                  "Annotation boxes are drawn into these frames' pixels (upstream): indicative only.", ""]
        rows = [[IOU_LABEL[k], gtea[k]["true_boxes"], gtea[k]["found_boxes"], gtea[k]["matched"],
                 _fmt(gtea[k]["recall"]), gtea[k]["false_boxes"], _fmt(gtea[k]["false_boxes_per_frame"]),
                 _fmt(gtea[k]["mean_best_iou"])]
                for k in ("iou50", "iou30")]
        lines += [markdown_table(["IoU", "true", "found", "matched", "recall", "false", "false/frame",
                                  "mean best IoU"], rows), "",
                  f"Time per frame {gtea['ms_per_frame']:.1f} ms "
                  f"(model loading {_fmt(gtea['mediapipe_init_s'])} s apart); "
                  f"handedness agreement of the hands matched at IoU >= 0.3 (labels swapped for an unmirrored "
                  f"camera): {_fmt(gtea['handedness_agreement_iou30'])}."]
    if reach:
        lines += ["", f"## MediaPipe Hands on the reach clip (both hands on frames {reach['annotated_frames']})", ""]
        rows = [[mode, IOU_LABEL[k], *(reach[mode][k][c] for c in ("true_boxes", "found_boxes", "matched")),
                 _fmt(reach[mode][k]["recall"]), reach[mode][k]["false_boxes"], _fmt(reach[mode][k]["mean_best_iou"])]
                for mode in ("video", "static") for k in ("iou50", "iou30")]
        lines += [markdown_table(["mode", "IoU", "true", "found", "matched", "recall", "false", "mean best IoU"],
                                 rows)]
    return "\n".join(lines) + "\n"


def main(argv=None):
    enable_compilation_cache()
    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_video_realtime", argv=argv)
    import cv2
    import jax

    from experiments.peers.mediapipe_hands import require_mediapipe

    cv2.setNumThreads(cfg.cv_threads or os.cpu_count() or 1)
    try:
        mp = require_mediapipe()
    except ImportError as err:  # `make bench` runs in .venv, without mediapipe: the other sides still run
        print(f"note: MediaPipe skipped: {err}", flush=True)
        mp = None
        cfg = dataclasses.replace(cfg, sides=tuple(s for s in cfg.sides if s != "mediapipe_hands"), gtea=False)
    speed, reach = {}, {}
    for clip in cfg.clips:
        if clip == "reach":
            frames, to_frames = load_reach(cfg)
            speed[clip] = speed_stage(cfg, clip, frames)
            reach = reach_stage(cfg, frames, to_frames) if mp is not None else {}
        else:
            speed[clip] = speed_stage(cfg, clip, load_sbi(cfg, cfg.frames))
        for name in cfg.sides:
            print(f"  {name}: {speed[clip][f'fps_{name}']:.1f} frames/s", flush=True)
    gtea = gtea_stage(cfg) if cfg.gtea else {}
    meta = {"cpu_count": os.cpu_count(), "cv_threads": cv2.getNumThreads(), "device": str(jax.devices()[0]),
            "mediapipe": getattr(mp, "__version__", "-") if mp else "-", "fit": cfg.fit}
    text = report(cfg, speed, gtea, reach, meta)
    pairs = (("ours_front_end", "mog2"), ("ours_front_end", "mediapipe_hands"), ("ours_background", "mog2"))
    ratios = {f"ratio_{ours}_vs_{peer}_{clip}": s[f"fps_{ours}"] / s[f"fps_{peer}"] for clip, s in speed.items()
              for ours, peer in pairs if f"fps_{ours}" in s and f"fps_{peer}" in s}  # above 1: ours is faster
    run.write({**ratios, "speed": speed, "gtea": gtea, "reach": reach, **meta}, text, filename="bench.json",
              flat=False)
    print(text)
    print(f"wrote {run.file('bench.json')}")


if __name__ == "__main__":
    main()
