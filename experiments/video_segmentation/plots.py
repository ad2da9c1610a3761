"""Figures of the video segmentation study: contact sheet of masks over frames, IoU over time, tracks,
and the overlay video's frames."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hog_jax.video import FACE, HAND  # noqa: E402
from lfd_jax import overlay, truth_coded  # noqa: E402


def overlay_frames(rec, seg) -> np.ndarray:
    """(T, H, 2W, 3) uint8: the left view with the ground truth (left half) and our labels (right)."""
    ours = truth_coded(seg.left.labels)
    return np.concatenate([overlay(rec.left, rec.left_labels), overlay(rec.left, ours)], axis=2)


def contact_sheet(rec, seg, start: int, n: int):
    """Frames from the segmentation phase: truth above, ours below."""
    frames = overlay_frames(rec, seg)
    idx = np.linspace(start, len(frames) - 1, n).astype(int)
    cols = min(n, 4)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 1.7 * rows), squeeze=False)
    for ax, t in zip(axes.flat, idx):
        ax.imshow(frames[t])
        ax.set_title(f"frame {t}: truth | ours", fontsize=8)
    for ax in axes.flat:
        ax.axis("off")
    fig.tight_layout()
    return fig


def iou_over_time(series) -> plt.Figure:
    """Hand IoU of the full pipeline per frame of the segmentation phase, one line per clip."""
    fig, ax = plt.subplots(figsize=(7, 3))
    for s in series:
        ax.plot(s, lw=0.6, alpha=0.5)
    ax.set_xlabel("frame after the segmentation starts")
    ax.set_ylabel("hand IoU")
    ax.set_ylim(0, 1)
    ax.set_title("hand IoU over time (level sets + tracking), every evaluated clip")
    return fig


def tracks(rec, seg, start: int) -> plt.Figure:
    """Tracked hand and face centroids in the left image against the truth."""
    pos = np.asarray(seg.positions.skin_left.position)
    lost = np.asarray(seg.positions.skin_left.lost)
    t = np.arange(len(pos))
    fig, axes = plt.subplots(1, 2, figsize=(10, 3))
    for ax, k, j, name in ((axes[0], HAND, 0, "hand"), (axes[1], FACE, 1, "face")):
        truth = np.where(rec.ellipse_found[:, 0, j, None], rec.ellipse_centre[:, 0, j], np.nan)
        ours = np.where(~lost[:, k, None], pos[:, k], np.nan)
        for c, axis in enumerate("xy"):
            ax.plot(t, truth[:, c], "k-", lw=1, label=f"truth {axis}" if c == 0 else None)
            ax.plot(t[start:], ours[start:, c], "--", lw=1, label=f"tracked {axis}")
        ax.set_title(f"{name} centroid (px)")
        ax.set_xlabel("frame")
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig
