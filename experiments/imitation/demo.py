"""Demo stage "imitation" of `experiments.demo`: one demonstration through the whole loop (the
quick preset, one evaluated demonstration): the rendered video, the stereo front end, the online PHMMs,
the grasp recogniser, the robot's task, and the side-by-side video (the person | the robot)."""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from experiments.config import StageResult, markdown_table
from experiments.imitation.config import PRESETS, Config
from experiments.imitation.demonstrations import draw_demos
from experiments.imitation.report import side_by_side
from experiments.imitation.stages import prepare, run_demo

VIDEO = "imitation_demo.mp4"


def demo_config(seed: int) -> Config:
    """The quick preset with one evaluated demonstration."""
    return dataclasses.replace(Config(**PRESETS["quick"]), seed=seed, n_demos=1)


def demo_stage(cfg) -> StageResult:
    """`make demo` stage: the quick preset's models (skin, grasp database, PHMMs, validation choices),
    then the first demonstration of seed `cfg.seed` through the loop with the robot rendered; the
    side-by-side video is `imitation_demo.mp4` (a GIF where OpenCV cannot write MP4).

    cfg: the demo's config (only `cfg.seed` is used)."""
    start = time.perf_counter()
    icfg = demo_config(int(cfg.seed))
    settings = icfg.video_settings()
    models, _, _ = prepare(icfg, settings)
    demo = draw_demos(1, icfg.seed, icfg.demonstrators, icfg.handover_xy)[0]
    result = run_demo(icfg, settings, models, demo, render_robot=True)
    robot = result["robot"]
    rows = [("action", demo.kind, result["kind_recognised"]),
            ("object", demo.target, result["target_recognised"]),
            ("grasp class", demo.grasp if demo.kind == "transfer" else "-", result["grasp_recognised"]),
            ("target position error (cm)", "", result["target_error_cm"]),
            ("place error (cm)", "", result["place_error_cm"]),
            ("robot", "", "did not run" if robot is None else
             ("success" if robot.success else f"failed at {robot.failed_stage}")),
            ("task (the demonstrated object within 5 cm of the demonstrated place, upright)", "",
             "done" if result["task_success"] else "not done"),
            ("first failing stage", "", result["failed_stage"] or "none")]
    elapsed = time.perf_counter() - start
    metrics = {"imitation_demo_kind": demo.kind, "imitation_demo_kind_recognised": result["kind_recognised"],
               "imitation_demo_target_correct": bool(result["target_recognised"] == demo.target),
               "imitation_demo_target_error_cm": result["target_error_cm"],
               "imitation_demo_robot_success": None if robot is None else bool(robot.success),
               "imitation_demo_task_success": bool(result["task_success"]),
               "imitation_demo_failed_stage": result["failed_stage"] or "",
               "imitation_demo_stage_time_s": result["times"], "imitation_demo_s": elapsed}
    report = "\n".join([
        "## Stage imitation: one demonstration, from video to the robot", "",
        f"A {demo.kind} demonstration (person {demo.person}, {len(np.asarray(demo.objects_xy))} objects) rendered at "
        f"{settings.width} x {settings.height}, {settings.fps:g} fps, through the video front end, the online PHMMs "
        "(BMVC 2008 §5.4), the grasp recogniser (GRASP §III) and the robot's task (MAP §III), with the models of "
        "`experiments.imitation`'s quick preset. The left view of the person beside the robot: "
        f"[{VIDEO}]({VIDEO}) (a GIF of the same name where OpenCV cannot write MP4).", "",
        markdown_table(["", "demonstrated", "recognised / done"], rows), "",
        f"Time: {elapsed:.0f} s (models included)."])
    return StageResult(metrics, {}, report,
                       files={VIDEO: lambda path: side_by_side(path, demo, result, settings)})
