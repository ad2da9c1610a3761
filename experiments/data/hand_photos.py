"""Readers of the real hand photo sets (UCI skin pixels, HGR hand photos, gtea_grasps frames), and photos
padded into batches for JAX.

* `skin_nonskin_uci.tsv` (UCI Skin Segmentation, Bhatt & Dhall): one pixel per line, a header
  `R G B T`, but the colour columns are in the order B, G, R as the UCI documentation says
  (`tests/test_hog_segment.py::test_uci_column_order_is_bgr` checks it on the data: skin reflects
  more red than blue); label 1 skin, 2 non-skin.
* `hgr_hands/` (HGR1, Kawulok et al. 2014): `images/NAME.jpg` and `masks/NAME.bmp`, skin 0 (black)
  and background 1 (white), the forearm included.

Photos come in many sizes (47 of the 106 are 640 x 480, the rest nearly all different), so a batch
is padded to one size by edge replication (the last row and column repeated): a per-pixel model
gives the padding the values of the border, and `experiments.skin_real.methods.filtered` re-replicates after every
median pass (`experiments.skin_real`), so a padded photo's pixels get exactly what the unpadded photo would. `valid` marks
the real pixels, and the truth is False outside them.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np

from lfd_jax import UCI_FILE

HGR_DIR = "hgr_hands"


def missing_data(root: str | Path) -> str | None:
    """None when `root` holds both data sets, else a one-line message naming what is missing."""
    root = Path(root)
    missing = [str(p) for p in (root / UCI_FILE, root / HGR_DIR / "images", root / HGR_DIR / "masks")
               if not p.exists()]
    if not missing:
        return None
    return (f"skin_real: real data not found ({', '.join(missing)}); pass --data DIR holding {UCI_FILE} "
            f"and {HGR_DIR}/ (see ../shared/data/README.md)")


class Photo(NamedTuple):
    """One HGR photo: its base name, bgr (h, w, 3) uint8 as OpenCV reads it, truth (h, w) bool skin."""

    name: str
    bgr: np.ndarray
    truth: np.ndarray


def hgr_names(root: str | Path, n: int = 0) -> list[str]:
    """The sorted base names of the photos under root/hgr_hands/images; n > 0 keeps n of them evenly
    spaced over the sorted list (the first character is the gesture, so they span the gestures)."""
    names = sorted(p.stem for p in (Path(root) / HGR_DIR / "images").glob("*.jpg"))
    if not names:
        raise ValueError(f"{root}: no photos under {HGR_DIR}/images")
    if 0 < n < len(names):
        names = [names[i] for i in np.linspace(0, len(names) - 1, n).round().astype(int)]
    return names


def load_photo(root: str | Path, name: str) -> Photo:
    """The photo `name` and its mask (skin where the mask is 0); ValueError if the sizes disagree."""
    folder = Path(root) / HGR_DIR
    bgr = cv2.imread(str(folder / "images" / f"{name}.jpg"), cv2.IMREAD_COLOR)
    mask = cv2.imread(str(folder / "masks" / f"{name}.bmp"), cv2.IMREAD_GRAYSCALE)
    if bgr is None or mask is None:
        raise ValueError(f"{name}: could not read images/{name}.jpg or masks/{name}.bmp under {folder}")
    if mask.shape != bgr.shape[:2]:
        raise ValueError(f"{name}: mask {mask.shape} and photo {bgr.shape[:2]} differ in size")
    return Photo(name, bgr, mask == 0)


class PhotoBatch(NamedTuple):
    """B photos padded to H x W by edge replication. rgb (B, H, W, 3) float32 in [0, 255]; rows (B, H)
    and cols (B, W) int32: the source row / column of each padded one (min(index, size - 1)), which
    replicate any (B, H, W) array's edges; valid (B, H, W) real pixels; truth (B, H, W) (False in the
    padding); sizes (B, 2) (h, w)."""

    rgb: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    valid: np.ndarray
    truth: np.ndarray
    sizes: np.ndarray


def pad_photos(photos: list[Photo], shape: tuple[int, int]) -> PhotoBatch:
    """`photos` (each at most `shape` = (H, W)) as one edge-replicated `PhotoBatch`."""
    H, W = shape
    sizes = np.array([p.truth.shape for p in photos], np.int32)
    if (sizes[:, 0] > H).any() or (sizes[:, 1] > W).any():
        raise ValueError(f"photos: a photo is larger than the batch shape {shape}")
    rows = np.minimum(np.arange(H, dtype=np.int32), sizes[:, :1] - 1)
    cols = np.minimum(np.arange(W, dtype=np.int32), sizes[:, 1:] - 1)
    rgb = np.stack([p.bgr[r][:, c, ::-1] for p, r, c in zip(photos, rows, cols)]).astype(np.float32)
    valid = ((np.arange(H)[None, :, None] < sizes[:, 0, None, None])
             & (np.arange(W)[None, None, :] < sizes[:, 1, None, None]))
    truth = np.stack([p.truth[r][:, c] for p, r, c in zip(photos, rows, cols)]) & valid
    return PhotoBatch(rgb, rows, cols, valid, truth, sizes)


GTEA_DIR, REACH_CLIP = "gtea_grasps", "reach_grasp/teaser_movement.gif"


def person_of(name: str) -> str:
    """The HGR person id of a photo's base name (`..._id05_2` -> `id05`); '' when there is none."""
    parts = [p for p in name.split("_") if p.startswith("id") and p[2:].isdigit()]
    return parts[0] if parts else ""


