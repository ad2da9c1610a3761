"""The grasp class of real hands (GRASP §III-V on real photos): the study's recogniser on the labelled
hands of `gtea_grasps` (real egocentric frames, the annotation inpainted: `real_photos.load_gtea_clean`),
each hand cut at its true box, beside the majority class and a YCrCb + HOG nearest-neighbour peer.

Per labelled hand whose coarse grasp (Feix et al. 2016, the label file's `grasp_coarse`) is power or
precision: the skin pixels inside the true box (ours: the one skin model of real photos,
`lfd_jax.fit_real_skin_model`, at its threshold; the peer: the YCrCb rule of Chai & Ngan, both median-filtered as GRASP's §III-A), the
component nearest the box centre cropped square (`hog_jax.crop_components`) at the study's crop size,
then
- `ours`: the study's recogniser as it classifies its own test images (its network where it has one,
  else eq. 3's vote over its database, exact search);
- `ycrcb_hog_1nn`: the YCrCb crop's HOG, the class of its nearest database view (k = 1);
- `majority`: Large Diameter (power) for every hand, the most frequent label.
A hand with no skin in its box is "not found" (counted wrong). Our six classes map to coarse types by
Cutkosky's taxonomy: Large Diameter, Small Diameter, Abducted Thumb and Power Sphere are power; Pinch
and Precision Disc precision. Figures: power / precision balanced accuracy (the mean of the two
recalls; majority alone: 0.5), raw coarse accuracy, the exact class's mean per-class recall over the
hands whose label is one of our classes (`lfd_cutkosky`), the coarse confusion, the crops.
"""
from __future__ import annotations

from pathlib import Path

import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import hog_jax
from experiments.data.hand_photos import read_gtea_grasps
from experiments.grasp_recognition.real_photos import RealFrames, load_gtea_clean
from experiments.peers.ycrcb import ycrcb_rule
from lfd_jax.grasp import Crops, Recogniser, crops_of, features, net_labels, recognise
from sim.grasping import GRASP_CLASSES

COARSE_OF_CLASS = {1: "power", 2: "power", 4: "power", 10: "power", 9: "precision", 12: "precision"}
COARSE = ("power", "precision")
METHODS = ("ours", "ycrcb_hog_1nn", "majority")


def _box_masks(frames: RealFrames, skin_masks: list[np.ndarray], keep: list[np.ndarray]):
    """(frame index, mask within the box, box centre (row, col)) for the kept hands of every frame."""
    out = []
    for f, (boxes, mask) in enumerate(zip(frames.boxes, skin_masks)):
        for k, (top, left, bottom, right) in enumerate(boxes):
            if keep[f][k]:
                inside = np.zeros_like(mask)
                inside[top:bottom, left:right] = True
                out.append((f, mask & inside, ((top + bottom) / 2, (left + right) / 2)))
    return out


def hand_crops(frames: RealFrames, skin_masks: list[np.ndarray], keep: list[np.ndarray], crop_size: int) -> Crops:
    """The crops of the kept hands: the skin mask inside each true box, its component nearest the box
    centre, square, at `crop_size` (`hog_jax.crop_components`)."""
    crops = []
    for f, mask, centre in _box_masks(frames, skin_masks, keep):
        grey = frames.rgb[f].astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32) / 255.0
        crops.append(crops_of(hog_jax.crop_components(grey[None], mask[None], seed_points=np.array([centre]),
                                                      out_size=crop_size)))
    return Crops(*(np.concatenate([getattr(c, n) for c in crops]) for n in Crops._fields))


def ours_masks(skin: hog_jax.SkinModel, frames: RealFrames) -> list[np.ndarray]:
    """The skin model's median-filtered skin mask of each frame (`hog_jax.segment`'s)."""
    return [np.asarray(hog_jax.segment(skin, rgb[None]).skin)[0] for rgb in frames.rgb]


def ycrcb_masks(frames: RealFrames) -> list[np.ndarray]:
    """The YCrCb rule's mask of each frame, median-filtered as GRASP's."""
    return [np.asarray(hog_jax.median3(ycrcb_rule(jnp.asarray(rgb))[None]))[0] for rgb in frames.rgb]


