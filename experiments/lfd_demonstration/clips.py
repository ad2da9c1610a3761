"""The pre-segmented OAC clips through the video front end: per clip, the pipeline's features and the
renderer's over its pick-up..put-down frames (`features`), cached; as `OACData` for the OAC protocol
(ECCV 2008 Tables 2-4, LfD 2009 Table I: leave-one-person-out, every CRF of the papers,
`experiments.data.oac_protocol.evaluate`) and for the CHCRF that labels the long recordings
(`labelling`)."""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from experiments.config import progress
from experiments.data import video
from experiments.data.oac import OACData
from experiments.data.oac_protocol import ProtocolOptions, evaluate, with_units
from experiments.data.video.settings import SOURCE_PACKAGES
from experiments.lfd_demonstration.config import Config
from experiments.lfd_demonstration.front import recording_objects
from experiments.lfd_demonstration.features import (FeatureSpec, FrameFeatures, as_oac_data, hand_window_features,
                                                    pipeline_features, renderer_features, segment_frames)
from experiments.lfd_demonstration.object_pixels import PixelCues, PixelFrames, window_cues
from lfd_common import Cache

SOURCES = ("pipeline", "renderer")


# the settings that change a clip's features (not the tables' or the long recordings')
_FEATURE_FIELDS = ("seed", "video_preset", "n_persons", "n_skin_persons", "pad_frames", "half_window", "blur_sigma",
                   "threshold", "n_samples", "min_hand_motion", "remove_person", "feature_fps")


# The rendering, the features, this module's `clip_features` and the front end of `front` with what it
# imports (`hog_jax` with its video front end, the peers); the tables', labels', report's and figures' modules
# stay out.
CLIP_PACKAGES: tuple[str, ...] = SOURCE_PACKAGES + (
    "experiments.lfd_demonstration.clips", "experiments.lfd_demonstration.features",
    "experiments.lfd_demonstration.front", "experiments.lfd_demonstration.config",
    "experiments.lfd_demonstration.evaluate", "experiments.lfd_demonstration.object_pixels", "experiments.peers",
    "hog_jax")
_CLIPS = Cache("lfd_clip_features", packages=CLIP_PACKAGES)


class InHandFrames(NamedTuple):
    """Training frames of the "object in hand" classifier (`in_hand`): the clip's person (N,), the
    `features.hand_window_features` (N, D) of its tracked frames, and whether the hand held the object (N,)."""

    person: np.ndarray
    features: np.ndarray
    held: np.ndarray


class ClipFeatures(NamedTuple):
    """One clip's features: {"pipeline", "renderer"}: `FrameFeatures` of its OAC frames at `feature_fps`,
    whether the front end found the hand, and the training frames of the "object in hand" classifier
    (`InHandFrames`) and of the object's pixels (`object_pixels.PixelFrames`), None where the hand was lost."""

    features: dict
    hand_found: bool
    in_hand: InHandFrames | None
    pixels: PixelFrames | None


def clip_features(cfg: Config, settings, skin_model, spec: FeatureSpec, key: tuple[int, int, int],
                  script) -> ClipFeatures:
    """The `ClipFeatures` of one clip: the whole clip runs through
    `recording_objects`, the return to rest after the put-down included (the classifier needs empty-hand
    frames on both sides of a period; sigma_m, the hand's width, is then the median over the whole clip, as
    over a whole long recording); a clip whose hand the front end never finds keeps zero pipeline
    features and gives no training frames (flagged, not dropped). Cached under
    `cache_dir("lfd_clip_features")` by the feature settings, the video settings (less the long
    recordings'), the spec, the clip, its script, the skin model and the source of `CLIP_PACKAGES`."""
    video_fields = {k: v for k, v in dataclasses.asdict(settings).items() if k not in ("n_scripts", "script_oacs")}
    return _CLIPS.get(lambda: _clip_features(cfg, settings, skin_model, spec, key, script),
                      cfg={k: getattr(cfg, k) for k in _FEATURE_FIELDS}, settings=video_fields, spec=spec,
                      clip=tuple(key), script=script, skin_model=skin_model)


