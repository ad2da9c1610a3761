"""The real reach clip (`../shared/data/reach_grasp/teaser_movement.gif`: 58 frames of 260 x 238 at
10 fps, a seated person reaches for a cube and moves it to the right; Dagioglou et al., HCII 2022) and
the project's own boxes of face, hands and cube on eight of its frames, to score tracks against.

The clip carries no ground truth. `reach_clip_boxes.csv` beside this module holds boxes drawn by eye on
a 2x grid of the frames 0, 10, 20, 26, 32, 40, 50 and 57 (about 3 px uncertain): `face` the visible
head (hair, forehead and the mask: the camera looks down on it), `right_hand` the person's right hand
(on the image's left; the hand that reaches), `left_hand` (resting on the table all along), `cube`.
Inclusive pixel coordinates x0, y0, x1, y1, origin top-left.

Scoring (`score_tracks`): a tracked point is on its part when it lies in the part's box grown by
`margin` pixels on every side; a frame where the part is not tracked counts as a miss.
"""
from __future__ import annotations

import csv
from pathlib import Path
from typing import NamedTuple

import numpy as np

CLIP = "reach_grasp/teaser_movement.gif"  # under the data folder (../shared/data)
BOXES_FILE = Path(__file__).with_name("reach_clip_boxes.csv")
PARTS = ("face", "right_hand", "left_hand", "cube")


class ClipBoxes(NamedTuple):
    """frames (F,) the annotated frame indices; boxes (F, len(PARTS), 4) x0, y0, x1, y1 in pixels."""

    frames: np.ndarray
    boxes: np.ndarray


def clip_boxes(path: str | Path = BOXES_FILE) -> ClipBoxes:
    """The annotated boxes (`ClipBoxes`), every part on every annotated frame.

    Raises:
        ValueError: naming the path for a missing column, an unknown part or a frame without every part.
    """
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    frames = sorted({int(r["frame"]) for r in rows})
    boxes = np.full((len(frames), len(PARTS), 4), np.nan)
    for r in rows:
        if r["part"] not in PARTS:
            raise ValueError(f"{path}: unknown part {r['part']!r}; expected one of {PARTS}")
        boxes[frames.index(int(r["frame"])), PARTS.index(r["part"])] = [float(r[k]) for k in ("x0", "y0", "x1", "y1")]
    if np.isnan(boxes).any():
        raise ValueError(f"{path}: every annotated frame needs a box for each of {PARTS}")
    return ClipBoxes(np.asarray(frames), boxes)


def on_box(points: np.ndarray, boxes: np.ndarray, margin: float) -> np.ndarray:
    """(...,) bool: each (x, y) point of `points` (..., 2) inside its box (..., 4) grown by `margin`;
    False for a NaN point."""
    x, y = points[..., 0], points[..., 1]
    with np.errstate(invalid="ignore"):
        return ((x >= boxes[..., 0] - margin) & (x <= boxes[..., 2] + margin)
                & (y >= boxes[..., 1] - margin) & (y <= boxes[..., 3] + margin))


def score_tracks(positions: dict[str, np.ndarray], annotated: ClipBoxes, margin: float = 4.0) -> dict:
    """Per tracked part: the share of annotated frames on which the track is on the part, and the median
    distance from the box centre (NaN where never tracked).

    Args:
        positions: part name (of `PARTS`) -> (T, 2) the tracked (x, y) pixels per frame, NaN where the
            part is not tracked.
        annotated: the `ClipBoxes`.
        margin: pixels the boxes grow by on every side.

    Returns:
        {part: {"on_part": share, "centre_distance_px": median, "frames": F}}.
    """
    out = {}
    for part, xy in positions.items():
        box = annotated.boxes[:, PARTS.index(part)]
        point = np.asarray(xy, float)[annotated.frames]
        centre = np.stack([(box[:, 0] + box[:, 2]) / 2, (box[:, 1] + box[:, 3]) / 2], axis=-1)
        distance = np.linalg.norm(point - centre, axis=-1)
        out[part] = {"on_part": float(on_box(point, box, margin).mean()),
                     "centre_distance_px": float(np.nanmedian(distance)) if np.isfinite(distance).any() else float("nan"),
                     "frames": int(len(annotated.frames))}
    return out
