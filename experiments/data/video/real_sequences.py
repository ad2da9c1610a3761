"""Real fixed-camera video with per-frame foreground truth, read one frame at a time, and its scoring.

Sequences (`SEQUENCES`, names -> folders under the data root, `DATA_DIR` = ../shared/data from the
project root; see ../shared/data/README.md):

* CDnet 2012/2014 (Goyette et al., CVPRW 2012; Wang et al., CVPRW 2014): `cdnet_highway`,
  `cdnet_pedestrians`. `input/in%06d.jpg` numbered from 1, `groundtruth/gt%06d.png` with 0 static
  background, 50 hard shadow, 85 outside the region of interest, 170 unknown motion, 255 foreground;
  `temporalROI.txt` (the evaluated frame numbers, inclusive) and `ROI.bmp` (white = evaluated).
* SBI 2015 (Maddalena & Petrosino, ICIAP 2015 workshops; masks of Wang, Luo & Jodoin, PRL 2017):
  `sbi_candela`, `sbi_hall_and_monitor`, `sbi_board`, `sbi_human_body2` (folders
  `sbi_indoor/{Candela_m1.10,HallAndMonitor,Board,HumanBody2}`): frames numbered from 0, 255
  foreground, 0 background, 170 unknown; one mask coded 0/1 (1 foreground); people in view from the
  first frame.

Truth (`iter_sequence`) is int8 per pixel: 1 foreground (255, or 1 in a mask coded 0/1), 0 background
(0 and CDnet's hard shadow 50), -1 ignored (85, 170 and pixels outside `ROI.bmp`), CDnet's convention.
`f1_counts` pools TP, FP, FN, TN over the scored pixels; precision = TP / (TP + FP), recall = TP / (TP +
FN), F1 = 2 P R / (P + R), each 0 when its denominator is 0 (`Counts`, which add up over frames).

Frames are read lazily (a generator): a long recording never sits in memory as one array.
"""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

__all__ = ["Counts", "DATA_DIR", "SEQUENCES", "SequenceInfo", "f1_counts", "iter_sequence", "read_truth",
           "sequence_info"]

DATA_DIR = "../shared/data"  # relative to the project root, as the experiments run
SEQUENCES = {
    "cdnet_highway": "cdnet_highway",
    "cdnet_pedestrians": "cdnet_pedestrians",
    "sbi_candela": "sbi_indoor/Candela_m1.10",
    "sbi_hall_and_monitor": "sbi_indoor/HallAndMonitor",
    "sbi_board": "sbi_indoor/Board",
    "sbi_human_body2": "sbi_indoor/HumanBody2",
}
_FOREGROUND, _BACKGROUND, _IGNORED = (255,), (0, 50), (85, 170)


class SequenceInfo(NamedTuple):
    """What a sequence folder holds.

    Attributes:
        path: the folder.
        numbers: (T,) the frame numbers in file order (`in%06d.jpg`).
        temporal_roi: (first, last), the evaluated frame numbers, inclusive (all without
            `temporalROI.txt`).
        roi: (H, W) bool, the evaluated pixels (all without `ROI.bmp`).
    """

    path: Path
    numbers: np.ndarray
    temporal_roi: tuple[int, int]
    roi: np.ndarray

    def evaluated(self) -> np.ndarray:
        """(T,) bool: the frames inside the temporal ROI."""
        first, last = self.temporal_roi
        return (self.numbers >= first) & (self.numbers <= last)


