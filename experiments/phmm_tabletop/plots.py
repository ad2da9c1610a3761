"""Figures of the PHMM table-top study: error maps over the test raster, the log-likelihood surface,
noise robustness, robot grasp-point paths."""
from __future__ import annotations

import numpy as np

from experiments.plotting import plt


def _raster_map(ax, values, title, vmax=None):
    im = ax.imshow(values, origin="lower", cmap="viridis", vmin=0, vmax=vmax)
    for (i, j), v in np.ndenumerate(values):
        ax.text(j, i, f"{v:.1f}", ha="center", va="center", fontsize=6, color="w")
    ax.set_title(title, fontsize=8)
    ax.set_xlabel("column (width, left to right)", fontsize=7)
    ax.set_ylabel("row (depth, near to far)", fontsize=7)
    return im


def plot_maps(maps: dict, shape, title: str, unit: str = "cm"):
    fig, axes = plt.subplots(1, len(maps), figsize=(3.6 * len(maps), 2.8))
    vmax = max(float(np.max(v)) for v in maps.values()) or 1.0
    for ax, (name, values) in zip(np.atleast_1d(axes), maps.items()):
        im = _raster_map(ax, np.asarray(values).reshape(shape), name, vmax)
    fig.colorbar(im, ax=axes, shrink=0.8, label=unit)
    fig.suptitle(title, fontsize=9)
    return fig


def plot_loglik_surface(axis, surface, true_phi, n_max: int):
    """log p(X | lambda^phi) - max over the phi grid, with the maximum and the true target."""
    fig, ax = plt.subplots(figsize=(4.5, 3.8))
    shown = np.maximum(surface - surface.max(), np.percentile(surface - surface.max(), 60))
    im = ax.contourf(axis, axis, shown.T, levels=30, cmap="viridis")
    i, j = np.unravel_index(np.argmax(surface), surface.shape)
    ax.plot(axis[i], axis[j], "r+", ms=12, label="maximum")
    ax.plot(true_phi[0], true_phi[1], "wx", ms=9, label="true target")
    ax.set_xlabel("phi_1 (depth)")
    ax.set_ylabel("phi_2 (width)")
    ax.set_title(f"log p(X | lambda^phi) - max, one pointing movement, 3x3 PHMM\n({n_max} local max.; "
                 f"colours clipped at the 60th percentile)", fontsize=8)
    ax.legend(fontsize=7)
    fig.colorbar(im, ax=ax)
    return fig


def plot_noise(noise_cm, error_cm: dict, rate: dict, hmm_rate: dict):
    """Position error and classification rate against the noise sigma; error_cm, rate: PHMM variant
    (e.g. "2x2", "3x3") -> {sigma: value}; entries of error_cm without a rate are baselines."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.4))
    sig = np.asarray(noise_cm)
    for g, style in zip(error_cm, ("o--", "s-", "d-", "v-.", "x:")):
        label = f"PHMM {g}" if g in rate else g  # a baseline without a classification rate
        ax1.plot(sig, [error_cm[g][s] for s in noise_cm], style, label=label)
        if g in rate:
            ax2.plot(sig, [rate[g][s] * 100 for s in noise_cm], style, label=label)
    ax2.plot(sig, [hmm_rate[s] * 100 for s in noise_cm], "^:", label="classical HMMs")
    ax1.set_xlabel("noise sigma (cm)")
    ax1.set_ylabel("position error (cm)")
    ax2.set_xlabel("noise sigma (cm)")
    ax2.set_ylabel("classification rate (%)")
    for ax in (ax1, ax2):
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    return fig


def plot_robot(setup, playbacks, reach_err):
    """Grasp-point paths of a few targets, side (y-z) and top (x-y) views, with the table."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
    picks = np.linspace(0, len(playbacks) - 1, 5).astype(int)
    for k in picks:
        g = playbacks[k].grasp
        line, = ax1.plot(g[:, 1], g[:, 2], lw=1)
        ax1.plot(*setup.targets[k, 1:], "o", color=line.get_color())
        ax2.plot(g[:, 0], g[:, 1], lw=1, color=line.get_color(), label=f"target {k}: {reach_err[k]:.1f} cm")
        ax2.plot(*setup.targets[k, :2], "o", color=line.get_color())
    ax1.axhline(setup.table_z, color="k", lw=1)
    ax1.axvline(setup.table_near_y, color="k", lw=0.5, ls=":")
    ax1.set_xlabel("y forward (m)")
    ax1.set_ylabel("z up (m)")
    ax1.set_title("robot grasp point, side view (table top: black line)", fontsize=8)
    ax2.set_xlabel("x right (m)")
    ax2.set_ylabel("y forward (m)")
    ax2.set_title("top view (o: scaled targets)", fontsize=8)
    ax2.legend(fontsize=6)
    for ax in (ax1, ax2):
        ax.set_aspect("equal")
    return fig
