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


def mask_tint(frame: np.ndarray, mask: np.ndarray, truth: np.ndarray | None = None) -> np.ndarray:
    """(H, W, 3) uint8: the frame with a foreground mask tinted; against `truth` (int8: 1 foreground, 0
    background, -1 ignored) the hits green, false alarms red and misses blue."""
    out = frame.astype(np.float32) * 0.5
    if truth is None:
        out[mask] += np.array([127, 127, 0], np.float32)
    else:
        for where, colour in ((mask & (truth == 1), (0, 160, 0)), (mask & (truth == 0), (200, 0, 0)),
                              (~mask & (truth == 1), (0, 0, 220))):
            out[where] += np.array(colour, np.float32)
    return np.clip(out, 0, 255).astype(np.uint8)


def background_sheet(name: str, kept: list) -> plt.Figure:
    """Rows of scored frames of one real sequence: the frame, then each method's mask against the truth
    (green hit, red false alarm, blue miss)."""
    methods = list(kept[0][3]) if kept else []
    rows, cols = max(len(kept), 1), 1 + len(methods)
    h, w = (kept[0][1].shape[:2]) if kept else (1, 1)
    fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.6 * rows * h / w + 0.4), squeeze=False)
    for r, (number, frame, truth, masks) in enumerate(kept):
        axes[r, 0].imshow(frame)
        axes[r, 0].set_title(f"{name} {number}", fontsize=7)
        for c, m in enumerate(methods, start=1):
            axes[r, c].imshow(mask_tint(frame, masks[m], truth))
            axes[r, c].set_title(m, fontsize=7)
    for ax in axes.flat:
        ax.axis("off")
    fig.tight_layout()
    return fig


_PART_COLOURS = {"face": "yellow", "right_hand": "red", "left_hand": "deepskyblue", "cube": "lime"}


def reach_sheet(frames: np.ndarray, labels: np.ndarray, positions: dict, boxes) -> plt.Figure:
    """The annotated frames of the reach clip: our labels tinted, the boxes drawn (face yellow, right
    hand red, left hand blue, cube green) and each tracked part's point in its box's colour."""
    from experiments.data.video.reach_clip import PARTS

    tinted = overlay(frames, truth_coded(labels))
    cols = 4
    rows = -(-len(boxes.frames) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.8 * rows), squeeze=False)
    for ax, (i, t) in zip(axes.flat, enumerate(boxes.frames)):
        ax.imshow(tinted[t])
        for j, part in enumerate(PARTS):
            x0, y0, x1, y1 = boxes.boxes[i, j]
            ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ec=_PART_COLOURS[part], lw=1))
        for part, xy in positions.items():
            if np.isfinite(xy[t]).all():
                ax.plot(*xy[t], "+", color=_PART_COLOURS[part], ms=12, mew=2)
        ax.set_title(f"frame {t}", fontsize=8)
    for ax in axes.flat:
        ax.axis("off")
    fig.tight_layout()
    return fig
