"""The real-video part of the study, background: every real sequence with per-frame truth
(`experiments.data.video.real_sequences`: CDnet highway and pedestrians, four SBI indoor scenes)
streamed in chunks through our background model (`hog_jax.video.run_background` with
`BackgroundOptions.real_video()` and `BackgroundStructure.real_video()`, one setting for every sequence,
its state carried from chunk to chunk) and OpenCV's MOG2 and KNN (their defaults, one `apply` per frame;
their shadow label counts as background), scored by CDnet's convention (hard shadow counts as
background; unknown and out-of-ROI pixels are ignored). Our setting ends in a 3 x 3 median of the mask,
so the peers are also scored with the same median (`cv2.medianBlur`, 3 x 3, replicated edges: on a
binary mask the majority of the nine pixels, as ours)."""
from __future__ import annotations

import itertools

import cv2
import numpy as np

from experiments.config import StageResult, progress
from experiments.data.video import real_sequences
from hog_jax.video import BackgroundOptions, BackgroundStructure, run_background

PEERS = {"mog2": cv2.createBackgroundSubtractorMOG2, "knn": cv2.createBackgroundSubtractorKNN}
METHODS = ("ours",) + tuple(PEERS) + tuple(f"{m}_median3" for m in PEERS)
CHUNK = 32  # frames per call of our model: memory stays bounded by the chunk, not the sequence


def chunks_of(frames, size: int):
    """Lists of up to `size` consecutive items of the iterator `frames`, until it ends."""
    while chunk := list(itertools.islice(frames, size)):
        yield chunk


def score_sequence(root: str, name: str, structure: BackgroundStructure, options: BackgroundOptions, step: int,
                   stop: int | None, keep: int) -> tuple[dict, list]:
    """(Counts per method, up to `keep` scored frames as (number, frame, truth, {method: mask})) of one sequence."""
    counts = {m: real_sequences.Counts() for m in METHODS}
    peers = {m: make() for m, make in PEERS.items()}
    state, seen, kept = None, 0, []
    info = real_sequences.sequence_info(root, name)
    n_frames = len(info.numbers) if stop is None else min(stop, len(info.numbers))
    every = max(1, int(info.evaluated()[:n_frames].sum()) // max(keep, 1))
    for chunk in chunks_of(real_sequences.iter_sequence(root, name, step=step, stop=stop), CHUNK):
        frames = np.stack([frame for _, frame, _ in chunk])
        state, ours = run_background(frames, structure=structure, options=options, initial_state=state,
                                     start_frame=seen)
        ours = np.asarray(ours)
        seen += len(chunk)
        for i, (number, frame, truth) in enumerate(chunk):
            masks = {"ours": ours[i]}
            for m, peer in peers.items():
                raw = np.where(peer.apply(np.ascontiguousarray(frame[..., ::-1])) == 255, 255, 0).astype(np.uint8)
                masks[m] = raw > 0  # 127, the shadow label, counts as background
                masks[f"{m}_median3"] = cv2.medianBlur(raw, 3) > 0
            if truth is None:
                continue
            for m, mask in masks.items():
                counts[m] = counts[m] + real_sequences.f1_counts(mask, truth)
            if len(kept) < keep and (number - info.temporal_roi[0]) % (every * step) == 0:
                kept.append((number, frame, truth, {m: masks[m] for m in ("ours",) + tuple(PEERS)}))
    return counts, kept


def score_sequences(names, score, prefix: str, plots, desc: str) -> tuple[dict, dict, list]:
    """Every sequence of `names` through `score(name) -> (Counts per method, kept frames)`: (metrics
    f"{prefix}f1_{name}_{method}" with precision and recall alike, contact sheets
    f"{prefix or 'background_'}{name}.png", the names scored); a sequence whose files are missing is
    skipped, saying so."""
    metrics, figures, scored = {}, {}, []
    bar = progress(names, desc=desc)
    for name in bar:
        bar.set_postfix_str(name)
        try:
            counts, kept = score(name)
        except FileNotFoundError as missing:
            print(f"note: {missing}; {name} skipped")
            continue
        for m, c in counts.items():
            metrics[f"{prefix}f1_{name}_{m}"] = c.f1
            metrics[f"{prefix}precision_{name}_{m}"] = c.precision
            metrics[f"{prefix}recall_{name}_{m}"] = c.recall
        scored.append(name)
        figures[f"{prefix or 'background_'}{name}.png"] = plots.background_sheet(name, kept)
    return metrics, figures, scored


def background_stage(cfg, plots) -> StageResult:
    """F1, precision and recall per real sequence and method, and a contact sheet per sequence."""
    structure, options = BackgroundStructure.real_video(), BackgroundOptions.real_video()
    metrics, figures, rows = score_sequences(
        cfg.real_sequences, lambda name: score_sequence(cfg.real_data, name, structure, options, cfg.real_step,
                                                        cfg.real_max_frames or None, cfg.sheet_frames // 2),
        "", plots, "real sequences")
    metrics["real_sequences_scored"] = rows
    if rows:
        for m in METHODS:
            metrics[f"f1_mean_{m}"] = float(np.mean([metrics[f"f1_{n}_{m}"] for n in rows]))
        metrics["ours_at_least_mog2_everywhere"] = bool(all(metrics[f"f1_{n}_ours"] >= metrics[f"f1_{n}_mog2"]
                                                            for n in rows))
    return StageResult(metrics, figures)
