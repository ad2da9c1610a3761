"""Figures of the grasp mapping study: Fig. 4 (VF errors), success rates, rendered frames."""
from __future__ import annotations

import numpy as np

from experiments.grasp_mapping.config import Config, conditions
from experiments.grasp_mapping.trials import finite_mean
from experiments.plotting import plt
from sim.grasping import GRASP_NAMES, VOLAR_GRASPS
from sim.scenes import render_frame
from sim.hands import grasp_model


def plot_fig4(cfg: Config, results: dict[str, dict]):
    """Fig. 4 style: VF position and orientation error per grasp, per condition group, both hands."""
    groups = ["none", "pos"] + [f"rot_{t:g}deg" for t in cfg.tilts_deg]
    conds = conditions(cfg)
    fig, axes = plt.subplots(2, len(groups), figsize=(3.2 * len(groups), 6), sharey="row")
    x = np.arange(len(cfg.grasps))
    for col, group in enumerate(groups):
        for row, (key, unit) in enumerate([("pos_err", "position error (mm)"), ("ang_err", "orientation error (deg)")]):
            ax = axes[row, col]
            for i, (hand, r) in enumerate(results.items()):
                names = np.array([conds[k].name if group != "pos" else conds[k].kind for k in r["cond"]])
                vals = [finite_mean(r[key][(names == group) & (r["grasp"] == g) & r["tactile"]]) for g in cfg.grasps]
                ax.bar(x + (i - 0.5) * 0.4, vals, 0.4, color=["black", "white"][i % 2], edgecolor="black", label=hand)
            ax.set_xticks(x, [str(g) for g in cfg.grasps])
            if row == 0:
                ax.set_title({"none": "no error", "pos": f"position {100 * cfg.offset_m:g} cm"}.get(group, group))
            if col == 0:
                ax.set_ylabel(unit)
            if row == 1:
                ax.set_xlabel("human grasp class")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Virtual-finger error, robot vs human grasp (tactile correction on for volar grasps 1, 2)")
    return fig


def plot_success(cfg: Config, tables: dict):
    """Success rate per grasp and condition, one heat map per hand."""
    hands = list(tables["success"])
    fig, axes = plt.subplots(1, len(hands), figsize=(7 * len(hands), 3.8), squeeze=False)
    labels = [c.name for c in conditions(cfg)]
    for ax, hand in zip(axes[0], hands):
        rows, names = [], []
        for g in cfg.grasps:
            table = tables["success"][hand][GRASP_NAMES[g]]
            rows.append([table[c] for c in labels])
            names.append(f"{g} {GRASP_NAMES[g]}")
            if g in VOLAR_GRASPS:
                rows.append([table[c + "_no_tactile"] for c in labels])
                names.append(f"{g} (no tactile)")
        im = ax.imshow(np.array(rows), vmin=0, vmax=1, cmap="viridis", aspect="auto")
        ax.set_xticks(range(len(labels)), labels, rotation=60, fontsize=7)
        ax.set_yticks(range(len(names)), names, fontsize=7)
        ax.set_title(f"{hand}: lifted 10 cm and held 1 s")
        for (i, j), v in np.ndenumerate(np.array(rows)):
            ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=6, color="w" if v < 0.5 else "k")
    fig.colorbar(im, ax=axes[0].tolist(), fraction=0.02)
    return fig


def render_frames(cfg: Config, results: dict[str, dict]) -> dict[str, np.ndarray]:
    """One frame per hand and grasp: the no-error trial with tactile correction, first seed, as
    `frame_<hand>_<grasp>.png`, and all of them tiled as `frames.png`."""
    frames, tiles = {}, []
    for hand, r in results.items():
        model, _ = grasp_model(hand)
        row = []
        for g in cfg.grasps:  # one frame per grasp class
            k = int(np.flatnonzero((r["grasp"] == g) & (r["cond"] == 0) & r["tactile"])[0])
            frame = render_frame(model, r["outcomes"].qpos[k], cfg.image_width, cfg.image_height, camera="front")
            frames[f"frame_{hand}_{g}.png"] = frame
            row.append(frame)
        tiles.append(np.concatenate(row, 1))
    return {**frames, "frames.png": np.concatenate(tiles, 0)}
