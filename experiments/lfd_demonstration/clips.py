"""The pre-segmented OAC clips through the video front end (issue 19): per clip, the pipeline's
features and the renderer's over its pick-up..put-down frames (`features`), cached; as `OACData` for
the OAC study's protocol (ECCV 2008 Tables 2-4, LfD 2009 Table I: leave-one-person-out, every CRF of
the papers, `experiments.oac_recognition.models.evaluate`) and for the CHCRF that labels the long
recordings (`labelling`)."""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import json
from pathlib import Path
from typing import NamedTuple

import numpy as np

from experiments.config import progress
from experiments.data import video
from experiments.data.oac import OACData
from experiments.lfd_demonstration.config import Config
from experiments.lfd_demonstration.front import recording_objects
from experiments.lfd_demonstration.features import (FeatureSpec, FrameFeatures, as_oac_data, pipeline_features,
                                                    renderer_features, segment_frames)
from experiments.oac_recognition import config as oac_config
from experiments.oac_recognition.models import evaluate
from lfd_common import cache_dir, write_npz

SOURCES = ("pipeline", "renderer")


def cut_recording(rec: video.Recording, T: int) -> video.Recording:
    """The recording's first T frames (every per-frame field cut; events, cameras and scalars kept)."""
    n = len(rec.left)
    per_frame = {f: getattr(rec, f)[:T] for f in rec._fields
                 if isinstance(getattr(rec, f), np.ndarray) and getattr(rec, f).ndim and len(getattr(rec, f)) == n
                 and not f.endswith(("_frames", "event_action", "event_object"))}
    return rec._replace(**per_frame)


@functools.cache  # once per process: a file edited during a run does not split its cache
def source_digest() -> str:
    """The code that makes a clip's features: `features`, `clip_features`, the front end's functions (of
    `stages` and of the video study) and every file of the hog_jax package (read from disk, so every
    entry point gets the same key), so an edit of any of them never reuses stale features (edits of
    the tables, labels, report or figures keep the cache)."""
    import experiments.lfd_demonstration.features as features
    import experiments.lfd_demonstration.front as stages
    import experiments.video_segmentation.stages as front
    import hog_jax

    package = sorted(Path(hog_jax.__file__).parent.rglob("*.py"))
    parts = [features, clip_features, stages.front_end, stages.hand_tracks, stages.recording_objects,
             stages.hand_width, front.skin_stage, front.background_options, front.segmentation_start, front.pad,
             front.camera_of]
    text = "".join(f.read_text() for f in package) + "".join(inspect.getsource(m) for m in parts)
    return hashlib.sha1(text.encode()).hexdigest()


# the settings that change a clip's features (not the tables' or the long recordings')
_FEATURE_FIELDS = ("seed", "video_preset", "n_persons", "n_skin_persons", "pad_frames", "half_window", "blur_sigma",
                   "threshold", "n_samples", "min_hand_motion", "remove_person", "feature_fps")


def _cache_path(cfg: Config, settings, spec: FeatureSpec, key: tuple[int, int, int]):
    video_fields = {k: v for k, v in dataclasses.asdict(settings).items() if k not in ("n_scripts", "script_oacs")}
    blob = json.dumps({"cfg": {k: getattr(cfg, k) for k in _FEATURE_FIELDS}, "settings": video_fields,
                       "spec": dataclasses.asdict(spec), "clip": key, "code": source_digest()}, sort_keys=True)
    return cache_dir("lfd_clip_features") / f"clip_{hashlib.sha1(blob.encode()).hexdigest()[:16]}.npz"


def _save(path, feats: dict[str, FrameFeatures], hand_found: bool) -> None:
    write_npz(path, hand_found=hand_found,
              **{f"{s}_{f}": getattr(feats[s], f) for s in SOURCES for f in FrameFeatures._fields})


def _load(path) -> tuple[dict[str, FrameFeatures], bool]:
    with np.load(path) as z:
        return ({s: FrameFeatures(*(z[f"{s}_{f}"] for f in FrameFeatures._fields)) for s in SOURCES},
                bool(z["hand_found"]))


