"""Figures of the real-reach study: accuracy along the reach per method, confusion matrices, the
PHMM's recognised φ per true size, and the onset / contact error histograms."""
from __future__ import annotations

import numpy as np

from experiments.plotting import plt
from experiments.real_reach.config import METHOD_NAMES, METHODS
from experiments.real_reach.data import SIZES


def plot_online(result, cfg, normalisation: str):
    """Three-way size accuracy of every method on the first 20–100 % of the reach (pooled over the
    held-out persons; dotted: chance)."""
    fig, ax = plt.subplots(figsize=(5.6, 3.6))
    xs = [100 * f for f in cfg.fractions]
    for m in METHODS:
        ax.plot(xs, [100 * result.accuracy(m, f) for f in cfg.fractions], marker="o", label=METHOD_NAMES[m])
    ax.axhline(100 / 3, color="0.5", ls=":", lw=0.8)
    ax.set_xlabel("% of the reach seen")
    ax.set_ylabel("size accuracy (%), chance 33 %")
    ax.set_ylim(0, 100)
    ax.set_title(f"Object size along the reach, leave-one-person-out ({normalisation} features)", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    return fig


def plot_confusions(result, normalisation: str):
    """One confusion matrix per method on whole reaches (rows true size, columns recognised)."""
    fig, axes = plt.subplots(1, len(METHODS), figsize=(3.0 * len(METHODS), 3.2), sharey=True)
    for ax, m in zip(axes, METHODS):
        counts = result.confusion(m)
        ax.imshow(counts / np.maximum(counts.sum(1, keepdims=True), 1), cmap="gray", vmin=0, vmax=1)
        ax.set_xticks(range(3), SIZES)
        ax.set_yticks(range(3), SIZES)
        ax.set_xlabel("recognised", fontsize=8)
        ax.set_title(f"{METHOD_NAMES[m]}\n{100 * result.accuracy(m):.1f} %", fontsize=7)
        for (i, j), c in np.ndenumerate(counts):
            ax.text(j, i, str(c), ha="center", va="center", color="red", fontsize=8)
    axes[0].set_ylabel("true size")
    fig.suptitle(f"Confusion on whole reaches, held-out persons ({normalisation} features)", fontsize=9)
    return fig


def plot_phi(result, normalisation: str):
    """The PHMM's recognised size (cm) per true size; the search box's edges show as walls."""
    fig, ax = plt.subplots(figsize=(5.0, 3.2))
    bins = np.linspace(result.phmm_cm.min() - 0.2, result.phmm_cm.max() + 0.2, 30)
    for k, s in enumerate(SIZES):
        ax.hist(result.phmm_cm[result.truth == k], bins=bins, alpha=0.5, label=f"true {s}")
    for cm in (2.5, 5.5, 7.5):
        ax.axvline(cm, color="k", lw=0.6, ls=":")
    ax.set_xlabel("recognised size (cm) = PHMM φ mapped through the corners")
    ax.set_ylabel("reaches")
    ax.set_title(f"PHMM φ ({normalisation}): {100 * result.edge_share:.0f} % on the search box's edge", fontsize=9)
    ax.legend(fontsize=7)
    return fig


def plot_events(r):
    """Histograms of estimated − annotated onset and contact frames per detector (60 Hz)."""
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.4), sharey=True)
    for ax, (event, errors) in zip(axes, (("onset", r.onset_error), ("contact", r.contact_error))):
        bins = np.arange(-30.5, 31.5, 2)
        for name, e in errors.items():
            ax.hist(np.clip(e, -30, 30), bins=bins, histtype="step", lw=1.3,
                    label=f"{name} (median abs. error {np.median(np.abs(e)):.0f})")
        ax.set_xlabel(f"{event}: estimated − annotated (frames)", fontsize=8)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("movements")
    fig.suptitle("Reach onset and contact found online, leave-one-person-out (60 Hz; errors clipped at ±30)",
                 fontsize=9)
    return fig