class Counts(NamedTuple):
    """Pooled pixel counts of a foreground prediction; `+` adds two counts.

    Attributes:
        tp, fp, fn, tn: true / false positives, false negatives, true negatives.
    """

    tp: int = 0
    fp: int = 0
    fn: int = 0
    tn: int = 0

    def __add__(self, other):  # type: ignore[override]
        return Counts(*(a + b for a, b in zip(self, other)))

    @property
    def precision(self) -> float:
        """TP / (TP + FP), 0 when nothing was predicted."""
        return self.tp / (self.tp + self.fp) if self.tp + self.fp else 0.0

    @property
    def recall(self) -> float:
        """TP / (TP + FN), 0 when nothing is true."""
        return self.tp / (self.tp + self.fn) if self.tp + self.fn else 0.0

    @property
    def f1(self) -> float:
        """2 P R / (P + R), 0 when P + R = 0."""
        p, r = self.precision, self.recall
        return 2 * p * r / (p + r) if p + r else 0.0


def _folder(root: str | Path, name: str) -> Path:
    if name in SEQUENCES:
        folder = Path(root) / SEQUENCES[name]
    elif (Path(root) / name / "input").is_dir():
        folder = Path(root) / name
    else:
        raise ValueError(f"name: expected one of {sorted(SEQUENCES)} or a folder under root, got {name!r}")
    if not (folder / "input").is_dir():
        raise FileNotFoundError(f"no sequence at {folder} (expected {folder / 'input'}/in%06d.jpg); the real data "
                                f"lives in {DATA_DIR}, see its README.md")
    return folder


def _read(path: Path, flags: int) -> np.ndarray:
    import cv2

    image = cv2.imread(str(path), flags)
    if image is None:
        raise FileNotFoundError(f"cannot read {path}")
    return image


def sequence_info(root: str | Path, name: str) -> SequenceInfo:
    """The frame numbers, temporal and spatial ROI of a sequence.

    Args:
        root: the data root (`DATA_DIR` from the project root).
        name: a key of `SEQUENCES`, or a folder under `root` of the same layout.

    Returns:
        The `SequenceInfo`.

    Raises:
        ValueError: naming `name` when it is neither.
        FileNotFoundError: naming the folder when it has no `input/`.
    """
    import cv2

    folder = _folder(root, name)
    numbers = np.array(sorted(int(p.stem[2:]) for p in (folder / "input").glob("in*.jpg")), np.int64)
    if numbers.size == 0:
        raise FileNotFoundError(f"no frames in {folder / 'input'}")
    temporal = (int(numbers[0]), int(numbers[-1]))
    if (folder / "temporalROI.txt").exists():
        a, b = (int(v) for v in (folder / "temporalROI.txt").read_text().split()[:2])
        temporal = (a, b)
    first = _read(folder / "input" / f"in{numbers[0]:06d}.jpg", cv2.IMREAD_COLOR)
    roi_file = folder / "ROI.bmp"
    roi = _read(roi_file, cv2.IMREAD_GRAYSCALE) > 0 if roi_file.exists() else np.ones(first.shape[:2], bool)
    if roi.shape != first.shape[:2]:
        raise ValueError(f"name: {roi_file} is {roi.shape}, the frames {first.shape[:2]}")
    return SequenceInfo(folder, numbers, temporal, roi)


def read_truth(labels: np.ndarray, roi: np.ndarray | None = None) -> np.ndarray:
    """A ground-truth label image as int8 truth: 1 foreground, 0 background, -1 ignored.

    255 is foreground, 0 and 50 (CDnet's hard shadow) background, 85 and 170 ignored; a mask whose
    values are all in {0, 1} is coded 0/1 (1 foreground, SBI's HallAndMonitor frame 0); pixels outside
    `roi` are ignored.

    Args:
        labels: (H, W) uint8 label image.
        roi: (H, W) bool, or None for every pixel.

    Returns:
        (H, W) int8 truth.

    Raises:
        ValueError: naming `labels` for values outside {0, 50, 85, 170, 255} (or not a 0/1 mask),
            naming `roi` for another shape.
    """
    labels = np.asarray(labels)
    if labels.ndim != 2:
        raise ValueError(f"labels: expected an (H, W) label image, got shape {labels.shape}")
    if labels.max(initial=0) <= 1:
        truth = labels.astype(np.int8)
    else:
        bad = ~np.isin(labels, _FOREGROUND + _BACKGROUND + _IGNORED)
        if bad.any():
            raise ValueError(f"labels: values must be in {_FOREGROUND + _BACKGROUND + _IGNORED}, got "
                             f"{sorted(set(np.unique(labels[bad]).tolist()))}")
        truth = np.where(labels == 255, 1, np.where(np.isin(labels, _IGNORED), -1, 0)).astype(np.int8)
    if roi is not None:
        roi = np.asarray(roi, bool)
        if roi.shape != labels.shape:
            raise ValueError(f"roi: expected shape {labels.shape}, got {roi.shape}")
        truth[~roi] = -1
    return truth


