"""Demo stage "imitation" of `experiments.demo`: the first demonstrations of the demo's seed (not chosen
by outcome) through the whole loop with the quick preset's models: the rendered video, the stereo front end,
the online PHMMs, the grasp recogniser, the robot's task, and one side-by-side video (the person | the
robot) per demonstration."""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from experiments.config import StageResult, markdown_table
from experiments.imitation.config import PRESETS, Config
from experiments.imitation.demonstrations import draw_demos
from experiments.imitation.report import side_by_side
from experiments.imitation.stages import prepare, run_demo

N_DEMOS = 3


def video_name(k: int) -> str:
    """The side-by-side video of demonstration k (0-based)."""
    return f"imitation_demo_{k + 1}.mp4"


def demo_config(seed: int) -> Config:
    """The quick preset with `N_DEMOS` evaluated demonstrations."""
    return dataclasses.replace(Config(**PRESETS["quick"]), seed=seed, n_demos=N_DEMOS)


def _outcome(result: dict) -> str:
    robot = result["robot"]
    return "did not run" if robot is None else ("success" if robot.success else f"failed at {robot.failed_stage}")


def _cm(value: float) -> str:
    return "-" if np.isnan(value) else f"{value:.1f}"


def demo_stage(cfg) -> StageResult:
    """`make demo` stage: the quick preset's models (skin, grasp database, PHMMs, validation choices),
    then the first `N_DEMOS` demonstrations of seed `cfg.seed` through the loop with the robot rendered;
    the side-by-side videos are `imitation_demo_<k>.mp4` (GIFs of the same names where OpenCV cannot write
    MP4).

    cfg: the demo's config (only `cfg.seed` is used)."""
    start = time.perf_counter()
    icfg = demo_config(int(cfg.seed))
    settings = icfg.video_settings()
    models, _, _ = prepare(icfg, settings)
    demos = draw_demos(icfg.n_demos, icfg.seed, icfg.demonstrators, icfg.handover_xy)
    results = []
    for k, demo in enumerate(demos):
        print(f"  demonstration {k + 1} of {len(demos)}: {demo.kind}", flush=True)
        results.append(run_demo(icfg, settings, models, demo, render_robot=True))
    rows = []
    for k, (demo, result) in enumerate(zip(demos, results)):
        transfer = demo.kind == "transfer"
        rows.append((k + 1, demo.kind, result["kind_recognised"], f"{demo.target} / {result['target_recognised']}",
                     f"{demo.grasp} / {result['grasp_recognised']}" if transfer else "-",
                     _cm(result["target_error_cm"]), _cm(result["place_error_cm"]), _outcome(result),
                     "done" if result["task_success"] else "not done", result["failed_stage"] or "none",
                     f"[video]({video_name(k)})"))
    elapsed = time.perf_counter() - start
    done = [bool(r["task_success"]) for r in results]
    metrics = {"imitation_demo_kinds": [d.kind for d in demos],
               "imitation_demo_kinds_recognised": [r["kind_recognised"] for r in results],
               "imitation_demo_target_correct": [bool(r["target_recognised"] == d.target) for d, r in zip(demos, results)],
               "imitation_demo_robot_success": [None if r["robot"] is None else bool(r["robot"].success) for r in results],
               "imitation_demo_task_success": done,
               "imitation_demo_tasks_done": int(sum(done)),
               "imitation_demo_failed_stages": [r["failed_stage"] or "" for r in results],
               "imitation_demo_stage_time_s": {f"demo_{k + 1}_{name}": t for k, r in enumerate(results)
                                                for name, t in r["times"].items()}, "imitation_demo_s": elapsed}
    report = "\n".join([
        f"## Stage imitation: the first {len(demos)} demonstrations of seed {icfg.seed}, from video to the robot", "",
        f"Each demonstration (a person pointing at an object or moving one, {settings.width} x {settings.height}, "
        f"{settings.fps:g} fps) goes through the video front end, the online PHMMs (BMVC 2008 §5.4), the grasp "
        "recogniser (GRASP §III) and the robot's task (MAP §III), with the models of `experiments.imitation`'s "
        "quick preset. The task is done when the demonstrated object ends within 5 cm of the demonstrated place "
        "(the hand-over spot for a pointing), upright and released. Object and grasp: demonstrated / recognised. "
        "Each video shows the left view of the person beside the robot (a GIF of the same name where OpenCV "
        "cannot write MP4).", "",
        markdown_table(["demo", "action", "recognised", "object", "grasp class", "target error (cm)",
                        "place error (cm)", "robot", "task", "first failing stage", "video"], rows), "",
        f"Tasks done: {sum(done)} of {len(demos)}. Time: {elapsed:.0f} s (models included)."])
    files = {video_name(k): (lambda path, d=demo, r=result: side_by_side(path, d, r, settings))
             for k, (demo, result) in enumerate(zip(demos, results))}
    return StageResult(metrics, {}, report, files=files)
