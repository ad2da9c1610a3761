"""The imitation loop's report.md and its side-by-side video (the person | the robot)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from experiments.config import markdown_table
from experiments.data import video
from experiments.imitation.demonstrations import AREA_X, AREA_Y, Demo


def _fmt(v) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return "nan" if not np.isfinite(v) else f"{v:.3g}"
    return str(v)


def report(cfg, settings, demos: list[Demo], results: list[dict], metrics: dict) -> str:
    """report.md: the loop's figures beside the papers' (where they have one), the failures by stage,
    the validation choices and every demonstration."""
    lines = [
        "# Imitation: from a demonstration video to the robot", "",
        f"{metrics['n_demonstrations']} demonstrations ({metrics['n_point']} pointing, {metrics['n_transfer']} "
        f"pick-and-place) at {settings.width} x {settings.height}, {settings.fps:g} fps; "
        f"persons 0-{cfg.demonstrators - 1} "
        f"demonstrate, the skin models come from the others' clips; run time {metrics['runtime_s']:.0f} s.", "",
        markdown_table(["measure", "ours", "papers"], [
            ["action accuracy (point vs pick; a pointing is a pick where the video shows an object moved)",
             _fmt(metrics["action_accuracy"]), "PHMM 93-94 % (BMVC Table, mocap)"],
            ["action accuracy from the PHMMs alone", _fmt(metrics["action_accuracy_phmm"]), "—"],
            ["target object (the PHMMs' nearest; in a transfer the object the video shows moved, where it "
             "decides)", _fmt(metrics["target_accuracy"]), "—"],
            ["target object from the PHMMs alone", _fmt(metrics["target_accuracy_phmm"]), "—"],
            ["target error (median, cm)", _fmt(metrics["target_error_cm"]), "PHMM ≈ 2 cm (mocap)"],
            ["grasp class accuracy (transfers; a missed transfer counts wrong)", _fmt(metrics["grasp_accuracy"]),
             "GRASP 61-75 % (single images)"],
            ["place error (median, cm)", _fmt(metrics["place_error_cm"]), "—"],
            ["places read from the object in the video (else from the hand)", _fmt(metrics["place_from_scene_rate"]),
             "—"],
            ["pick-up / put-down error (mean abs, frames)",
             f"{_fmt(metrics['pickup_error_frames_mean_abs'])} / {_fmt(metrics['putdown_error_frames_mean_abs'])}",
             "LfD 1.2 / 3.4 frames (25 fps)"],
            ["recognition all right", _fmt(metrics["recognition_success_rate"]), "—"],
            ["task success (the demonstrated object within 5 cm of the demonstrated place, upright)",
             _fmt(metrics["task_success_rate"]), "—"],
            ["task success with everything recognised right", _fmt(metrics["task_success_all_recognised_rate"]), "—"],
            ["task success with no other object pushed more than 5 cm", _fmt(metrics["task_success_undisturbed_rate"]),
             "—"],
            ["robot runs that pushed another object more than 5 cm (no collision-aware path)",
             _fmt(metrics["others_disturbed_rate"]), "—"],
        ]), "",
        "## Failures by the stage that caused them", "",
        "The first stage in the loop's order (tracking, action, target, grasp, place, then the robot's stages) "
        "that went wrong in each failed task (a task done with a wrongly recognised grasp class is not a failure).",
        "",
        markdown_table(["stage", "demonstrations"], sorted(metrics["failures_by_stage"].items())) or "none", "",
        "## Settings chosen on validation demonstrations", "",
        f"{metrics['validation_demonstrations']} demonstrations of seed {cfg.seed} + 1000: the tracker's offset from "
        f"the kinematic features {np.round(metrics['validation_offset_m'], 3).tolist()} m, observation noise "
        f"{metrics['chosen_sigma_m']:g} m, movement threshold {metrics['chosen_threshold_m']:g} m "
        f"(scores: right actions + right targets {metrics['validation_scores']}).", "",
        "## Stage times (s per demonstration)", "",
        "Rendering and the front end's tracks are cached per demonstration (a rerun reads them); the first run of "
        "a demonstration pays both, and the first front-end call of a process its compilation.", "",
        markdown_table(["stage", "s"], [[k, f"{v:.2f}"] for k, v in metrics["stage_time_s"].items()]), "",
        "## Demonstrations", "",
        markdown_table(["#", "person", "kind", "recognised", "object", "recognised", "error cm", "grasp", "recognised",
                        "place error cm", "failed"],
                       [[i, d.person, d.kind, r["kind_recognised"], d.target, r["target_recognised"],
                         _fmt(r["target_error_cm"]), d.grasp, r["grasp_recognised"], _fmt(r["place_error_cm"]),
                         r["failed_stage"]] for i, (d, r) in enumerate(zip(demos, results))]),
    ]
    shown = zip(demos, results[:len(metrics["videos"])])
    videos = [[f"[{video_name(i)}]({video_name(i)})", i, d.kind,
               "done" if r["task_success"] else f"not done ({r['failed_stage']})"] for i, (d, r) in enumerate(shown)]
    lines += ["", "## Side-by-side videos", "",
              "The first demonstrations, not chosen: the person's left view (the tracked hand circled) beside the "
              "robot (or, where no robot ran, a top view of what was recognised).", "",
              markdown_table(["video", "#", "kind", "task"], videos)]
    lines += ["", "## Notes", "",
              ("- Grasp recognition runs on the hand crop of a foveal camera turned to the tracked hand at the "
               f"recognised grasp moment ({cfg.fovea_px} x {cfg.fovea_px} px over {cfg.fovea_fov_deg:g} degrees; "
               "`experiments.imitation.fovea`)." if cfg.fovea_px else
               "- Grasp recognition runs on the hand crop of the left view at the recognised grasp moment; at the "
               "quick preset's 160 x 120 the hand is about 10 pixels wide, so the grasp class is close to chance "
               "there."),
              ("- The hand orientation eq. 4 recognises (the study's database) is turned from the view it was "
               "recognised in into the world (`lfd_jax.imitation.hand_rotation`); the robot imitates its turn about "
               "the vertical." if cfg.robot_orientation == "recognised" and cfg.grasp_database == "study" else
               "- The robot's hand takes the grasp's canonical orientation (`robot_orientation: canonical`; the "
               "demonstrations' crops carry no orientation, the study's database gives one by eq. 4)."),
              "- The robot's approach follows the reach PHMM's synthesised movement to the recognised object "
              "(`approach: phmm`) or the controller's straight line (`approach: straight`).",
              "- Robot scene objects stand in for the video's binoculars, cup and pitcher "
              "(`sim.manipulator.DEFAULT_OBJECTS`); in a transfer the handled one is the object of the demonstrated "
              "grasp class.",
              "- Merging the detector's events before the final recognition was designed while looking at the quick "
              "preset's evaluation demonstrations (4 of them); its settings are not tuned on them."]
    if not metrics.get("robot_ran"):
        lines += ["", "The robot step did not run (`robot: false`); `task_success_rate` is null."]
    return "\n".join(lines)


def _table_view(demo: Demo, result: dict, size: tuple[int, int]) -> np.ndarray:
    """A top view of the table (H, W, 3): the objects (grey), the demonstrated object (green ring), the
    recognised target (red cross), the true and recognised places (green, red squares)."""
    h, w = size
    img = np.full((h, w, 3), (150, 110, 70), np.uint8)
    x0, x1, y0, y1 = AREA_X[0] - 0.1, AREA_X[1] + 0.1, AREA_Y[0] - 0.1, AREA_Y[1] + 0.1

    def px(xy):
        xy = np.asarray(xy, float)
        return (int(round((x1 - xy[0]) / (x1 - x0) * (w - 1))), int(round((xy[1] - y0) / (y1 - y0) * (h - 1))))

    for k, xy in enumerate(demo.objects_xy):
        cv2.circle(img, px(xy), max(2, w // 40), (200, 200, 200), -1)
    cv2.circle(img, px(demo.objects_xy[demo.target]), max(4, w // 25), (0, 200, 0), 1)
    r = result["recognised"]
    if np.isfinite(r.target_xy).all():
        cv2.drawMarker(img, px(r.target_xy), (230, 0, 0), cv2.MARKER_CROSS, max(6, w // 20), 1)
    if demo.kind == "transfer":
        cv2.rectangle(img, np.subtract(px(demo.place_xy), 3), np.add(px(demo.place_xy), 3), (0, 200, 0), 1)
    if np.isfinite(r.place_xy).all():
        cv2.rectangle(img, np.subtract(px(r.place_xy), 2), np.add(px(r.place_xy), 2), (230, 0, 0), -1)
    return img


def video_name(i: int) -> str:
    """The side-by-side video of the i-th demonstration (the first keeps its former name)."""
    return "side_by_side.mp4" if i == 0 else f"side_by_side_{i}.mp4"


def side_by_side(path, demo: Demo, result: dict, settings) -> Path:
    """The person (left view, the tracked hand marked) beside the robot's frames (the controller's
    render), or, without a robot run, beside a top view of what the loop recognised."""
    rec = result["rec"]
    tracked = result["tracked"]
    person = rec.left.copy()
    for t in np.flatnonzero(tracked.found):
        r, c = np.rint(tracked.hand_rc[t]).astype(int)
        cv2.circle(person[t], (int(c), int(r)), 3, (255, 255, 0), 1)
    h, w = person.shape[1:3]
    robot = result.get("robot")
    frames = getattr(robot, "frames", None) if robot is not None else None
    if frames is not None and len(frames):
        frames = np.asarray(frames, np.uint8)
        idx = np.linspace(0, len(frames) - 1, len(person)).round().astype(int)
        right = np.stack([cv2.resize(frames[i], (int(round(frames.shape[2] * h / frames.shape[1])), h)) for i in idx])
    else:
        right = np.repeat(_table_view(demo, result, (h, w))[None], len(person), 0)
    return video.write_video(np.concatenate([person, right], axis=2), Path(path), fps=settings.fps)
