"""Figures of the OAC study: hand trajectories per class (LfD Fig. 7), rendered views, error bars."""
from __future__ import annotations

import numpy as np

from experiments.data import oac
from experiments.data.oac_protocol import PAPER_TABLE2, PAPER_TABLE3
from experiments.oac_recognition.config import Config
from experiments.plotting import plt


def plot_trajectories(data: oac.OACData):
    """Hand position relative to the face per class, 2-D image and 3-D stereo (like LfD Fig. 7)."""
    colors = ("tab:blue", "tab:orange", "tab:green")
    fig = plt.figure(figsize=(12, 5))
    ax2 = fig.add_subplot(1, 2, 1)
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    grid = np.linspace(0, 1, 50)
    for c in range(oac.N_CLASSES):
        rows = np.flatnonzero(data.action == c)
        means2, means3 = [], []
        for i in rows:
            L = data.lengths[i]
            p2, p3 = data.pos2d[i, :L], data.pos3d[i, :L]
            ax2.plot(p2[:, 0], p2[:, 1], ":", color=colors[c], lw=0.6, alpha=0.6)
            ax3.plot(p3[:, 0], p3[:, 2], -p3[:, 1], ":", color=colors[c], lw=0.6, alpha=0.5)
            s = np.linspace(0, 1, L)
            means2.append(np.stack([np.interp(grid, s, p2[:, k]) for k in range(2)], -1))
            means3.append(np.stack([np.interp(grid, s, p3[:, k]) for k in range(3)], -1))
        m2, m3 = np.mean(means2, 0), np.mean(means3, 0)
        ax2.plot(m2[:, 0], m2[:, 1], "-", color=colors[c], lw=2.5, label=oac.CLASSES[c])
        ax3.plot(m3[:, 0], m3[:, 2], -m3[:, 1], "-", color=colors[c], lw=2.5, label=oac.CLASSES[c])
    ax2.invert_yaxis()
    ax2.set_xlabel("x (px, image right)")
    ax2.set_ylabel("y (px, image down)")
    ax2.set_title("a) 2-D hand position relative to the face")
    ax2.legend(fontsize=8)
    ax2.set_aspect("equal")
    ax3.set_xlabel("x (m)")
    ax3.set_ylabel("depth (m, from the camera)")
    ax3.set_zlabel("up (m)")
    ax3.set_title("b) 3-D (stereo) hand position relative to the face")
    return fig


def plot_views(cfg: Config, n_cols: int = 8):
    """Hand and object views over one recording per class (person 0, repetition 0)."""
    fig, axes = plt.subplots(2 * oac.N_CLASSES, n_cols, figsize=(1.3 * n_cols, 1.4 * 2 * oac.N_CLASSES))
    for c in range(oac.N_CLASSES):
        rec = oac.recording_images(cfg.data_settings(), c, 0, 0)
        frames = np.linspace(0, rec["n"] - 1, n_cols).round().astype(int)
        for j, t in enumerate(frames):
            axes[2 * c, j].imshow(rec["hand_img"][t], cmap="gray", vmin=0, vmax=1)
            axes[2 * c + 1, j].imshow(rec["obj_img"][t], cmap="gray", vmin=0, vmax=1)
            axes[2 * c, j].set_title(f"t={t}", fontsize=7)
        axes[2 * c, 0].set_ylabel(f"{oac.OBJECTS[c]}\nhand", fontsize=7)
        axes[2 * c + 1, 0].set_ylabel("object", fontsize=7)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle("segmented hand views and square-normalised object windows (person 0)", fontsize=9)
    return fig


def plot_errors(t: dict):
    """Bars: our median error (max as whisker) beside the paper's, for Tables 2 and 3."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.8), sharey=True)
    for ax, tgt in zip(axes, ("actions", "objects")):
        items = [(m, t["table2"][tgt][m], PAPER_TABLE2[tgt][m]) for m in t["table2"][tgt]]
        items += [(m, t["table3"][tgt][m], PAPER_TABLE3[tgt][m]) for m in ("chcrf", "fcrf")]
        x = np.arange(len(items))
        med = [o["median"] for _, o, _ in items]
        mx = [o["max"] - o["median"] for _, o, _ in items]
        ax.bar(x - 0.2, med, 0.4, yerr=[np.zeros(len(x)), mx], label="ours (median, max)", capsize=2)
        ax.bar(x + 0.2, [p[0] for _, _, p in items], 0.4, label="paper (median)")
        ax.set_xticks(x, [m for m, _, _ in items], rotation=30, fontsize=8)
        ax.set_title(tgt)
        ax.set_ylabel("error %")
        ax.legend(fontsize=8)
    return fig