def hgr_split(names: list[str], fit_ids: tuple[str, ...], validation_ids: tuple[str, ...]) -> dict[str, list[str]]:
    """The HGR photos split by person: {"fit": ..., "validation": ..., "test": the other persons}."""
    split = {"fit": [], "validation": [], "test": []}
    for name in names:
        person = person_of(name)
        split["fit" if person in fit_ids else "validation" if person in validation_ids else "test"].append(name)
    return split


def scaled(rgb: np.ndarray, scale: float, masks: tuple[np.ndarray, ...] = ()) -> tuple[np.ndarray, ...]:
    """An RGB image resized by `scale` (area averaging) and bool masks with it (nearest); scale 1 keeps them."""
    if scale == 1.0:
        return (rgb, *masks)
    h, w = rgb.shape[:2]
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    return (cv2.resize(rgb, size, interpolation=cv2.INTER_AREA),
            *(cv2.resize(m.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST) > 0 for m in masks))


class GteaFrame(NamedTuple):
    """One egocentric frame: rgb (h, w, 3) float32; ignore (h, w) bool, the annotation drawn into the
    pixels (masked out of every count); boxes (K, 4) int (top, left, bottom, right), exclusive, the
    true hand boxes; in_box (h, w) bool, their union."""

    name: str
    rgb: np.ndarray
    ignore: np.ndarray
    boxes: np.ndarray
    in_box: np.ndarray


def annotation_mask(bgr: np.ndarray, boxes: list[tuple[int, int, int, int]]) -> np.ndarray:
    """The pixels of gtea_grasps' drawn annotation (x0, y0, x1, y1 boxes, inclusive): a 7-px band on
    every drawn box edge, and near the boxes the saturated pure blue / green lines and the red text
    (one channel high, the others far below), grown by 2 px. Found from the label file's boxes and
    the colours alone, never from any skin model."""
    h, w = bgr.shape[:2]
    band, near, top = np.zeros((h, w), np.uint8), np.zeros((h, w), bool), np.zeros((h, w), bool)
    for x0, y0, x1, y1 in boxes:
        cv2.rectangle(band, (x0, y0), (x1, y1), 1, 7)
        near[max(y0 - 40, 0):y1 + 31, max(x0 - 30, 0):x1 + 31] = True
        top[max(y0 - 25, 0):y0 + 60, max(x0 - 10, 0):x1 + 160] = True   # the text is written from the box's top
    c = bgr.astype(np.int32)
    high, low = c.max(-1), c.min(-1)
    pure = (high - low > 110) & (high > 140) & ((c - low[..., None]) < 70).sum(-1) == 2
    red = (c[..., 2] - np.maximum(c[..., 0], c[..., 1]) > 80) & top
    drawn = cv2.dilate(((pure & near) | red).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    return (band > 0) | drawn


class GteaLabels(NamedTuple):
    """One labelled gtea_grasps frame as stored: name (its stem), bgr (H, W, 3) uint8 with the
    annotation drawn in, hands and objects: lists of (x0, y0, x1, y1) inclusive boxes (labels.csv)."""

    name: str
    bgr: np.ndarray
    hands: list
    objects: list


def read_gtea(root: str | Path) -> list[GteaLabels]:
    """The labelled frames of gtea_grasps, in name order (`GteaLabels`).

    Raises:
        ValueError: naming the image that cannot be read.
    """
    import csv
    folder = Path(root) / GTEA_DIR
    rows: dict[str, list[dict]] = {}
    with open(folder / "labels.csv", newline="") as f:
        for row in csv.DictReader(f):
            rows.setdefault(row["image"], []).append(row)
    frames = []
    for image, labels in sorted(rows.items()):
        bgr = cv2.imread(str(folder / image), cv2.IMREAD_COLOR)
        if bgr is None:
            raise ValueError(f"{image}: could not read it under {folder}")
        hands = [tuple(int(r[k]) for k in ("hand_xmin", "hand_ymin", "hand_xmax", "hand_ymax")) for r in labels]
        objects = [tuple(int(r[k]) for k in ("obj_xmin", "obj_ymin", "obj_xmax", "obj_ymax")) for r in labels
                   if r["obj_xmin"] not in ("", "-1")]
        frames.append(GteaLabels(Path(image).stem, bgr, hands, objects))
    return frames


def read_gtea_grasps(root: str | Path) -> dict[str, list[tuple[str, int]]]:
    """Each labelled gtea_grasps frame's hands' grasps, in the order of `read_gtea`'s hand boxes:
    frame stem -> [(grasp_coarse: "power", "precision", ..., lfd_cutkosky: the project's class or -1)]."""
    import csv
    grasps: dict[str, list[tuple[str, int]]] = {}
    with open(Path(root) / GTEA_DIR / "labels.csv", newline="") as f:
        for row in csv.DictReader(f):
            grasps.setdefault(Path(row["image"]).stem, []).append(
                (row["grasp_coarse"], int(row["lfd_cutkosky"]) if row["lfd_cutkosky"] else -1))
    return grasps


def load_gtea(root: str | Path, scale: float = 1.0) -> list[GteaFrame]:
    """The frames of gtea_grasps with their hand boxes (labels.csv) and annotation masks, scaled."""
    frames = []
    for name, bgr, hands, objects in read_gtea(root):
        ignore = annotation_mask(bgr, hands + objects)
        in_box = np.zeros(bgr.shape[:2], bool)
        for x0, y0, x1, y1 in hands:
            in_box[y0:y1 + 1, x0:x1 + 1] = True
        rgb, ignore, in_box = scaled(bgr[..., ::-1].astype(np.float32), scale, (ignore, in_box))
        boxes = np.array([(y0, x0, y1 + 1, x1 + 1) for x0, y0, x1, y1 in hands], np.float64) * scale
        frames.append(GteaFrame(name, rgb, ignore, np.round(boxes).astype(int), in_box))
    return frames
