"""Demo stage "phmm" of `experiments.demo`: recognise one pointing demonstration with 2x2 PHMMs and
reach for the pointed-at position with the robot arm."""
from __future__ import annotations

import time

import numpy as np

import phmm_jax as P
from experiments.config import StageResult
from experiments.data import tabletop as tt
from experiments.phmm_tabletop import measures as ms
from experiments.phmm_tabletop.config import PRESETS
from experiments.plotting import plt
from lfd_common import cache_dir


def _demo_models(seed: int, reps: int, n_iter: int):
    """2x2 PHMMs of both actions trained on the outer corners (cached on disk by their settings)."""
    folder = cache_dir("phmm_tabletop")
    # "_v2": the model file format that stores the structure without fit options; older files are not read.
    paths = [folder / f"demo_phmm_{a}_s{seed}_r{reps}_i{n_iter}_v2.npz" for a in tt.ACTIONS]
    train = tt.protocol_data(seed, (2, 2), reps, (2, 2), 1)[0]
    if all(p.exists() for p in paths):
        return [P.load(p) for p in paths], train
    X = tt.resample(train, 100)
    cfg = P.HMMConfig(n_states=20, min_duration=4, max_duration=6)
    models = [P.fit_phmm(list(X[train.action == a].reshape(4, reps, 100, -1)), (2, 2), cfg,
                         options=P.FitOptions(max_iter=n_iter))
              for a in range(len(tt.ACTIONS))]
    for model, path in zip(models, paths):
        P.save(path, model)
    return models, train


def demo_stage(cfg) -> StageResult:
    """Demo stage "phmm": one simulated pointing demonstration is recognised by 2x2 PHMMs (action and
    pointed-at table position); the robot arm then reaches for that position with a movement
    synthesised by the reaching PHMM, retargeted (eqs. 10-24) and played back in MuJoCo.
    Figure `phmm_demo.png`. `cfg` needs a `seed` field (the demo's DemoConfig)."""
    start = time.perf_counter()
    quick = PRESETS["quick"]  # the demo trains with the quick preset's settings, on the outer corners only
    models, train = _demo_models(0, quick["train_repetitions"], quick["n_iter"])
    rng = np.random.default_rng(cfg.seed)
    subject = tt.sample_subject(np.random.default_rng(0))  # the trained demonstrator
    target = tt.RASTER_ORIGIN + np.r_[rng.uniform(0.15, 0.85, 2) * tt.RASTER_SIZE_M, 0.0]
    demo = tt.stack_recordings([tt.simulate_movement(rng, subject, target, "pointing")],
                               [tt.ACTIONS.index("pointing")], target[None])
    rec = P.recognize(models, tt.resample(demo, 100), n_steps=20)
    label = int(rec.label[0])
    corners = tt.raster_targets(2, 2)
    estimate = ms.phi_to_position(corners, rec.phi[:, label])[0]
    reaching = tt.ACTIONS.index("reaching")
    setup = ms.RobotSetup(train, estimate[None])
    movement = np.asarray(P.synthesize(models[reaching], P.target_to_phi(corners, estimate)))
    angles, qpos, playbacks = setup.play(movement[None])
    grasp = playbacks[0].grasp
    closest = int(np.argmin(np.linalg.norm(grasp - setup.targets[0], axis=-1)))
    frame = ms.render_reach(setup, qpos[0, closest], 320, 240)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 3.6), gridspec_kw={"width_ratios": [1, 1.6]})
    hand = ms.hand_centre(demo.markers[0, :demo.lengths[0]])
    ax1.add_patch(plt.Rectangle(tt.RASTER_ORIGIN[:2], *tt.RASTER_SIZE_M, fill=False, ls=":", color="k"))
    ax1.plot(hand[:, 0], hand[:, 1], "b-", lw=1, label="demonstrator's hand")
    ax1.plot(*target[:2], "ko", label="pointed-at target")
    ax1.plot(*estimate[:2], "r+", ms=12, label="recognised target")
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (m)")
    ax1.set_ylabel("y (m)")
    ax1.legend(fontsize=7, loc="lower right")
    ax1.set_title(f"recognised: {tt.ACTIONS[label]} (log-lik. {rec.loglik[0, label]:.0f} vs "
                  f"{rec.loglik[0, 1 - label]:.0f})", fontsize=8)
    ax2.imshow(frame)
    ax2.axis("off")
    ax2.set_title("robot reaches for the recognised target (side, front)", fontsize=8)

    error_cm = float(np.linalg.norm(estimate[:2] - target[:2]) * 100)
    reach_cm = float(np.linalg.norm(grasp[closest] - setup.targets[0]) * 100)
    metrics = {
        "phmm_demo_action_recognised": tt.ACTIONS[label],
        "phmm_demo_action_correct": label == tt.ACTIONS.index("pointing"),
        "phmm_demo_target_error_cm": error_cm,
        "phmm_demo_robot_reach_error_cm": reach_cm,
        "phmm_demo_s": time.perf_counter() - start,
    }
    section = "\n".join([
        "## Stage phmm: recognise a pointing demonstration, reach for the target with the robot arm",
        "",
        f"Recognised action: **{tt.ACTIONS[label]}** (true: pointing); pointed-at position estimated "
        f"{error_cm:.1f} cm from the true target. The robot's grasp point comes within {reach_cm:.2f} cm "
        f"(robot scale) of the scaled estimate. Stage time {metrics['phmm_demo_s']:.1f} s.",
        "",
        "![phmm demo](phmm_demo.png)",
    ])
    return StageResult(metrics, {"phmm_demo.png": fig}, section)
