"""Demo stage "mapping" of `experiments.demo`: one human grasp class executed by both robot hands."""
from __future__ import annotations

import time

import numpy as np

from experiments.config import StageResult, markdown_table
from sim.grasping import GRASP_CLASSES, GRASP_NAMES, robot_grasp_for
from sim.grasping import rollout_grasps
from sim.grasping import plan_trials
from sim.scenes import render_frame
from sim.hands import HAND_NAMES, grasp_model


def grasp_demo_stage(cfg, grasp: int | None = None) -> StageResult:
    """Demo stage: map one (recognised) human grasp class to both robot hands and execute it on `native`.

    `cfg` is the demo's config (its `seed` picks the class when `grasp` is None); figure `grasp_demo.png`
    (Barrett left, Karlsruhe right, at the end of the 1 s hold).
    """
    grasp = GRASP_CLASSES[cfg.seed % len(GRASP_CLASSES)] if grasp is None else int(grasp)
    start = time.perf_counter()
    metrics, tiles, rows = {"grasp_demo_class": grasp}, [], []
    for hand in HAND_NAMES:
        params, object_start = plan_trials(hand, [grasp], np.zeros((1, 2)), np.zeros(1), np.ones(1, bool),
                                           [cfg.seed])
        out = rollout_grasps(hand, params, object_start, backend="native")
        robot = robot_grasp_for(grasp, hand)
        metrics[f"grasp_demo_lifted_{hand}"] = bool(out.lifted[0])
        metrics[f"grasp_demo_lift_m_{hand}"] = float(out.lift_m[0])
        tiles.append(render_frame(grasp_model(hand)[0], out.qpos[0], 320, 240, camera="front"))
        rows.append((hand, robot, "yes" if out.lifted[0] else "no", float(out.lift_m[0]),
                     int(out.n_corrections[0])))
    metrics["grasp_demo_s"] = time.perf_counter() - start
    report = "\n".join([
        f"## Stage grasp: human grasp {grasp} ({GRASP_NAMES[grasp]}) executed by two robot hands", "",
        "Preshape and hand orientation from the human reference grasp (MAP §III), MuJoCo `mujoco.batch`, "
        "lift 10 cm and hold 1 s.", "",
        markdown_table(["hand", "robot grasp", "lifted", "lift (m)", "tactile corrections"], rows), "",
        "![grasp demo](grasp_demo.png)"])
    return StageResult(metrics, {"grasp_demo.png": np.concatenate(tiles, 1)}, report)
