"""Figures of the skin study on real photos: a contact sheet of photos with the true mask and each
method's errors, and precision against recall over our model's thresholds."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from experiments.skin_real.metrics import confusion_counts, per_photo_iou  # noqa: E402

_LABELS = {"ours": "ours (hog_jax)", "ycrcb": "YCrCb rule", "ycrcb_unfiltered": "YCrCb rule, unfiltered",
           "grabcut": "GrabCut from ours"}
_HIT, _FALSE_ALARM, _MISS = (0.1, 0.8, 0.1), (0.9, 0.1, 0.1), (0.1, 0.3, 1.0)


def error_image(bgr: np.ndarray, pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(h, w, 3) float RGB: the photo dimmed to grey, true skin found in green, false skin in red,
    missed skin in blue."""
    grey = (bgr.astype(np.float32) @ np.array([0.114, 0.587, 0.299], np.float32) / 255.0)[..., None]
    out = np.repeat(0.35 * grey, 3, axis=-1)
    for where, colour in ((pred & truth, _HIT), (pred & ~truth, _FALSE_ALARM), (~pred & truth, _MISS)):
        out[where] = 0.35 * out[where] + 0.65 * np.asarray(colour)
    return out


def contact_sheet(sheet: list) -> plt.Figure:
    """One row per photo: the photo, its true mask, then each method's errors (titles: photo IoU)."""
    methods = list(sheet[0][1])
    cols = 2 + len(methods)
    fig, axes = plt.subplots(len(sheet), cols, figsize=(2.6 * cols, 2.2 * len(sheet)), squeeze=False)
    for row, (photo, masks) in zip(axes, sheet):
        row[0].imshow(photo.bgr[..., ::-1])
        row[0].set_title(photo.name, fontsize=7)
        row[1].imshow(photo.truth, cmap="gray_r", vmin=0, vmax=1)
        row[1].set_title("true skin (black)", fontsize=7)
        for ax, m in zip(row[2:], methods):
            valid = np.ones((1, *photo.truth.shape), bool)
            iou = per_photo_iou(confusion_counts(masks[m][None], photo.truth[None], valid))[0]
            ax.imshow(error_image(photo.bgr, masks[m], photo.truth))
            ax.set_title(f"{_LABELS[m]}: IoU {iou:.2f}", fontsize=7)
    for ax in axes.flat:
        ax.axis("off")
    fig.suptitle("green: skin found, red: false skin, blue: missed skin", fontsize=8)
    fig.tight_layout()
    return fig


def precision_recall(thresholds, curves: dict, points: dict, threshold: float) -> plt.Figure:
    """Precision against recall of our model over `thresholds` (curves: name -> (precision, recall)
    arrays), each point labelled with its threshold, and every method's operating point (points:
    method -> (precision, recall)); ours at `threshold`."""
    fig, ax = plt.subplots(figsize=(6, 5))
    shown = [v for precision, recall in [*curves.values(), *points.values()] for v in np.ravel([precision, recall])]
    low = max(0.0, float(np.nanmin(shown)) - 0.05)
    for (name, (precision, recall)), style in zip(curves.items(), ("o-", "s--")):
        ax.plot(recall, precision, style, ms=3, lw=1, label=f"ours over thresholds, {name}")
        for t, r, p in zip(thresholds, recall, precision):
            ax.annotate(f"{t:g}", (r, p), fontsize=6, xytext=(2, 2), textcoords="offset points")
    for (m, (precision, recall)), marker in zip(points.items(), "*^vD"):
        label = f"{_LABELS[m]}" + (f" (threshold {threshold:.2f})" if m == "ours" else "")
        ax.plot(recall, precision, marker, ms=10, label=f"{label}, HGR photos")
    ax.set_xlabel("recall (pooled over pixels)")
    ax.set_ylabel("precision")
    ax.set_xlim(low, 1.01)
    ax.set_ylim(low, 1.01)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title("skin pixels: precision vs recall (threshold labels: log-ratio)", fontsize=9)
    return fig
