"""Figures of the grasp recognition study (GRASP Figs. 5, 7, 8, the sweeps, a contact sheet)."""
from __future__ import annotations

import numpy as np

from experiments.data.grasp_tests import STAGES
from experiments.grasp_recognition.config import Config
from experiments.plotting import plt
from sim.grasping import GRASP_CLASSES, GRASP_NAMES


def plot_confusions(mats: dict[str, np.ndarray], accs: dict[str, float]):
    fig, axes = plt.subplots(1, len(mats), figsize=(4.2 * len(mats), 4.2))
    ticks = [str(g) for g in GRASP_CLASSES]
    for ax, (name, c) in zip(np.atleast_1d(axes), mats.items()):
        rate = c / np.maximum(c.sum(1, keepdims=True), 1)
        ax.imshow(rate, cmap="gray", vmin=0, vmax=1)
        ax.set_xticks(range(len(ticks) + 1), ticks + ["none"])
        ax.set_yticks(range(len(ticks)), ticks)
        ax.set_xlabel("recognised")
        ax.set_ylabel("true")
        ax.set_title(f"{name}: {100 * accs[name]:.0f} % (n = {c.sum()})")
        for i in range(rate.shape[0]):
            for j in range(rate.shape[1]):
                if c[i, j]:
                    ax.text(j, i, str(c[i, j]), ha="center", va="center", color="red", fontsize=8)
    fig.suptitle("Confusion matrices (white = 100 %), like GRASP Fig. 7")
    return fig


def plot_orientation(errs: dict[str, np.ndarray], geo: dict[str, float]):
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    width = 0.8 / (len(errs) + 1)
    xs = np.arange(3)
    ax.bar(xs, [0.0, 16.8, 10.5], width, label="paper, X (angles as printed)", color="0.6")
    for i, (name, e) in enumerate(errs.items()):
        ax.bar(xs + (i + 1) * width, e, width, label=f"ours, {name} (geodesic {geo[name]:.1f}°)")
    ax.set_xticks(xs + width * len(errs) / 2, ["azimuth φ", "elevation θ", "roll ψ"])
    ax.set_ylabel("mean absolute error (deg)")
    ax.set_title("Orientation error, like GRASP Fig. 8")
    ax.legend(fontsize=8)
    return fig


def plot_neighbours(queries, db, idx, dist, true, labels, n_show: int = 7):
    n_show = min(n_show, idx.shape[1])
    fig, axes = plt.subplots(len(queries), n_show + 1, figsize=(1.6 * (n_show + 1), 1.9 * len(queries)))
    axes = np.atleast_2d(axes)
    for r, (img, q) in enumerate(queries):
        axes[r, 0].imshow(img, cmap="gray")
        axes[r, 0].set_title(f"query: {GRASP_CLASSES[true[q]]}\nrecognised {GRASP_CLASSES[labels[q]]}"
                             if labels[q] >= 0 else "query: no hand", fontsize=7)
        for c in range(n_show):
            ax = axes[r, c + 1]
            j = idx[q, c]
            if j >= 0:
                ax.imshow(db.images[j], cmap="gray")
                o = np.degrees(db.euler[j])
                ax.set_title(f"y={GRASP_CLASSES[db.labels[j]]} d={dist[q, c]:.2f}\n"
                             f"o=({o[0]:.0f},{o[1]:.0f},{o[2]:.0f})", fontsize=6)
        for ax in axes[r]:
            ax.axis("off")
    fig.suptitle("Nearest database views of test queries (class y, distance d, orientation o in deg), like Fig. 5",
                 fontsize=9)
    return fig


