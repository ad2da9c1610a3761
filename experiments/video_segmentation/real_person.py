"""The real-video part of the study, the person: the whole front end (`VideoOptions.real_video()`: the
background model, the colour models learnt before frame `cfg.real_person_start`, the competing level
sets) streamed in chunks through the SBI indoor sequences, whose masks mark the people (and the
objects they leave). A pixel is the front end's foreground where the level sets give it a region
other than the background (person, skin or object; the one-pixel boundaries between regions count as
background), scored from `real_person_start` on by CDnet's convention, beside the background model's
own foreground of the same run (the motion mask the level sets start from)."""
from __future__ import annotations

import itertools
from pathlib import Path

import jax
import numpy as np

from experiments.config import StageResult
from experiments.data.video import real_sequences
from experiments.video_segmentation.real_background import chunks_of, score_sequences
from hog_jax.video import VideoOptions, fit_video_models, stream_recording
from lfd_jax import UCI_FILE, fit_real_skin_model

CHUNK = 32  # frames per call of the front end: memory holds a chunk, not the sequence
METHODS = ("front_end", "background_model")


def score_person(cfg, skin, name: str, keep: int) -> tuple[dict, list]:
    """(Counts per method, up to `keep` scored frames as (number, frame, truth, {method: mask})) of one
    SBI sequence through the front end."""
    options = VideoOptions.real_video()
    start = cfg.real_person_start
    items = real_sequences.iter_sequence(cfg.real_data, name, stop=cfg.real_max_frames or None)
    head = list(itertools.islice(items, start))
    if len(head) < start:
        raise ValueError(f"real_person_start: {name} has {len(head)} frames, fewer than {start}")
    models, _ = fit_video_models(jax.random.key(cfg.seed + 2), skin, np.stack([f for _, f, _ in head]), start, options)
    counts = {m: real_sequences.Counts() for m in METHODS}
    kept = []
    info = real_sequences.sequence_info(cfg.real_data, name)
    every = max(1, (len(info.numbers) - start) // max(keep, 1))
    pending = []  # the (number, frame, truth) of the chunk being segmented, in step with its masks

    def frames_of(groups):
        for group in groups:
            pending[:] = group
            yield np.stack([f for _, f, _ in group])

    source = chunks_of(itertools.chain(head, items), CHUNK)
    for seg in stream_recording(models, frames_of(source), start, options, total=len(info.numbers)):
        labels, motion = np.asarray(seg.labels), np.asarray(seg.foreground)
        for i, (number, frame, truth) in enumerate(pending):
            if truth is None or number < start:
                continue
            masks = {"front_end": labels[i] >= 1, "background_model": motion[i]}
            for m, mask in masks.items():
                counts[m] = counts[m] + real_sequences.f1_counts(mask, truth)
            if len(kept) < keep and (number - start) % every == 0:
                kept.append((number, frame, truth, masks))
    return counts, kept


def person_stage(cfg, plots) -> StageResult:
    """The front end's person F1 per SBI sequence beside its background model's; a contact sheet each."""
    names = [n for n in cfg.real_sequences if n.startswith("sbi_")]
    if not names or not (Path(cfg.real_data) / UCI_FILE).is_file():
        print(f"note: no SBI sequence chosen or no skin pixels ({UCI_FILE}) under {cfg.real_data}; the person is not scored")
        return StageResult({"person_sequences_scored": []})
    skin = fit_real_skin_model(cfg.real_data, seed=cfg.seed)
    metrics, figures, scored = score_sequences(names, lambda name: score_person(cfg, skin, name, cfg.sheet_frames // 2),
                                               "person_", plots, "real people")
    metrics["person_sequences_scored"] = scored
    return StageResult(metrics, figures)
