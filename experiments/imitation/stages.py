"""The stages of the imitation loop and its `main`: skin models, the grasp
recogniser, the PHMMs, the settings chosen on validation demonstrations, every evaluated demonstration
through the loop (`run_demo`), the metrics, the report and a side-by-side video."""
from __future__ import annotations

import time
from typing import Any, NamedTuple

import numpy as np

import phmm_jax as P
import sim
from experiments.config import parse_config, progress
from experiments.imitation import pipeline as pl
from experiments.imitation.config import PRESETS, VALIDATION_SEED, Config
from experiments.imitation.demonstrations import Demo, demo_track, draw_demos, render_demo, table_xy, table_z
from experiments.imitation.grasp_stage import grasp_function, grasp_recogniser, view_rotation
from lfd_common import Cache, enable_compilation_cache
from lfd_jax import imitation as im

STAGES = ("tracking", "action", "target", "grasp", "place")  # recognition stages, in the loop's order
_TRAIN_SEED = 2000
DISTURBED_M = 0.05  # another object pushed farther than this (x-y) by the robot counts as disturbed


class Models(NamedTuple):
    """What the loop runs with: the skin model (the hand crop and the front end), the
    grasp recogniser, the PHMMs (`KINDS` order, then the reach PHMM) and the settings chosen on validation
    demonstrations."""

    skin: Any
    grasp: Any
    phmms: list
    offset: np.ndarray
    sigma_m: float
    threshold_m: float
    online: Any
    reach: Any  # the reach PHMM with the chosen observation noise (`lfd_jax.imitation.reach_target`)


def skin_models(cfg: Config, settings):
    """The video study's skin model from the clips of the last `n_skin_persons` (no demonstrator)."""
    from experiments.data.video import fit_skin_models

    return fit_skin_models(settings, range(cfg.demonstrators, cfg.n_persons), cfg.seed)[0]


# `pipeline.train_phmms` runs the demonstrations' kinematics, `lfd_jax.imitation` and `phmm_jax`; the pipeline
# module's import closure is `TRACK_PACKAGES`, the rest of `lfd_jax.imitation` and `phmm_jax`.
_PHMMS = Cache("imitation_phmm", packages=pl.TRACK_PACKAGES + ("lfd_jax.imitation", "phmm_jax"))


def phmm_models(cfg: Config, settings) -> list:
    """The PHMMs trained on kinematics of their own seed (`pipeline.train_phmms`), cached (one file)."""
    fields = {k: getattr(cfg, k) for k in ("seed", "n_persons", "n_skin_persons", "handover_xy", "n_states",
                                           "train_repetitions", "phmm_iter")}
    return _PHMMS.get(lambda: pl.train_phmms(cfg, settings, cfg.seed + _TRAIN_SEED), cfg=fields, settings=settings)


def tracked_demo(cfg, settings, demo, skin):
    rec = render_demo(settings, demo, progress=None)
    return rec, pl.track(cfg, settings, demo, rec, skin)


def validation_stage(cfg: Config, settings, phmms, skin) -> tuple[np.ndarray, float, float, dict]:
    """The tracker's offset (median of tracked - kinematic features), the PHMMs' observation noise and
    the detector's threshold, chosen on `n_validation` demonstrations of their own seed by the number of
    right actions plus right targets (ties: the first in the config's order)."""
    demos = draw_demos(cfg.n_validation, cfg.seed + VALIDATION_SEED, cfg.demonstrators, cfg.handover_xy)
    actors = pl.Actors(settings)
    tracked, gaps = [], []
    for demo in progress(demos, desc="validation demonstrations"):
        rec, t = tracked_demo(cfg, settings, demo, skin)
        x, visible = pl.kinematic_features(actors(demo), demo_track(actors(demo), demo, settings))
        both = im.plausible(t, cfg.median_frames) & visible[: len(t.found)]
        gaps.append(t.diff[both] - x[: len(t.found)][both])
        tracked.append(t)
    gaps = np.concatenate(gaps) if gaps else np.zeros((0, 3))
    offset = np.median(gaps, axis=0) if len(gaps) else np.zeros(3)
    scores = {}
    for sigma in cfg.noise_sigmas_m:
        for thr in cfg.online_thresholds_m:
            online = im.recognizer(phmms, sigma, thr, cfg.online_window)
            reach = P.with_observation_noise(phmms[pl.REACH], sigma ** 2)
            score = 0
            for demo, t in zip(demos, tracked):
                r = im.recognise_demo(online, t, offset, cfg.median_frames, demo.objects_xy, cfg.handover_xy,
                                      merge_gap=cfg.merge_gap, reach_phmm=reach, area=pl.AREA)
                score += (r.kind == demo.kind) + (r.target == demo.target)
            scores[(sigma, thr)] = score
    sigma, thr = max(scores, key=lambda k: scores[k])  # the first maximum: dict order = config order
    metrics = {"validation_demonstrations": len(demos), "validation_offset_m": [float(v) for v in offset],
               "validation_scores": {f"sigma_{s:g}_threshold_{t:g}": v for (s, t), v in scores.items()},
               "chosen_sigma_m": float(sigma), "chosen_threshold_m": float(thr)}
    return offset, float(sigma), float(thr), metrics


