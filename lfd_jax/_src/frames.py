"""Images and video into the frames format of `hog_jax` (`hog_jax.video.segment_recording`,
`segment_stereo`, `hog_jax.background.run_background`): (T, H, W, 3) uint8 RGB.

* `load_image_folder`: every image of a folder (sorted by name) as one clip; all of one size.
* `load_video`: a video file through OpenCV's `VideoCapture`, BGR converted to RGB.
* `load_stereo_videos`: a left and a right video of the same length and frame size.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from lfd_common import check_int

__all__ = ["IMAGE_SUFFIXES", "StereoFrames", "VideoFrames", "load_image_folder", "load_stereo_videos", "load_video"]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm")


class VideoFrames(NamedTuple):
    """The frames of one clip.

    Attributes:
        frames: (T, H, W, 3) uint8 RGB.
        rate_hz: the frame rate (None where the source gives none).
    """

    frames: np.ndarray
    rate_hz: float | None


class StereoFrames(NamedTuple):
    """The frames of a stereo pair.

    Attributes:
        left: (T, H, W, 3) uint8 RGB.
        right: (T, H, W, 3) uint8 RGB, the shape of `left`.
        rate_hz: the left video's frame rate (None where it states none).
    """

    left: np.ndarray
    right: np.ndarray
    rate_hz: float | None


def _to_rgb(image: np.ndarray, source: Path) -> np.ndarray:
    import cv2

    if image.dtype == np.uint16:  # 16-bit PNG/TIFF: rounded to 8 bits
        image = ((image.astype(np.uint32) + 128) // 257).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise ValueError(f"path: {source} has {image.dtype} pixels; expected 8- or 16-bit images")
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def _max_frames(max_frames: int | None) -> int | None:
    return None if max_frames is None else check_int(max_frames, "max_frames", min_value=1)


def load_image_folder(path, max_frames: int | None = None, rate_hz: float | None = None) -> VideoFrames:
    """The images of a folder as one clip, sorted by file name.

    Args:
        path: the folder; its files with a suffix in `IMAGE_SUFFIXES` are read (16-bit images rounded
            to 8 bits, grey and RGBA converted to RGB).
        max_frames: read at most this many images (None: all).
        rate_hz: the frame rate to record (the folder states none).

    Returns:
        `VideoFrames`.

    Raises:
        ValueError: naming `path` for a missing folder, a folder without images, an unreadable image,
            or images of different sizes; naming `max_frames` for a value below 1.
    """
    import cv2

    root = Path(path)
    if not root.is_dir():
        raise ValueError(f"path: no such folder {root}")
    files = sorted(p for p in root.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise ValueError(f"path: {root} holds no image ({', '.join(IMAGE_SUFFIXES)})")
    limit = _max_frames(max_frames)
    frames = []
    for file in files[:limit]:
        image = cv2.imread(str(file), cv2.IMREAD_UNCHANGED)
        if image is None:
            raise ValueError(f"path: cannot read the image {file}")
        frames.append(_to_rgb(image, file))
        if frames[-1].shape != frames[0].shape:
            raise ValueError(f"path: {file.name} is {frames[-1].shape[1]}x{frames[-1].shape[0]} pixels, "
                             f"{files[0].name} {frames[0].shape[1]}x{frames[0].shape[0]}; a clip needs one size")
    return VideoFrames(np.stack(frames), rate_hz)


def load_video(path, max_frames: int | None = None, name: str = "path") -> VideoFrames:
    """The frames of a video file, read by OpenCV's `VideoCapture`, as RGB.

    Args:
        path: the video file.
        max_frames: read at most this many frames (None: all).
        name: the argument's name in error messages.

    Returns:
        `VideoFrames` with the container's frame rate (None when it states none).

    Raises:
        ValueError: naming `name` for a missing file or one OpenCV cannot decode a frame of.
    """
    import cv2

    file = Path(path)
    if not file.is_file():
        raise ValueError(f"{name}: no such file {file}")
    limit = _max_frames(max_frames)
    capture = cv2.VideoCapture(str(file))
    try:
        if not capture.isOpened():
            raise ValueError(f"{name}: OpenCV cannot open {file} as a video")
        rate = float(capture.get(cv2.CAP_PROP_FPS))
        frames = []
        while limit is None or len(frames) < limit:
            ok, frame = capture.read()
            if not ok:
                break
            frames.append(_to_rgb(frame, file))
    finally:
        capture.release()
    if not frames:
        raise ValueError(f"{name}: {file} has no frame OpenCV can decode")
    return VideoFrames(np.stack(frames), rate if np.isfinite(rate) and rate > 0 else None)


def load_stereo_videos(left, right, max_frames: int | None = None) -> StereoFrames:
    """A stereo pair of video files, frame by frame (`load_video` for each).

    Args:
        left: the left video file.
        right: the right video file.
        max_frames: read at most this many frames of each (None: all).

    Returns:
        `StereoFrames`.

    Raises:
        ValueError: naming `left` or `right` for a file that cannot be read, and `right` when its
            number of frames or frame size differs from the left video's.
    """
    a = load_video(left, max_frames, name="left")
    b = load_video(right, max_frames, name="right")
    if a.frames.shape[1:] != b.frames.shape[1:]:
        raise ValueError(f"right: frames of {b.frames.shape[2]}x{b.frames.shape[1]} pixels, the left video's "
                         f"are {a.frames.shape[2]}x{a.frames.shape[1]}")
    if len(a.frames) != len(b.frames):
        raise ValueError(f"right: {len(b.frames)} frames, the left video has {len(a.frames)}")
    return StereoFrames(a.frames, b.frames, a.rate_hz)