def plot_sweeps(sw: dict, cfg: Config):
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for name, accs in sw["k"].items():
        axes[0].plot(list(accs), list(accs.values()), "o-", label=name)
    axes[0].set_xscale("log")
    axes[0].set_xlabel("k")
    axes[0].set_ylabel("accuracy")
    axes[0].set_title("accuracy against k (exact kNN)")
    for name, accs in sw["db"].items():
        axes[1].plot(list(accs), list(accs.values()), "o-", label=name)
    axes[1].set_xscale("log")
    axes[1].set_xlabel("database views per grasp")
    axes[1].set_title("accuracy against database size")
    bl = sw["bl"]["large"]
    grid = np.array([[bl[(b, lv)] for lv in cfg.levels_sweep] for b in cfg.bins_sweep])
    im = axes[2].imshow(grid, cmap="viridis", vmin=0, vmax=1)
    axes[2].set_xticks(range(len(cfg.levels_sweep)), cfg.levels_sweep)
    axes[2].set_yticks(range(len(cfg.bins_sweep)), cfg.bins_sweep)
    axes[2].set_xlabel("levels L")
    axes[2].set_ylabel("bins B")
    axes[2].set_title("accuracy on the large set for B x L")
    for i in range(grid.shape[0]):
        for j in range(grid.shape[1]):
            axes[2].text(j, i, f"{grid[i, j]:.2f}", ha="center", va="center", color="w", fontsize=8)
    fig.colorbar(im, ax=axes[2])
    for ax in axes[:2]:
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return fig


def plot_contact_sheet(db, X, seg_images, per_view: int):
    """Per grasp: three database views, the three snapshots of its first test sequence and their
    segmented crops."""
    n_cols = 9
    fig, axes = plt.subplots(len(GRASP_CLASSES), n_cols, figsize=(1.5 * n_cols, 1.6 * len(GRASP_CLASSES)))
    for gi, g in enumerate(GRASP_CLASSES):
        views = gi * per_view + np.linspace(0, per_view - 1, 5).astype(int)[1:4]
        seq = np.flatnonzero(X.labels == gi)[:3]
        panels = ([(db.images[v], "gray", f"db {g}") for v in views] + [(X.frames[i], None, STAGES[X.stage[i]])
                                                                        for i in seq]
                  + [(seg_images[i], "gray", "segmented") for i in seq])
        for c, (img, cmap, title) in enumerate(panels):
            axes[gi, c].imshow(img, cmap=cmap, vmin=0 if cmap else None, vmax=1 if cmap else None)
            axes[gi, c].set_title(title, fontsize=6)
        for ax in axes[gi]:
            ax.axis("off")
        axes[gi, 0].text(-0.3, 0.5, f"{g}\n{GRASP_NAMES[g]}", transform=axes[gi, 0].transAxes, ha="right",
                         va="center", fontsize=7)
    fig.suptitle("Database views (database hand), test frames (test hand) and their skin segmentation", fontsize=9)
    return fig


def plot_ladder(m: dict):
    """Accuracy (with its 95 % interval on the large set) and geodesic orientation error down the ladder."""
    names = m["ladder_rungs"]
    r = np.arange(1, len(names) + 1)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 4.5))
    acc = np.array(m["ladder_accuracy_large"])
    lo, hi = np.array(m["ladder_accuracy_large_ci95_low"]), np.array(m["ladder_accuracy_large_ci95_high"])
    a1.errorbar(r, acc, yerr=[acc - lo, hi - acc], fmt="o-", capsize=3, label="large set (95 % interval)")
    for key, label in (("ladder_accuracy_X", "X"), ("ladder_accuracy_Xp", "X'"), ("ladder_accuracy_Xpp", "X''")):
        a1.plot(r, m[key], "s--", alpha=0.7, label=label)
    a1.axhline(1 / 6, color="0.5", lw=0.8, ls=":", label="chance")
    a1.set_ylim(0, 1)
    a1.set_ylabel("accuracy")
    a2.plot(r, m["ladder_orientation_geodesic_error_deg_large"], "o-", label="large, all images")
    a2.plot(r, m["ladder_orientation_geodesic_error_deg_large_correct"], "o-", label="large, correctly classified")
    a2.set_ylabel("geodesic orientation error (deg)")
    for ax in (a1, a2):
        ax.set_xticks(r, [str(i) for i in r])
        ax.set_xlabel("rung")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.text(0.01, 0.01, "   ".join(f"{i}. {n}" for i, n in zip(r, names)), fontsize=6.5, wrap=True)
    fig.suptitle("Where the accuracy goes: one more difference from the database per rung")
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    return fig
