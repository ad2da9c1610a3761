"""The CDnet 2012/2014 "baseline/highway" video (changedetection.net; Goyette et al., CVPRW 2012; Wang
et al., CVPRW 2014) and CDnet's scoring of foreground masks.

Folder layout (../shared/data/cdnet_highway/, see its README): `input/in%06d.jpg` (1,700 frames of
320 x 240), `groundtruth/gt%06d.png` (per pixel: 0 static background, 50 hard shadow, 85 outside the
region of interest, 170 unknown motion, 255 moving foreground), `temporalROI.txt` ("470 1700": the
1-based, inclusive range of evaluated frames; frames 1-469 learn the background and carry no labels)
and `ROI.bmp` (white = evaluated).

Scoring (`score_cdnet`), CDnet's convention: a prediction is scored against foreground = 255 and
background = {0, 50} (shadows count as background); pixels labelled 85 or 170 and pixels outside the
spatial ROI are ignored; TP, FP, FN and TN are pooled over all evaluated frames and pixels, then
precision = TP / (TP + FP), recall = TP / (TP + FN), F1 = 2 P R / (P + R) (each 0 when its
denominator is 0).
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import NamedTuple

import numpy as np

from lfd_common import as_array

__all__ = ["CDNET_DIR", "CDnetScore", "CDnetVideo", "FOREGROUND", "IGNORED", "load_cdnet", "score_cdnet"]

CDNET_DIR = "../shared/data/cdnet_highway"  # relative to the project root, as the experiments run
FOREGROUND = 255
BACKGROUND = (0, 50)
IGNORED = (85, 170)


class CDnetVideo(NamedTuple):
    """frames (T, H, W, 3) uint8 RGB; groundtruth (T, H, W) uint8 labels; roi (H, W) bool; numbers (T,)
    the frames' 1-based numbers; temporal_roi (first, last), the evaluated range (1-based, inclusive)."""

    frames: np.ndarray
    groundtruth: np.ndarray
    roi: np.ndarray
    numbers: np.ndarray
    temporal_roi: tuple[int, int]

    def evaluated(self) -> np.ndarray:
        """(T,) bool: the frames inside the temporal ROI."""
        first, last = self.temporal_roi
        return (self.numbers >= first) & (self.numbers <= last)


class CDnetScore(NamedTuple):
    """Pooled precision, recall, F1 and the counts behind them."""

    precision: float
    recall: float
    f1: float
    tp: int
    fp: int
    fn: int
    tn: int


def _read(path: Path, flags: int) -> np.ndarray:
    import cv2

    image = cv2.imread(str(path), flags)
    if image is None:
        raise FileNotFoundError(f"cannot read {path}")
    return image


def load_cdnet(path: str | Path = CDNET_DIR, first: int = 1, last: int | None = None) -> CDnetVideo:
    """Frames `first`..`last` (1-based, inclusive; default all) of a CDnet sequence folder, with their
    ground truth, the spatial ROI and the temporal ROI. FileNotFoundError naming the folder when it (or
    one of its files) is missing; ValueError for a range outside the sequence."""
    import cv2

    root = Path(path)
    inputs = root / "input"
    if not inputs.is_dir():
        raise FileNotFoundError(f"no CDnet sequence at {root} (expected {inputs}/in%06d.jpg); the data lives in "
                                "../shared/data/cdnet_highway, see ../shared/data/README.md")
    n_total = len(list(inputs.glob("in*.jpg")))
    last = n_total if last is None else last
    if not 1 <= first <= last <= n_total:
        raise ValueError(f"first, last: expected 1 <= first <= last <= {n_total}, got {first}, {last}")
    numbers = np.arange(first, last + 1)

    def frame(i):
        return cv2.cvtColor(_read(inputs / f"in{i:06d}.jpg", cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)

    def label(i):  # palette PNGs with an identity grey palette: the grey value is the label
        return _read(root / "groundtruth" / f"gt{i:06d}.png", cv2.IMREAD_GRAYSCALE)

    with ThreadPoolExecutor(max_workers=4) as pool:  # OpenCV decodes without the GIL
        frames = np.stack(list(pool.map(frame, numbers)))
        truth = np.stack(list(pool.map(label, numbers)))
    roi_file = root / "ROI.bmp"
    roi = _read(roi_file, cv2.IMREAD_GRAYSCALE) > 0 if roi_file.exists() else np.ones(frames.shape[1:3], bool)
    temporal = (1, n_total)
    if (root / "temporalROI.txt").exists():
        a, b = (int(v) for v in (root / "temporalROI.txt").read_text().split()[:2])
        temporal = (a, b)
    return CDnetVideo(frames, truth, roi, numbers, temporal)


def score_cdnet(pred_masks, groundtruth, roi=None) -> CDnetScore:
    """CDnet's pooled scores of predicted foreground masks (T, H, W) bool against label images (T, H, W)
    (see the module docstring), optionally restricted to a spatial ROI (H, W) bool. ValueError naming
    the argument for shapes that disagree, non-boolean masks or labels outside {0, 50, 85, 170, 255}."""
    pred = as_array(pred_masks, "pred_masks", ndim=3, dtype=None)
    gt = as_array(groundtruth, "groundtruth", ndim=3, dtype=None)
    if pred.shape != gt.shape:
        raise ValueError(f"pred_masks: shape {pred.shape} differs from groundtruth's {gt.shape}")
    if pred.dtype != bool and not np.all((pred == 0) | (pred == 1)):
        raise ValueError("pred_masks: expected boolean masks (or 0/1)")
    if not np.all(np.isin(gt, (FOREGROUND, *BACKGROUND, *IGNORED))):
        raise ValueError(f"groundtruth: labels must be in {(FOREGROUND, *BACKGROUND, *IGNORED)}, got "
                         f"{sorted(set(np.unique(gt).tolist()) - {FOREGROUND, *BACKGROUND, *IGNORED})}")
    pred = pred.astype(bool)
    valid = ~np.isin(gt, IGNORED)
    if roi is not None:
        roi = as_array(roi, "roi", shape=gt.shape[1:], dtype=None).astype(bool)
        valid &= roi[None]
    fg = gt == FOREGROUND
    tp = int(np.count_nonzero(pred & fg & valid))
    fp = int(np.count_nonzero(pred & ~fg & valid))
    fn = int(np.count_nonzero(~pred & fg & valid))
    tn = int(np.count_nonzero(~pred & ~fg & valid))
    precision = tp / (tp + fp) if tp + fp else 0.0
    recall = tp / (tp + fn) if tp + fn else 0.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall else 0.0
    return CDnetScore(precision, recall, f1, tp, fp, fn, tn)