def iter_sequence(root: str | Path, name: str, step: int = 1, stop: int | None = None
                  ) -> Iterator[tuple[int, np.ndarray, np.ndarray | None]]:
    """Yield every frame of a sequence in order, with its truth on the scored frames.

    Args:
        root: the data root (`DATA_DIR` from the project root).
        name: a key of `SEQUENCES`, or a folder under `root` of the same layout.
        step: truth on every `step`-th evaluated frame (counted from the temporal ROI's first), None
            on the others; every frame is yielded all the same (a model must see them all), >= 1.
        stop: yield only the first `stop` frames, or None for all.

    Yields:
        (frame number, RGB frame (H, W, 3) uint8, truth (H, W) int8 in {1, 0, -1} (`read_truth`, ROI
        applied) or None outside the scored frames).

    Raises:
        ValueError: naming the argument for an unknown name, step < 1, stop < 0, a label image with
            unknown values or frames of different sizes.
        FileNotFoundError: naming the folder or file that is missing.
    """
    import cv2

    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise ValueError(f"step: expected an int >= 1, got {step!r}")
    if stop is not None and (isinstance(stop, bool) or not isinstance(stop, (int, np.integer)) or stop < 0):
        raise ValueError(f"stop: expected an int >= 0 or None, got {stop!r}")
    info = sequence_info(root, name)
    first, last = info.temporal_roi
    for number in info.numbers[:stop]:
        frame = cv2.cvtColor(_read(info.path / "input" / f"in{number:06d}.jpg", cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
        if frame.shape[:2] != info.roi.shape:
            raise ValueError(f"name: frame {number} is {frame.shape[:2]}, the first {info.roi.shape}")
        truth = None
        if first <= number <= last and (number - first) % step == 0:
            labels = _read(info.path / "groundtruth" / f"gt{number:06d}.png", cv2.IMREAD_GRAYSCALE)
            truth = read_truth(labels, info.roi)
        yield int(number), frame, truth


def f1_counts(pred, truth) -> Counts:
    """TP, FP, FN, TN of a foreground prediction against int8 truth, ignored pixels (-1) left out.

    Args:
        pred: (..., H, W) bool (or 0/1) foreground.
        truth: the same shape, int8 in {1, 0, -1} (`iter_sequence`).

    Returns:
        The `Counts` (precision, recall and F1 as its properties).

    Raises:
        ValueError: naming the argument for shapes that differ, a non-boolean prediction or truth
            outside {1, 0, -1}.
    """
    p = np.asarray(pred)
    t = np.asarray(truth)
    if p.shape != t.shape:
        raise ValueError(f"pred: shape {p.shape} differs from truth's {t.shape}")
    if p.dtype != bool and not np.all((p == 0) | (p == 1)):
        raise ValueError("pred: expected a boolean mask (or 0/1)")
    if not np.all((t == 1) | (t == 0) | (t == -1)):
        raise ValueError("truth: expected values in {1, 0, -1}")
    p = p.astype(bool)
    fg, bg = t == 1, t == 0
    return Counts(int(np.sum(p & fg)), int(np.sum(p & bg)), int(np.sum(~p & fg)), int(np.sum(~p & bg)))
