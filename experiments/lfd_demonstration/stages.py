"""The stages of the learning-from-demonstration study and its `main`: skin models from the
last persons' clips; every long recording through the video front end (`hog_jax.video.segment_stereo`),
the object in the hand from phase differences (`hog_jax.video.segment_objects`) beside the OpenCV peer,
and the pick-up / put-down events (`hog_jax.video.periods_in_hand`); figures; one writer."""
from __future__ import annotations

import time

import numpy as np

import hog_jax
import sim
from experiments.config import StageResult, parse_config, progress
from experiments.data import video
from experiments.lfd_demonstration import plots
from experiments.lfd_demonstration.front import recording_objects
from experiments.lfd_demonstration.boundaries import (SEARCH_AFTER_S, SEARCH_BEFORE_S, SPEED_SMOOTH_S, hand_speed,
                                                      snap_to_slowest)
from experiments.lfd_demonstration.clips import ClipSet, InHandFrames, clip_stage, table_metrics, tables
from experiments.lfd_demonstration.config import PRESETS, Config
from experiments.lfd_demonstration.features import FeatureSpec, hand_window_features, pipeline_features
from experiments.lfd_demonstration.in_hand import (EVIDENCE_CAP, SWITCH_COST_PER_FPS, fit_in_hand,
                                                  in_hand_log_odds, in_hand_path)
from experiments.lfd_demonstration.labelling import label_metrics, label_periods
from experiments.lfd_demonstration.object_pixels import PixelFrames, fit_object_pixels, object_pixel_masks, window_cues
from experiments.lfd_demonstration.evaluate import EventMatch, held_object_motion, iou_by_bin, match_events, pooled_iou
from experiments.lfd_demonstration.report import report
from lfd_common import enable_compilation_cache

def _event_metrics(matches: list, prefix: str) -> dict:
    pick = np.concatenate([np.abs(m.pickup_error) for m in matches])
    put = np.concatenate([np.abs(m.putdown_error) for m in matches])
    stat = lambda f, x: float(f(x)) if x.size else float("nan")
    return {f"{prefix}pickup_error_frames": stat(np.mean, pick), f"{prefix}putdown_error_frames": stat(np.mean, put),
            f"{prefix}pickup_error_frames_median": stat(np.median, pick),
            f"{prefix}putdown_error_frames_median": stat(np.median, put),
            f"{prefix}events_missed": sum(m.missed for m in matches),
            f"{prefix}events_spurious": sum(m.spurious for m in matches), f"{prefix}events_matched": int(pick.size)}


def _all_missed(n_true: int) -> EventMatch:
    """The events of a recording nothing was found in (a flagged hand or classifier): every true one missed."""
    return EventMatch(np.zeros(0, int), np.zeros(0, int), n_true, 0)


# the object masks whose pooled IoU is reported: ours (phase, the paper's), the OpenCV peer's, the learned
# pixels (`object_pixels`), and ours and the peer's restricted to the periods the learned ones are shown in
MASK_SOURCES = ("ours", "peer", "learned", "ours_in_periods", "peer_in_periods")
DEPTH_EDGES_CM = (0.0, 1.0, 2.0, 4.0, 8.0, np.inf)
ROTATION_EDGES_DEG = (0.0, 1.0, 2.0, 4.0, 8.0, np.inf)


def failure_cases(w: dict) -> dict:
    """LfD §III-B's failure cases: pooled object IoU (ours, peer, learned) by the held object's depth offset from
    the hand (|cm|) and by its in-plane rotation (degrees per frame), `evaluate.held_object_motion`."""
    return {f"{what}_{name}": iou_by_bin(w[name], w["truth"], w[key], edges)
            for what, key, edges in (("depth_offset_cm", "depth", DEPTH_EDGES_CM),
                                     ("rotation_deg_per_frame", "rotation", ROTATION_EDGES_DEG))
            for name in ("ours", "peer", "learned")}


def recording_labels(cfg: Config, settings, clips, rec, out: dict, periods, match, spec: FeatureSpec) -> dict:
    """The CHCRF labels (eqs. 9-10) of one recording's found periods and, as the oracle segmentation,
    of its true ones, each with the true OAC where a found period matched one."""
    feats = pipeline_features(out, spec)
    label = lambda starts, stops: label_periods(cfg, settings, clips, int(rec.person), feats, out["hand"],  # noqa
                                                np.asarray(starts, int), np.asarray(stops, int), cfg.scale(settings))
    truth = np.stack([rec.event_action, rec.event_object], 1).astype(int)
    found_truth = np.full((len(periods.pickup), 2), -1)
    found_truth[match.found_index] = truth[match.true_index]
    return {"found": label(periods.pickup, periods.putdown), "found_truth": found_truth, "found_periods": periods,
            "true": label(rec.pickup_frames, np.asarray(rec.putdown_frames) + 1), "true_truth": truth}


