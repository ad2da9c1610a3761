"""Demo stage "grasp" of `experiments.demo`: the quick grasp recognition run and the robot preshapes."""
from __future__ import annotations

import dataclasses

from experiments.config import StageResult, markdown_table
from experiments.grasp_recognition.config import PRESETS, Config
from experiments.grasp_recognition.stages import run_experiment
from sim.grasping import GRASP_NAMES, robot_grasp_for


def demo_stage(cfg) -> StageResult:
    """Demo stage: the `quick` evaluation (seeded by the demo's seed; its figures under
    `grasp_recognition/`), and the robot preshape each completed test grasp maps to (GRASP Fig. 2, MAP Fig. 2)."""
    config = dataclasses.replace(Config(**PRESETS["quick"]), seed=cfg.seed)
    result, nested = run_experiment(config)
    m = result.metrics
    rows = []
    for true, got, stage in zip(nested["true_class_X"], nested["recognised_class_X"], nested["stage_X"]):
        if stage == 2:
            robot = lambda g, hand, mp="map2009": robot_grasp_for(g, hand, mp) if g > 0 else "-"
            rows.append((f"{true} {GRASP_NAMES[true]}", f"{got} {GRASP_NAMES.get(got, 'no hand')}",
                         robot(got, "barrett"), robot(got, "karlsruhe"), robot(got, "barrett", "iros2008")))
    keys = ("accuracy_X", "accuracy_Xp", "accuracy_Xpp", "accuracy_large", "orientation_geodesic_error_deg_X",
            "lsh_recall_at_k", "query_ms")
    section = (f"Grasp recognition (quick: {m['n_database_views']} database views): accuracy X / X' / X'' = "
               f"{100 * m['accuracy_X']:.0f} / {100 * m['accuracy_Xp']:.0f} / {100 * m['accuracy_Xpp']:.0f} % "
               f"(paper 61 / 71 / 75 %), large set {100 * m['accuracy_large']:.0f} %. Completed grasps of X and "
               "the robot preshape the recognised grasp maps to:\n\n"
               + markdown_table(("true", "recognised", "Barrett (MAP)", "Karlsruhe (MAP)", "Barrett (GRASP)"), rows))
    return StageResult({f"grasp_{k}": m[k] for k in keys},
                       {f"grasp_recognition/{name}": fig for name, fig in result.figures.items()}, section)