def _clip_features(cfg: Config, settings, skin_model, spec: FeatureSpec, key: tuple[int, int, int],
                   script) -> ClipFeatures:
    """`clip_features`, computed."""
    rec = video.render_recording(settings, script, progress=progress)
    a, b = int(rec.pickup_frames[0]), int(rec.putdown_frames[0]) + 1
    frames = segment_frames(a, b, settings.fps, cfg.feature_fps)
    pick = lambda f: FrameFeatures(*(np.asarray(x)[frames] for x in f))  # noqa: E731
    half = (round(cfg.half_window * cfg.scale(settings)),) * 2
    renderer = pick(renderer_features(rec, video.grey(rec.left), half, spec))
    person, cls, rep = key
    out = recording_objects(cfg, settings, rec, skin_model, 10_000 + 1000 * person + 100 * cls + rep, peer=False)
    if out is None:
        return ClipFeatures({"pipeline": FrameFeatures(*(np.zeros_like(x) for x in renderer)), "renderer": renderer},
                            False, None, None)
    tracked = np.flatnonzero(out["tracked"])
    features = hand_window_features(out["grey"][tracked], out["labels"][tracked], out["hand"][tracked],
                                    out["half"])
    held = np.asarray(rec.object) >= 0
    in_hand = InHandFrames(np.full(tracked.size, person), features, held[tracked])
    cues = window_cues(out["objects"], out["labels"], out["hand"], out["half"])
    pixels = PixelFrames(np.full(held.size, person), out["truth"], cues).take(np.flatnonzero(out["tracked"] & held))
    return ClipFeatures({"pipeline": pick(pipeline_features(out, spec)), "renderer": renderer}, True, in_hand, pixels)


class ClipSet(NamedTuple):
    """The clips' features per source as `OACData`, how many clips lost the hand, and the clips'
    `InHandFrames` and `PixelFrames` concatenated (None when every clip lost it)."""

    data: dict
    hand_lost: int
    n_clips: int
    in_hand: InHandFrames | None
    pixels: PixelFrames | None


def clip_stage(cfg: Config, settings, skin_model, spec: FeatureSpec) -> ClipSet:
    """Every clip of the clip persons (`cfg.clip_repetitions` per person and OAC) through the pipeline,
    the first repetition of every person and OAC first (a clip's features do not depend on the order)."""
    persons = cfg.clip_persons(settings)
    jobs = sorted(((p, c, r, s) for p, c, r, s in video.clip_scripts(settings)
                   if p in persons and r < cfg.clip_repetitions), key=lambda job: (job[2], job[0], job[1]))
    clips = [clip_features(cfg, settings, skin_model, spec, (p, c, r), script)
             for p, c, r, script in progress(jobs, desc="OAC clips through the front end")]
    meta = np.array([(c, c, p, r) for p, c, r, _ in jobs], int).reshape(-1, 4)
    data = {s: as_oac_data([clip.features[s] for clip in clips], *meta.T) for s in SOURCES}
    found = [clip for clip in clips if clip.hand_found]
    in_hand = InHandFrames(*(np.concatenate(x) for x in zip(*(c.in_hand for c in found)))) if found else None
    pixels = None
    if found:
        cues = PixelCues(*(np.concatenate(x) for x in zip(*(c.pixels.cues for c in found))))
        pixels = PixelFrames(np.concatenate([c.pixels.person for c in found]),
                             np.concatenate([c.pixels.truth for c in found]), cues)
    return ClipSet(data, len(clips) - len(found), len(jobs), in_hand, pixels)


def crf_config(cfg: Config, n_persons: int) -> ProtocolOptions:
    """The OAC protocol with this study's runs and search settings (the other settings the OAC study's)."""
    return ProtocolOptions(seed=cfg.seed, n_persons=n_persons, n_runs=cfg.n_runs, max_iter=cfg.crf_max_iter,
                           n_hidden=cfg.n_hidden)


def tables(cfg: Config, clips: ClipSet) -> dict:
    """Per source: the OAC protocol's tables (nested {median, max} error %), LfD's Table I as `table1`."""
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
    out = {k: v for k, v in with_units(by_source["pipeline"]).items()}
    out["renderer"] = with_units(by_source["renderer"])
    out.update(clips_n=clips.n_clips, clips_hand_lost=clips.hand_lost,
               clips_hand_hog_rate=hand_features_found(clips.data["pipeline"]),
               clips_hand_hog_rate_renderer=hand_features_found(clips.data["renderer"]))
    return out