def classifier_in_hand(frames: InHandFrames | None, person: int, out: dict, fps: float) -> np.ndarray | None:
    """(T,) "object in hand" of a recording's frames from the classifier (`in_hand`) trained on the
    clips of the other persons: its log odds (capped at `EVIDENCE_CAP`, 0 where the hand is not tracked)
    through `in_hand_path`; None without such clips or where they show one class only (flagged: the
    classifier's events are then all missed)."""
    if frames is None:
        return None
    others = frames.person != person
    if np.unique(frames.held[others]).size < 2:
        return None
    classifier = fit_in_hand(frames.features[others], frames.held[others])
    log_odds = in_hand_log_odds(classifier, hand_window_features(out["grey"], out["labels"], out["hand"], out["half"]))
    evidence = np.where(out["tracked"], np.clip(log_odds, -EVIDENCE_CAP, EVIDENCE_CAP), 0.0)
    return in_hand_path(evidence, SWITCH_COST_PER_FPS * fps)


def learned_object_masks(pixels: PixelFrames | None, person: int, out: dict, held: np.ndarray) -> np.ndarray | None:
    """(T, h, w) the held object's pixels (`object_pixels`) in a recording's frames that `held` (T,) says
    hold an object, from the model fitted on the clips of the other persons; None without such clips."""
    others = np.zeros(0, int) if pixels is None else np.flatnonzero(pixels.person != person)
    if others.size == 0:
        return None
    model = fit_object_pixels(pixels.take(others))
    cues = window_cues(out["objects"], out["labels"], out["hand"], out["half"])
    return object_pixel_masks(model, cues, held & out["tracked"])