def prepare(cfg: Config, settings) -> tuple[Models, dict, dict]:
    """Every model of the loop and the validation choices: (Models, metrics, stage times s)."""
    times = {}
    t0 = time.perf_counter()
    skin = skin_models(cfg, settings)
    times["skin_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    grasp = grasp_recogniser(cfg, settings, skin)
    times["grasp_database_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    phmms = phmm_models(cfg, settings)
    times["phmm_training_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    offset, sigma, thr, metrics = validation_stage(cfg, settings, phmms, skin)
    times["validation_s"] = time.perf_counter() - t0
    online = im.recognizer(phmms, sigma, thr, cfg.online_window)
    reach = P.with_observation_noise(phmms[pl.REACH], sigma ** 2)
    return Models(skin, grasp, phmms, offset, sigma, thr, online, reach), metrics, times


# ------------------------------------------------------------------------------------------ robot
def scene_objects(demo: Demo) -> tuple[int, ...]:
    """The robot scene's objects (`sim.grasp_objects` classes) standing in for the video's binoculars,
    cup and pitcher (the manipulator scene's defaults, `sim.manipulator.DEFAULT_OBJECTS`); in a transfer
    the handled object is the object of the demonstrated grasp's class (the object that grasp is for)."""
    from sim.robot import DEFAULT_OBJECTS

    objects = list(DEFAULT_OBJECTS)
    if demo.kind == "transfer":
        objects[demo.target] = demo.grasp
    return tuple(objects)


def task_spec(cfg: Config, demo: Demo, r: im.Recognised) -> sim.TaskSpec:
    """The `sim.TaskSpec` of what was recognised (`lfd_jax.imitation.task_spec`) in the robot scene of the
    demonstration (`scene_objects`) with `cfg.robot_hand`."""
    return im.task_spec(r, scene_objects(demo), demo.objects_xy, cfg.robot_hand)


def robot_task(cfg: Config, demo: Demo, r: im.Recognised, phmms, render: bool = False, camera_rot=None):
    """The robot repeats what was recognised (`lfd_jax.imitation.robot_task`, MAP §III grasp strategy
    through the mapping table) with the `task_spec`, approaching along the synthesised reach to the
    object (the reach PHMM `phmms[pipeline.REACH]` where `cfg.approach` is "phmm", else a straight line),
    the hand turned as recognised where `camera_rot` (the world -> camera rotation of the view the grasp
    was recognised in, `grasp_stage.view_rotation`) is given. Returns the `sim.TaskResult`."""
    reach = phmms[pl.REACH] if cfg.approach == "phmm" else None
    return im.robot_task(r, scene_objects(demo), demo.objects_xy, reach, cfg.robot_hand, seed=int(demo.seed % 1000),
                         render=render, area=pl.AREA, camera_rot=camera_rot)


# ------------------------------------------------------------------------------------------ per demo
def scene_reader(cfg: Config, rec, tracked: im.Tracked):
    """`lfd_jax.imitation.place_reader` on the recording's left view (None without `cfg.place_from_scene`)."""
    if not cfg.place_from_scene:
        return None
    return im.place_reader(rec.left, rec.P_left, rec.fps, tracked.start, cfg.online_window, cfg.place_rest_s,
                           table_z=table_z(), table_xy=table_xy())


def run_demo(cfg: Config, settings, models: Models, demo: Demo, robot: bool = True, render_robot: bool = False) -> dict:
    """One demonstration through the loop: the recognised action, target, grasp and place beside the
    truth, the stage that failed first (None: none), the robot's outcome and per-stage times (s)."""
    times = {}
    t0 = time.perf_counter()
    rec = render_demo(settings, demo, progress=None)
    times["render_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    tracked = pl.track(cfg, settings, demo, rec, models.skin)
    times["tracking_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    grasp = grasp_function(cfg, models.grasp, models.skin, demo, rec, tracked.hand_rc, settings)
    r = im.recognise_demo(models.online, tracked, models.offset, cfg.median_frames, demo.objects_xy, cfg.handover_xy,
                          grasp, merge_gap=cfg.merge_gap, reach_phmm=models.reach,
                          scene=scene_reader(cfg, rec, tracked), area=pl.AREA)
    times["recognition_s"] = time.perf_counter() - t0
    truth_xy = np.asarray(demo.objects_xy)[demo.target]
    out = {"kind": demo.kind, "kind_recognised": r.kind, "target": demo.target, "target_recognised": r.target,
           "target_error_cm": float(np.linalg.norm(r.target_xy - truth_xy) * 100) if r.kind else float("nan"),
           "grasp": demo.grasp, "grasp_recognised": r.grasp,
           "tracked_frames": int(im.plausible(tracked, cfg.median_frames).sum()),
           "place_error_cm": float("nan"), "pickup_error_frames": float("nan"), "putdown_error_frames": float("nan"),
           "recognised": r, "rec": rec, "tracked": tracked}
    if demo.kind == "transfer" and r.kind == "transfer":
        out["place_error_cm"] = float(np.linalg.norm(r.place_xy - np.asarray(demo.place_xy)) * 100)
        out["pickup_error_frames"] = float(r.grasp_frame - rec.pickup_frames[0])
        out["putdown_error_frames"] = float(r.putdown_frame - rec.putdown_frames[0])
    checks = {"tracking": out["tracked_frames"] >= 3, "action": r.kind == demo.kind,
              "target": r.target == demo.target,
              "grasp": demo.kind != "transfer" or r.grasp == demo.grasp,
              "place": demo.kind != "transfer" or out["place_error_cm"] <= cfg.place_tolerance_m * 100}
    wrong = next((s for s in STAGES if not checks[s]), None)
    out["robot"], out["recognised_right"], out["task_success"] = None, wrong is None, False
    ran = robot and cfg.robot and r.kind is not None
    if ran:
        t0 = time.perf_counter()
        oriented = cfg.robot_orientation == "recognised" and r.grasp_frame >= 0
        seen_from = view_rotation(cfg, rec, tracked.hand_rc[r.grasp_frame]) if oriented else None
        res = robot_task(cfg, demo, r, models.phmms, render=render_robot, camera_rot=seen_from)
        times["robot_s"] = time.perf_counter() - t0
        out["robot"], out["task_success"] = res, task_done(cfg, demo, r, res)
    failed = wrong  # a failed task: the first recognition stage that went wrong, else the robot's stage
    if out["task_success"]:
        failed = None
    elif failed is None and ran:
        failed = f"robot_{out['robot'].failed_stage or 'outcome'}"
    out["failed_stage"], out["times"] = failed, times
    return out


def task_done(cfg: Config, demo: Demo, r: im.Recognised, res: sim.TaskResult) -> bool:
    """The task success: the demonstrated object (the robot handles the recognised one) ended
    within `cfg.place_tolerance_m` of the demonstrated place (the hand-over spot for pointing), upright
    and released; whatever grasp class the robot used."""
    off = np.linalg.norm(np.asarray(res.object_pos, float)[:2] - np.asarray(demo.place_xy, float))
    return bool(r.target == demo.target and res.upright and res.released and off <= cfg.place_tolerance_m)


def summarise(results: list[dict], robot_ran: bool) -> dict:
    """metrics over the demonstrations (module docstring of `experiments.imitation`)."""
    n = len(results)
    mean = lambda xs: float(np.mean(xs)) if len(xs) else float("nan")  # noqa: E731
    transfers = [r for r in results if r["kind"] == "transfer"]
    errs = [r["target_error_cm"] for r in results if np.isfinite(r["target_error_cm"])]
    failures: dict[str, int] = {}
    for r in results:
        if r["failed_stage"] is not None:
            failures[r["failed_stage"]] = failures.get(r["failed_stage"], 0) + 1
    robot = [r["robot"] for r in results if r["robot"] is not None]
    times = {}
    for r in results:
        for k, v in r["times"].items():
            times[k] = times.get(k, 0.0) + v
    place = [r["place_error_cm"] for r in transfers if np.isfinite(r["place_error_cm"])]
    return {
        "n_demonstrations": n, "n_point": n - len(transfers), "n_transfer": len(transfers),
        "action_accuracy": mean([r["kind_recognised"] == r["kind"] for r in results]),
        "action_accuracy_phmm": mean([r["recognised"].kind_phmm == r["kind"] for r in results]),
        "target_accuracy": mean([r["target_recognised"] == r["target"] for r in results]),
        "target_accuracy_phmm": mean([r["recognised"].target_phmm == r["target"] for r in results]),
        "target_error_cm": float(np.median(errs)) if errs else float("nan"),
        "target_error_cm_mean": mean(errs),
        "grasp_accuracy": mean([r["grasp_recognised"] == r["grasp"] for r in transfers]),
        "grasp_found_rate": mean([r["grasp_recognised"] != -1 for r in transfers
                                  if r["kind_recognised"] == "transfer"]),
        "place_error_cm": float(np.median(place)) if place else float("nan"),
        "pickup_error_frames_mean_abs": mean([abs(r["pickup_error_frames"]) for r in transfers
                                              if np.isfinite(r["pickup_error_frames"])]),
        "putdown_error_frames_mean_abs": mean([abs(r["putdown_error_frames"]) for r in transfers
                                               if np.isfinite(r["putdown_error_frames"])]),
        "place_from_scene_rate": mean([r["recognised"].place_from == "scene" for r in transfers
                                       if r["kind_recognised"] == "transfer"]),
        "recognition_success_rate": mean([r["recognised_right"] for r in results]),
        "task_success_rate": mean([r["task_success"] for r in results]) if robot_ran else None,
        "task_success_all_recognised_rate": mean([r["recognised_right"] and r["task_success"] for r in results])
        if robot_ran else None,
        # the arm has no collision-aware path: how often it pushed another object aside
        "others_disturbed_rate": mean([x.others_moved_m > DISTURBED_M for x in robot]),
        "task_success_undisturbed_rate": mean([r["task_success"] and r["robot"].others_moved_m <= DISTURBED_M
                                               for r in results]) if robot_ran else None,
        "robot_ran": bool(robot) and robot_ran, "robot_success_rate": mean([bool(x.success) for x in robot]),
        "failures_by_stage": failures,
        "stage_time_s": {k: v / max(n, 1) for k, v in times.items()},
    }


def main(argv=None) -> dict:
    from experiments.imitation.report import report, side_by_side, video_name

    cfg, run = parse_config(Config, PRESETS, name="imitation", argv=argv)
    sim.setup_rendering()
    enable_compilation_cache()
    start = time.perf_counter()
    settings = cfg.video_settings()
    models, val_metrics, prep_times = prepare(cfg, settings)
    robot_ran = cfg.robot
    demos = draw_demos(cfg.n_demos, cfg.seed, cfg.demonstrators, cfg.handover_xy)
    results = []
    for i, demo in enumerate(progress(demos, desc="demonstrations")):
        results.append(run_demo(cfg, settings, models, demo, render_robot=robot_ran and i < cfg.n_videos))
        r = results[-1]
        if i >= cfg.n_videos:  # only the first recordings are drawn (side_by_side): 50 paper ones filled 9 GB
            r.pop("rec")
        print(f"demo {i}: {demo.kind} object {demo.target} grasp {demo.grasp} -> {r['kind_recognised']} object "
              f"{r['target_recognised']} grasp {r['grasp_recognised']} ({r['target_error_cm']:.1f} cm); "
              f"failed: {r['failed_stage']}", flush=True)
    runtime = time.perf_counter() - start
    metrics = summarise(results, robot_ran)
    metrics.update(val_metrics)
    metrics["prepare_time_s"] = prep_times
    metrics["runtime_s"] = runtime
    paths = [side_by_side(run.file(video_name(i)), demos[i], results[i], settings)
             for i in range(min(cfg.n_videos, len(demos)))]
    metrics["video"], metrics["videos"] = paths[0].name, [p.name for p in paths]
    run.write(metrics, report(cfg, settings, demos, results, metrics), flat=False)
    print(f"wrote {run.path}/ in {runtime:.0f} s")
    return metrics
