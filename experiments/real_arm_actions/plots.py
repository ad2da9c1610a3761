"""Figures of the real-arm action study: confusion matrices, accuracy per held-out person, and the
side PHMMs' recognised φ against the true side."""
from __future__ import annotations

import numpy as np

from experiments.data.ue_adl import ACTION_NAMES, ACTIONS
from experiments.plotting import plt
from experiments.real_arm_actions.config import METHOD_NAMES


def plot_confusions(results: dict, kind: str):
    """One confusion matrix per method (rows: true action, columns: recognised; white = 100 %)."""
    fig, axes = plt.subplots(1, len(results), figsize=(3.2 * len(results) + 0.8, 3.6), sharey=True)
    for ax, (method, result) in zip(np.atleast_1d(axes), results.items()):
        counts = result.confusion()
        rate = counts / np.maximum(counts.sum(1, keepdims=True), 1)
        ax.imshow(rate, cmap="gray", vmin=0, vmax=1)
        ax.set_xticks(range(len(ACTIONS)), ACTIONS, fontsize=8)
        ax.set_yticks(range(len(ACTION_NAMES)), ACTION_NAMES, fontsize=7)
        ax.set_xlabel("recognised (" + ", ".join(f"{a} {n}" for a, n in zip(ACTIONS, ACTION_NAMES)) + ")", fontsize=5)
        ax.set_title(f"{METHOD_NAMES[method]}\n{100 * result.accuracy:.1f} % (n = {counts.sum()})", fontsize=8)
        for (i, j), c in np.ndenumerate(counts):
            if c:
                ax.text(j, i, str(c), ha="center", va="center", color="red", fontsize=8)
    np.atleast_1d(axes)[0].set_ylabel("true action", fontsize=8)
    fig.suptitle(f"UE-ADL, {kind}: confusion matrices over the held-out persons", fontsize=9)
    return fig


def plot_per_person(results: dict, kind: str):
    """Accuracy of every method on every held-out person."""
    persons = list(next(iter(results.values())).per_person())
    fig, ax = plt.subplots(figsize=(max(5.0, 0.9 * len(persons) + 2.5), 3.4))
    width = 0.8 / len(results)
    xs = np.arange(len(persons))
    for k, (method, result) in enumerate(results.items()):
        acc = result.per_person()
        ax.bar(xs + k * width, [100 * acc[p] for p in persons], width, label=f"{method} ({100 * result.accuracy:.1f} %)")
    ax.set_xticks(xs + width * (len(results) - 1) / 2, persons, fontsize=8)
    ax.set_ylim(0, 105)
    ax.axhline(25, color="0.5", lw=0.8, ls=":")
    ax.set_ylabel("accuracy (%), chance 25 %")
    ax.set_title(f"UE-ADL, {kind}: accuracy per held-out person", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    return fig


def plot_side_phi(side, kind: str):
    """φ recognised by the true action's side PHMM (0: left-arm corner, 1: right-arm corner)."""
    fig, ax = plt.subplots(figsize=(5.0, 3.2))
    bins = np.linspace(-0.15, 1.15, 27)
    for s, name in ((0, "left arm"), (1, "right arm")):
        ax.hist(side.phi[side.side == s], bins=bins, alpha=0.6, label=f"true side: {name}")
    ax.axvline(0.5, color="k", lw=0.8, ls="--")
    ax.set_xlabel("recognised φ (0 = left-arm model, 1 = right-arm model)")
    ax.set_ylabel("trials")
    ax.set_title(f"UE-ADL, {kind}: side PHMMs, side correct {100 * side.side_correct.mean():.1f} %", fontsize=9)
    ax.legend(fontsize=7)
    return fig