def clip_features(cfg: Config, settings, rgb_skin, spec: FeatureSpec, key: tuple[int, int, int],
                  script) -> tuple[dict[str, FrameFeatures], bool]:
    """({"pipeline", "renderer"}: features of the clip's OAC frames at `feature_fps`, hand found): the
    clip is cut after its put-down (the front end is causal), run through `recording_objects`; a clip
    whose hand the front end never finds keeps zero pipeline features (flagged, not dropped)."""
    path = _cache_path(cfg, settings, spec, key)
    if path.exists():
        return _load(path)
    rec = video.render_recording(settings, script, progress=progress)
    a, b = int(rec.pickup_frames[0]), int(rec.putdown_frames[0]) + 1
    rec = cut_recording(rec, b)
    frames = segment_frames(a, b, settings.fps, cfg.feature_fps)
    pick = lambda f: FrameFeatures(*(np.asarray(x)[frames] for x in f))  # noqa: E731
    half = (round(cfg.half_window * cfg.scale(settings)),) * 2
    renderer = pick(renderer_features(rec, video.grey(rec.left), half, spec))
    person, cls, rep = key
    out = recording_objects(cfg, settings, rec, rgb_skin, 10_000 + 1000 * person + 100 * cls + rep, peer=False)
    pipeline = (pick(pipeline_features(out, spec)) if out is not None
                else FrameFeatures(*(np.zeros_like(x) for x in renderer)))
    feats = {"pipeline": pipeline, "renderer": renderer}
    _save(path, feats, out is not None)
    return feats, out is not None


class ClipSet(NamedTuple):
    """The clips' features per source as `OACData`, and how many clips lost the hand."""

    data: dict
    hand_lost: int
    n_clips: int


def clip_stage(cfg: Config, settings, rgb_skin, spec: FeatureSpec) -> ClipSet:
    """Every clip of the clip persons (`cfg.clip_repetitions` per person and OAC) through the pipeline,
    the first repetition of every person and OAC first (a clip's features do not depend on the order)."""
    persons = cfg.clip_persons(settings)
    jobs = sorted(((p, c, r, s) for p, c, r, s in video.clip_scripts(settings)
                   if p in persons and r < cfg.clip_repetitions), key=lambda job: (job[2], job[0], job[1]))
    feats, meta, lost = {s: [] for s in SOURCES}, [], 0
    for p, c, r, script in progress(jobs, desc="OAC clips through the front end"):
        f, found = clip_features(cfg, settings, rgb_skin, spec, (p, c, r), script)
        lost += not found
        for s in SOURCES:
            feats[s].append(f[s])
        meta.append((c, c, p, r))
    meta = np.array(meta, int).reshape(-1, 4)
    data = {s: as_oac_data(feats[s], *meta.T) for s in SOURCES}
    return ClipSet(data, lost, len(jobs))


def crf_config(cfg: Config, n_persons: int) -> oac_config.Config:
    """The OAC study's CRF protocol with this study's runs and search settings."""
    return oac_config.Config(seed=cfg.seed, n_persons=n_persons, n_runs=cfg.n_runs, max_iter=cfg.crf_max_iter,
                             n_hidden=cfg.n_hidden)


def tables(cfg: Config, clips: ClipSet) -> dict:
    """Per source: the OAC study's tables (nested {median, max} error %), LfD's Table I as `table1`."""
    out = {}
    for source, data in clips.data.items():
        t, _ = evaluate(crf_config(cfg, int(data.person.max()) + 1), data)
        t["table1"] = t.pop("table_lfd")
        out[source] = t
    return out


def hand_features_found(data: OACData) -> float:
    """The fraction of real frames with a non-zero hand HOG."""
    valid = np.arange(data.hand_hog.shape[1])[None] < data.lengths[:, None]
    return float((np.abs(data.hand_hog).sum(-1) > 0)[valid].mean())


def table_metrics(by_source: dict, clips: ClipSet) -> dict:
    """The pipeline's tables as `table1_*` .. `table4_*` (error %, median and max over the runs), the
    renderer masks' as `renderer_table*`, and the clips' counts."""
    from experiments.oac_recognition.stages import with_units

    out = {k: v for k, v in with_units(by_source["pipeline"]).items()}
    out["renderer"] = with_units(by_source["renderer"])
    out.update(clips_n=clips.n_clips, clips_hand_lost=clips.hand_lost,
               clips_hand_hog_rate=hand_features_found(clips.data["pipeline"]),
               clips_hand_hog_rate_renderer=hand_features_found(clips.data["renderer"]))
    return out