def classes_of(rec: Recogniser, crops: Crops) -> np.ndarray:
    """(N,) Cutkosky classes of the crops by the recogniser (its network where it has one), -1 where
    no hand was found."""
    x = features(rec, crops.images, crops.masks, crops.found)
    index = recognise(rec, x, crops.found, exact=True, labels=net_labels(rec, crops)).labels
    return np.where(index >= 0, np.asarray(GRASP_CLASSES)[np.maximum(index, 0)], -1)


def nearest_view_classes(rec: Recogniser, crops: Crops) -> np.ndarray:
    """(N,) the Cutkosky class of each crop's nearest database view by HOG (k = 1), -1 where no hand."""
    x = features(rec, crops.images, crops.masks, crops.found)
    labels = np.full(len(crops.found), -1)
    if crops.found.any():
        labels[crops.found] = np.asarray(hog_jax.predict(rec.model, x[crops.found], 1).label)
    return np.where(labels >= 0, np.asarray(GRASP_CLASSES)[np.maximum(labels, 0)], -1)


def grasp_scores(predicted: np.ndarray, coarse: np.ndarray, exact: np.ndarray) -> dict:
    """Scores of predicted Cutkosky classes (-1: not found) against the coarse labels (N,) and the exact
    classes (N,) (-1 where the label is none of ours)."""
    got = np.array([COARSE_OF_CLASS.get(int(c), "not found") for c in predicted])
    recalls = [float(np.mean(got[coarse == c] == c)) for c in COARSE if np.any(coarse == c)]
    ours = exact >= 0
    exact_recalls = [float(np.mean(predicted[exact == c] == c)) for c in np.unique(exact[ours])]
    confusion = {f"{t}_as_{p}": int(np.sum((coarse == t) & (got == p))) for t in COARSE
                 for p in (*COARSE, "not found")}
    return {"balanced_accuracy": float(np.mean(recalls)), "coarse_accuracy": float(np.mean(got == coarse)),
            "exact_mean_recall": float(np.mean(exact_recalls)) if exact_recalls else float("nan"),
            "found": float(np.mean(predicted >= 0)), **confusion}


def crop_sheet(crops: Crops, coarse: np.ndarray, predicted: np.ndarray, columns: int = 10) -> plt.Figure:
    """The real hand crops our recogniser saw, each titled with its label and our class."""
    rows = -(-len(coarse) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(1.3 * columns, 1.5 * rows), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for i, ax in enumerate(axes.flat[:len(coarse)]):
        ax.imshow(crops.images[i], cmap="gray", vmin=0, vmax=1)
        ax.set_title(f"{coarse[i][:4]} -> {predicted[i] if predicted[i] >= 0 else 'none'}", fontsize=6)
    fig.suptitle("gtea_grasps hands at their true boxes: label (coarse) -> our class (Cutkosky)", fontsize=8)
    fig.tight_layout()
    return fig


def evaluate_real_grasps(rec: Recogniser, skin: hog_jax.SkinModel, data: str | Path, crop_size: int
                         ) -> tuple[dict, dict]:
    """({method: scores} plus "hands", {figure name: figure}) on gtea_grasps (module docstring)."""
    frames = load_gtea_clean(data)
    labels = read_gtea_grasps(data)
    grasps = [labels[name] for name in frames.names]
    keep = [np.array([c in COARSE for c, _ in hands]) for hands in grasps]
    coarse = np.array([c for hands in grasps for c, _ in hands if c in COARSE])
    exact = np.array([e for hands in grasps for c, e in hands if c in COARSE])
    ours_crops = hand_crops(frames, ours_masks(skin, frames), keep, crop_size)
    peer_crops = hand_crops(frames, ycrcb_masks(frames), keep, crop_size)
    predicted = {"ours": classes_of(rec, ours_crops), "ycrcb_hog_1nn": nearest_view_classes(rec, peer_crops),
                 "majority": np.full(len(coarse), 1)}
    metrics = {m: grasp_scores(p, coarse, exact) for m, p in predicted.items()}
    metrics["hands"] = {"power": int(np.sum(coarse == "power")), "precision": int(np.sum(coarse == "precision")),
                        "exact_labelled": int(np.sum(exact >= 0))}
    return metrics, {"real_grasp_crops_gtea.png": crop_sheet(ours_crops, coarse, predicted["ours"])}