def object_stage(cfg: Config, settings, skin_model, clips: ClipSet | None = None,
                 spec: FeatureSpec = FeatureSpec()) -> tuple[dict, StageResult]:
    """Every long recording: the object in the hand (ours and the peer), pooled IoUs, the events of the
    paper's rule (a mask found: ours, the peer) and of the hand-window classifier (`in_hand`, with
    `clips`; its boundaries moved to the hand's slowest frames, `boundaries`); with `clips`, the CHCRF label
    and Z(x) of each OAC the classifier found."""
    radius = max(1, round(cfg.filter_radius * settings.fps / 25.0))
    frames = lambda seconds: max(1, round(seconds * settings.fps))  # noqa: E731
    sums = {name: np.zeros(2, int) for name in MASK_SOURCES}
    events = {"ours": [], "peer": [], "classifier": []}
    rows, first, labelled, learned_ran = [], None, [], False
    cases = {"ours": [], "peer": [], "learned": [], "truth": [], "depth": [], "rotation": []}  # the failure cases
    for i, script in enumerate(progress(video.long_scripts(settings), desc="long recordings")):
        rec = video.render_recording(settings, script, progress=progress)
        out = recording_objects(cfg, settings, rec, skin_model, i)
        row = {"person": int(script.person), "frames": int(len(rec.left)), "true_events": int(len(rec.pickup_frames)),
               "hand_found": out is not None}
        rows.append(row)
        if out is None:  # flagged: every true event of the recording is missed
            for name in events:
                events[name].append(_all_missed(len(rec.pickup_frames)))
            continue
        row.update(sigma_px=out["sigma_px"], tracked=float(out["tracked"][out["start"]:].mean()))
        classified = classifier_in_hand(clips and clips.in_hand, int(script.person), out, settings.fps)
        found_by = {"ours": (out["ours"][1], out["decided"]), "peer": (out["peer"][1], out["decided"]),
                    "classifier": (classified, out["tracked"])}
        segmented = {}
        for name, (found, decided) in found_by.items():
            if found is None:
                events[name].append(_all_missed(len(rec.pickup_frames)))
                continue
            periods = hog_jax.video.periods_in_hand(found, settings.fps, radius, cfg.min_duration_s, decided)
            if name == "classifier":
                periods = snap_to_slowest(periods, hand_speed(out["hand"], out["tracked"], frames(SPEED_SMOOTH_S)),
                                          frames(SEARCH_BEFORE_S), frames(SEARCH_AFTER_S))
            match = match_events(rec.pickup_frames, rec.putdown_frames, periods.pickup, periods.putdown)
            events[name].append(match)
            segmented[name] = (found, decided, periods, match)
            row.update({f"{name}_missed": match.missed, f"{name}_spurious": match.spurious,
                        f"{name}_found_events": int(len(periods.pickup))})
        source = "classifier" if "classifier" in segmented else "ours"  # the periods the CHCRF labels
        found, decided, periods, match = segmented[source]
        held = periods.in_hand
        learned = None  # the learned pixels are shown in the classifier's periods only
        if source == "classifier":
            learned = learned_object_masks(clips and clips.pixels, int(script.person), out, held)
        learned_ran |= learned is not None
        masks = {"ours": out["ours"][0], "peer": out["peer"][0],
                 "learned": np.zeros_like(out["truth"]) if learned is None else learned,
                 "ours_in_periods": out["ours"][0] & held[:, None, None],
                 "peer_in_periods": out["peer"][0] & held[:, None, None]}
        for name in MASK_SOURCES:
            counts = pooled_iou(masks[name], out["truth"])
            sums[name] += counts
            row[f"{name}_iou"] = counts[0] / max(counts[1], 1)
        depth, rotation = held_object_motion(rec)
        for key, value in (("ours", masks["ours"]), ("peer", masks["peer"]), ("learned", masks["learned"]),
                           ("truth", out["truth"]), ("depth", np.abs(depth)), ("rotation", rotation)):
            cases[key].append(value)
        if clips is not None:
            labelled.append(recording_labels(cfg, settings, clips.data["pipeline"], rec, out, periods, match, spec))
        if first is None:
            first = {**out, "rec": rec, "masks": out["ours"][0], "learned": masks["learned"], "raw": found,
                     "decided": decided, "periods": periods,
                     "source": source, "labels": labelled[-1] if labelled else None}
    iou = {name: sums[name][0] / max(sums[name][1], 1) for name in MASK_SOURCES}
    if not learned_ran:
        iou["learned"] = float("nan")
    metrics = {"object_mask_iou": iou["ours"], "object_mask_iou_peer": iou["peer"],
               "object_mask_iou_learned": iou["learned"], "object_mask_iou_in_periods": iou["ours_in_periods"],
               "object_mask_iou_peer_in_periods": iou["peer_in_periods"], "n_recordings": len(rows),
               "events_true": sum(r["true_events"] for r in rows),
               "recordings": {str(k): r for k, r in enumerate(rows)},
               **_event_metrics(events["ours"], ""), **_event_metrics(events["peer"], "peer_"),
               **_event_metrics(events["classifier"], "classifier_")}
    if first is None:
        return metrics, StageResult(metrics)
    failure = failure_cases({k: np.concatenate(v) for k, v in cases.items()})
    metrics["iou_by"] = failure
    if labelled:
        metrics.update(label_metrics(labelled))
    figures = {"fig3_likelihood_ratios.png": plots.likelihood_ratios(first),
               "fig8_object_in_hand.png": plots.object_in_hand(first, settings.fps),
               "object_masks.png": plots.object_mask_sheet(first),
               "iou_vs_depth_and_rotation.png": plots.iou_by_motion(failure)}
    return metrics, StageResult(metrics, figures)


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, name="lfd_demonstration", argv=argv)
    sim.setup_rendering()
    enable_compilation_cache()
    start_s = time.perf_counter()
    settings = cfg.video_settings()
    skin_persons = range(settings.n_persons - cfg.n_skin_persons, settings.n_persons)
    skin_model, skin_metrics = video.fit_skin_models(settings, skin_persons, cfg.seed)
    spec = FeatureSpec()
    clip_metrics, clip_set = {}, None
    if cfg.clip_repetitions:
        clip_set = clip_stage(cfg, settings, skin_model, spec)
        clip_metrics = table_metrics(tables(cfg, clip_set), clip_set)
    metrics, result = object_stage(cfg, settings, skin_model, clip_set, spec)
    metrics.update(clip_metrics)
    runtime = time.perf_counter() - start_s
    written = run.write_stages([result], header=report(cfg, settings, metrics, runtime), runtime_s=runtime,
                               **skin_metrics, **clip_metrics)
    print(f"wrote {run.path}/ in {runtime:.0f} s")
    return written
