"""Pictures of recordings for people: label maps over the frames, grey frames, video files.

The label colours follow the simulated recordings' ground-truth code (0 background, 1 person, 2 hand
skin, 3 face skin, 4 object, ...); `truth_coded` maps the labels of `hog_jax.video`'s segmentation into
that code, so that truth and result are drawn alike.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from lfd_common import as_array, check_real

# colour of each label value (background: none)
LABEL_COLOURS = np.array([[0, 0, 0], [255, 140, 0], [230, 25, 40], [255, 225, 25], [0, 110, 255], [40, 200, 60],
                          [220, 40, 220]], np.uint8)


_LUMA = np.array([0.299, 0.587, 0.114], np.float32)  # ITU-R BT.601, as cv2.COLOR_RGB2GRAY


_LUMA = np.array([0.299, 0.587, 0.114], np.float32)  # ITU-R BT.601, as cv2.COLOR_RGB2GRAY

# hog_jax.video's labels (-1 none, 0 background, 1 person, 2 skin, 3 object) in the ground truth's colour
# code (0 background, 1 person, 2 hand skin, 3 face skin, 4 object)
_AS_TRUTH = np.array([0, 0, 1, 2, 4], np.uint8)


def grey(frames) -> np.ndarray:
    """Grey frames, with OpenCV's weights (ITU-R BT.601), rounded.

    Args:
        frames: (T, H, W, 3) uint8 RGB.

    Returns:
        (T, H, W) uint8.

    Raises:
        ValueError: naming `frames` for another shape or dtype.
    """
    arr = _frames(frames, "frames")
    return np.clip(np.rint(arr.astype(np.float32) @ _LUMA), 0, 255).astype(np.uint8)


def _frames(frames, name: str) -> np.ndarray:
    arr = np.asarray(frames)
    if arr.ndim != 4 or arr.shape[-1] != 3 or arr.dtype != np.uint8 or arr.shape[0] == 0:
        raise ValueError(f"{name}: expected (T, H, W, 3) uint8 frames, T > 0, got {arr.dtype} {arr.shape}")
    return arr


def truth_coded(labels) -> np.ndarray:
    """`hog_jax.video` labels in the colour code of `LABEL_COLOURS` (skin drawn as hand skin).

    Args:
        labels: integer label maps of any shape, values -1 (none), 0 background, 1 person, 2 skin, 3 object.

    Returns:
        uint8 array of the same shape in the ground truth's code.

    Raises:
        ValueError: naming `labels` for values outside -1..3.
    """
    labels = np.asarray(labels)
    if labels.size and (labels.min() < -1 or labels.max() > 3):
        raise ValueError(f"labels: expected values in -1..3, got {labels.min()}..{labels.max()}")
    return _AS_TRUTH[labels + 1]


def overlay(frames, labels, alpha: float = 0.5) -> np.ndarray:
    """Frames with every non-background label tinted in its `LABEL_COLOURS` colour and outlined.

    Args:
        frames: (T, H, W, 3) uint8 RGB.
        labels: (T, H, W) integer labels in the code of `LABEL_COLOURS` (`truth_coded` converts
            `hog_jax.video`'s labels).
        alpha: the weight of the tint, in [0, 1].

    Returns:
        (T, H, W, 3) uint8.

    Raises:
        ValueError: naming the argument for a bad shape, dtype or range.
    """
    import cv2

    frames = _frames(frames, "frames")
    labels = as_array(labels, "labels", shape=frames.shape[:3], dtype=np.int64, min_value=0,
                      max_value=len(LABEL_COLOURS) - 1)
    alpha = check_real(alpha, "alpha", min_value=0.0, max_value=1.0)
    colour = LABEL_COLOURS[labels].astype(np.float32)
    mask = (labels > 0)[..., None]
    out = np.where(mask, (1 - alpha) * frames + alpha * colour, frames)
    kernel = np.ones((3, 3), np.uint8)
    for t in range(len(labels)):  # outlines: pixels whose 3 x 3 neighbourhood has another label
        lab = labels[t].astype(np.uint8)
        edge = (cv2.dilate(lab, kernel) != cv2.erode(lab, kernel)) & (lab > 0)
        out[t][edge] = LABEL_COLOURS[lab[edge]]
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


class VideoWriter:
    """Frames written chunk by chunk to an MP4 file (OpenCV, codec 'mp4v'), so that a long overlay never
    sits in memory; a GIF (Pillow) where OpenCV cannot write MP4 (that fallback keeps the frames until
    `close`). A context manager: `with VideoWriter(path, fps) as out: out.write(chunk)`; `out.path` is
    the file written once closed.

    Args:
        path: the file; its suffix becomes .mp4 (.gif for the fallback).
        fps: frames per second, in [0.1, 240].

    Raises:
        ValueError: naming the argument for a bad frame rate, or frames of the wrong shape, dtype or
            size (`write`).
    """

    def __init__(self, path, fps: float = 25.0):
        self.fps = check_real(fps, "fps", min_value=0.1, max_value=240.0)
        self.path = Path(path).with_suffix(".mp4")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer, self._size, self._kept = None, None, []

    def write(self, frames) -> None:
        """Append (t, H, W, 3) uint8 RGB frames (every chunk of one size H x W)."""
        import cv2

        frames = _frames(frames, "frames")
        size = frames.shape[1:3]
        if self._size is None:
            self._size = size
            h, w = size
            writer = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*"mp4v"), self.fps, (w, h))
            self._writer = writer if writer.isOpened() else None
        elif size != self._size:
            raise ValueError(f"frames: expected frames of {self._size}, got {size}")
        if self._writer is None:
            self._kept.extend(frames)
            return
        for frame in frames:
            self._writer.write(np.ascontiguousarray(frame[..., ::-1]))

    def close(self) -> Path:
        """Finish the file; returns its path (.gif for the fallback)."""
        if self._writer is not None:
            self._writer.release()
            self._writer = None
        if self._kept:
            from PIL import Image

            self.path = self.path.with_suffix(".gif")
            images = [Image.fromarray(f) for f in self._kept]
            images[0].save(self.path, save_all=True, append_images=images[1:], duration=int(round(1000 / self.fps)),
                           loop=0)
            self._kept = []
        return self.path

    def __enter__(self) -> "VideoWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def write_video(frames, path, fps: float = 25.0) -> Path:
    """Frames as an MP4 file (OpenCV, codec 'mp4v'), or a GIF (Pillow) where OpenCV cannot write MP4
    (`VideoWriter` in one chunk).

    Args:
        frames: (T, H, W, 3) uint8 RGB.
        path: the file; its suffix becomes .mp4 (.gif for the fallback).
        fps: frames per second, in [0.1, 240].

    Returns:
        The path written.

    Raises:
        ValueError: naming the argument for bad frames or frame rate.
    """
    frames = _frames(frames, "frames")
    with VideoWriter(path, fps) as out:
        out.write(frames)
    return out.path
