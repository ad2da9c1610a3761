"""Rendered to real, rung by rung: the scene convnet (cfg.classifier "scene_cnn") trained on rendered
scenes through one more realism step per rung (`lfd_jax.grasp.realistic_frames`, cumulative in the
order of `config.REALISM_STEPS`), each rung scored on the real hands of `gtea_grasps` (validation:
`real_grasps.evaluate_real_grasps`) and on the rendered test sets (the class from the network, X and
the large set; a frame without a hand found counts as wrong), all rungs at one training budget.

    python -m experiments.grasp_recognition.realism --preset best --backgrounds ../shared/data \\
        --n-scenes 1000 --n-scene-hands 20 --cnn-epochs 20 --n-random-views 0 --n-azimuth 30 --n-elevation 8 \\
        --out DIR

(a reduced training budget; the database only gives eq. 4's orientation and the 1-NN peer, not the
network's class, so a small one does).

The background step's patches are cut from real video that is no evaluation data
(`scene_realism.background_frames`).
Writes metrics.json (per rung) and report.md (the table).
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import jax
import numpy as np

import hog_jax
import sim
from experiments.config import parse_config
from experiments.data.grasp_tests import random_set, sequence_set, skin_training_pixels
from experiments.grasp_recognition.config import PRESETS, REALISM_STEPS, Config
from experiments.grasp_recognition.real_grasps import evaluate_real_grasps
from experiments.grasp_recognition.recogniser import recogniser_of, study_database
from lfd_common import enable_compilation_cache
from lfd_jax import fit_real_skin_model
from lfd_jax.grasp import net_labels, segment_frames


def rungs(steps: tuple[str, ...] = REALISM_STEPS) -> list[str]:
    """The rungs' `scene_realism` values: none, then one more step each."""
    return ["none"] + ["+".join(steps[:i + 1]) for i in range(len(steps))]


def rendered_accuracy(rec, tests: dict, seg: dict) -> dict:
    """{name: accuracy} of the recogniser's network's class on segmented rendered test sets."""
    return {name: float(np.mean(net_labels(rec, seg[name]) == t.labels)) for name, t in tests.items()}


def score_rung(cfg: Config, skin, real_skin, data: str | Path, tests: dict, seg: dict, db) -> dict:
    """One rung: the scene convnet of `cfg` (trained or from the cache) scored on gtea_grasps and on the
    segmented rendered test sets `seg` of `tests`."""
    key = jax.random.key(cfg.seed)
    t0 = time.perf_counter()
    rec = recogniser_of(cfg, key, db, None, skin)
    train_s = time.perf_counter() - t0
    real, _ = evaluate_real_grasps(rec, real_skin, data, cfg.crop_size)
    return {"rung": cfg.scene_realism, "background_share": cfg.background_share, "train_s": train_s,
            **{f"rendered_accuracy_{n}": v for n, v in rendered_accuracy(rec, tests, seg).items()},
            **{f"real_{k}": real["ours"][k] for k in ("balanced_accuracy", "exact_mean_recall", "coarse_accuracy",
                                                     "found")}}


def rung_inputs(cfg: Config, data: str | Path) -> tuple:
    """(skin model of the rendered scenes, skin model of real photos, rendered test sets, their
    segmentations, the database) every rung shares."""
    skin_px, bg_px = skin_training_pixels(cfg.seed, cfg.n_skin_images)
    skin = hog_jax.fit_skin_model(jax.random.fold_in(jax.random.key(cfg.seed), 1), skin_px, bg_px)
    tests = {"X": sequence_set(cfg.seed, cfg.frame_size), "large": random_set(cfg.n_large, cfg.seed, cfg.frame_size)}
    seg = {name: segment_frames(skin, t.frames, cfg.crop_size, adaptation=cfg.skin_adaptation)
           for name, t in tests.items()}
    return skin, fit_real_skin_model(data, seed=cfg.seed), tests, seg, study_database(cfg)


def run_rungs(cfg: Config, data: str | Path) -> list[dict]:
    """Every rung's scores (module docstring): gtea_grasps (validation) and the rendered test sets."""
    inputs = rung_inputs(cfg, data)
    out = []
    for steps in rungs():
        out.append(score_rung(dataclasses.replace(cfg, scene_realism=steps), inputs[0], inputs[1], data, *inputs[2:]))
        print(out[-1], flush=True)
    return out


def table(rows: list[dict]) -> str:
    """The rungs as a markdown table."""
    lines = ["| rung | background share | gtea balanced acc. | gtea exact recall | rendered X | rendered large | "
             "train s |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['rung']} | {r['background_share']:g} | {r['real_balanced_accuracy']:.3f} | "
              f"{r['real_exact_mean_recall']:.3f} | {r['rendered_accuracy_X']:.3f} | "
              f"{r['rendered_accuracy_large']:.3f} | {r['train_s']:.0f} |"
              for r in rows]
    return "\n".join(lines) + "\n"


def main(argv=None) -> list[dict]:
    cfg, run = parse_config(Config, PRESETS, "grasp_realism", argv, description=__doc__)
    if cfg.real_photos == "none" or cfg.backgrounds == "none":
        raise SystemExit("real_photos and backgrounds: the rungs need ../shared/data (or another folder) for both")
    sim.setup_rendering()
    enable_compilation_cache()
    rows = run_rungs(cfg, cfg.real_photos)
    metrics = {"rungs": [r["rung"] for r in rows],
               **{f"rung{i}_{k}": v for i, r in enumerate(rows) for k, v in r.items() if k != "rung"}}
    run.write(metrics, "# Rendered to real, rung by rung\n\n" + table(rows), {})
    print(table(rows))
    return rows


if __name__ == "__main__":
    main()
