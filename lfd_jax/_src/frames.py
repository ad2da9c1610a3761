"""Images and video into the frames format of `hog_jax` (`hog_jax.video.segment_recording`,
`segment_stereo`, `hog_jax.background.run_background`): (T, H, W, 3) uint8 RGB.

Streaming readers yield chunks of at most `chunk` frames, so that a long recording never sits in
memory as one array (a 10-minute 640 x 480 video at 25 fps is 14 GB of uint8 RGB):

* `iter_image_folder`: every image of a folder (sorted by name), all of one size.
* `iter_video`: a video file (or an animated GIF) through OpenCV's `VideoCapture`, BGR converted to
  RGB; PIL reads a GIF that OpenCV cannot open.
* `iter_stereo_videos`: a left and a right video of the same length and frame size, chunk by chunk.
* `video_info`: frame size, rate and count of a video file or an image folder without decoding it.

The whole-clip loaders `load_image_folder`, `load_video` and `load_stereo_videos` stack what the
iterators yield.
"""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from lfd_common import check_int

__all__ = ["IMAGE_SUFFIXES", "StereoFrames", "VideoFrames", "VideoInfo", "iter_image_folder", "iter_stereo_videos",
           "iter_video", "load_image_folder", "load_stereo_videos", "load_video", "video_info"]

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


class VideoInfo(NamedTuple):
    """What a video file or an image folder holds, read without decoding every frame (`video_info`).

    Attributes:
        height: H, pixels.
        width: W, pixels.
        rate_hz: the frame rate (None where the source states none).
        n_frames: the number of frames: exact for a folder, the container's count for a video file
            (None where it states none; some containers' counts are estimates).
    """

    height: int
    width: int
    rate_hz: float | None
    n_frames: int | None


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


def _rate(value: float) -> float | None:
    return float(value) if np.isfinite(value) and value > 0 else None


def _chunks(frames: Iterator[np.ndarray], chunk: int) -> Iterator[np.ndarray]:
    """Stack consecutive frames into arrays of `chunk` frames (the last may be shorter)."""
    buffer = []
    for frame in frames:
        buffer.append(frame)
        if len(buffer) == chunk:
            yield np.stack(buffer)
            buffer = []
    if buffer:
        yield np.stack(buffer)


def _folder_files(path) -> tuple[Path, list[Path]]:
    root = Path(path)
    if not root.is_dir():
        raise ValueError(f"path: no such folder {root}")
    files = sorted(p for p in root.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise ValueError(f"path: {root} holds no image ({', '.join(IMAGE_SUFFIXES)})")
    return root, files


def _read_image(file: Path) -> np.ndarray:
    import cv2

    image = cv2.imread(str(file), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ValueError(f"path: cannot read the image {file}")
    return _to_rgb(image, file)


def iter_image_folder(path, chunk: int = 32, max_frames: int | None = None) -> Iterator[np.ndarray]:
    """The images of a folder, sorted by file name, in chunks of frames.

    The folder is listed when called; each image is read when its chunk is reached.

    Args:
        path: the folder; its files with a suffix in `IMAGE_SUFFIXES` are read (16-bit images rounded
            to 8 bits, grey and RGBA converted to RGB).
        chunk: the most frames per yielded array, >= 1.
        max_frames: read at most this many images (None: all).

    Returns:
        An iterator of (t, H, W, 3) uint8 RGB arrays, 1 <= t <= chunk (only the last shorter).

    Raises:
        ValueError: naming `path` for a missing folder or a folder without images (when called), an
            unreadable image or images of different sizes (when reached); naming `chunk` or
            `max_frames` for a value below 1.
    """
    chunk = check_int(chunk, "chunk", min_value=1)
    limit = _max_frames(max_frames)
    _, files = _folder_files(path)
    files = files[:limit]

    def frames():
        first = None
        for file in files:
            image = _read_image(file)
            if first is None:
                first = (file, image.shape)
            elif image.shape != first[1]:
                raise ValueError(f"path: {file.name} is {image.shape[1]}x{image.shape[0]} pixels, "
                                 f"{first[0].name} {first[1][1]}x{first[1][0]}; a clip needs one size")
            yield image

    return _chunks(frames(), chunk)


def load_image_folder(path, max_frames: int | None = None, rate_hz: float | None = None) -> VideoFrames:
    """The images of a folder as one clip, sorted by file name (`iter_image_folder`, stacked).

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
    return VideoFrames(np.concatenate(list(iter_image_folder(path, 256, max_frames))), rate_hz)


def _is_gif(file: Path) -> bool:
    return file.suffix.lower() == ".gif"


def _pil_frames(file: Path) -> Iterator[np.ndarray]:
    """The frames of an animated GIF by PIL (each composed onto the previous, as a viewer shows them)."""
    from PIL import Image, ImageSequence

    with Image.open(file) as image:
        for frame in ImageSequence.Iterator(image):
            yield np.asarray(frame.convert("RGB"), np.uint8)


def _pil_info(file: Path) -> VideoInfo:
    from PIL import Image

    with Image.open(file) as image:
        duration = image.info.get("duration")
        return VideoInfo(image.height, image.width, _rate(1000.0 / duration) if duration else None,
                         int(getattr(image, "n_frames", 1)))


def _open_capture(file: Path, name: str):
    """An opened `cv2.VideoCapture` of `file`, or None for a GIF that OpenCV cannot open."""
    import cv2

    if not file.is_file():
        raise ValueError(f"{name}: no such file {file}")
    capture = cv2.VideoCapture(str(file))
    if capture.isOpened():
        return capture
    capture.release()
    if _is_gif(file):
        return None
    raise ValueError(f"{name}: OpenCV cannot open {file} as a video")


def video_info(path, name: str = "path") -> VideoInfo:
    """Frame size, rate and count of a video file (or animated GIF) or an image folder, without
    decoding the video (a folder's first image is read for its size).

    Args:
        path: a video file or a folder of images.
        name: the argument's name in error messages.

    Returns:
        `VideoInfo`.

    Raises:
        ValueError: naming `name` for a missing file or folder, a folder without images, or a file
            that neither OpenCV nor (for a GIF) PIL can open.
    """
    import cv2

    p = Path(path)
    if p.is_dir():
        _, files = _folder_files(p)
        image = _read_image(files[0])
        return VideoInfo(image.shape[0], image.shape[1], None, len(files))
    capture = _open_capture(p, name)
    if capture is None:
        try:
            return _pil_info(p)
        except OSError as error:
            raise ValueError(f"{name}: neither OpenCV nor PIL can open {p}: {error}") from None
    try:
        count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        return VideoInfo(int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)), int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)),
                         _rate(capture.get(cv2.CAP_PROP_FPS)), count if count > 0 else None)
    finally:
        capture.release()


def iter_video(path, chunk: int = 32, max_frames: int | None = None, name: str = "path") -> Iterator[np.ndarray]:
    """The frames of a video file (or an animated GIF) in chunks, decoded as they are needed, as RGB.

    OpenCV's `VideoCapture` decodes; a GIF that it cannot open is read by PIL. The file is opened when
    called (so that a missing or undecodable file fails at once); `video_info` gives the frame rate,
    size and count.

    Args:
        path: the video file.
        chunk: the most frames per yielded array, >= 1.
        max_frames: read at most this many frames (None: all).
        name: the argument's name in error messages.

    Returns:
        An iterator of (t, H, W, 3) uint8 RGB arrays, 1 <= t <= chunk (only the last shorter).

    Raises:
        ValueError: naming `name` for a missing file or one that cannot be opened (when called) or
            has no decodable frame (when iterated); naming `chunk` or `max_frames` for a value
            below 1.
    """
    chunk = check_int(chunk, "chunk", min_value=1)
    limit = _max_frames(max_frames)
    file = Path(path)
    capture = _open_capture(file, name)

    def frames():
        n = 0
        if capture is None:
            try:
                for frame in _pil_frames(file):
                    if limit is not None and n >= limit:
                        break
                    n += 1
                    yield frame
            except OSError as error:
                raise ValueError(f"{name}: PIL cannot read {file}: {error}") from None
        else:
            try:
                while limit is None or n < limit:
                    ok, frame = capture.read()
                    if not ok:
                        break
                    n += 1
                    yield _to_rgb(frame, file)
            finally:
                capture.release()
        if n == 0:
            raise ValueError(f"{name}: {file} has no frame OpenCV can decode")

    return _chunks(frames(), chunk)


def load_video(path, max_frames: int | None = None, name: str = "path") -> VideoFrames:
    """The frames of a video file (or an animated GIF) as RGB (`iter_video`, stacked).

    Args:
        path: the video file.
        max_frames: read at most this many frames (None: all).
        name: the argument's name in error messages.

    Returns:
        `VideoFrames` with the container's frame rate (None when it states none).

    Raises:
        ValueError: naming `name` for a missing file or one OpenCV cannot decode a frame of.
    """
    chunks = iter_video(path, 256, max_frames, name)
    frames = np.concatenate(list(chunks))
    return VideoFrames(frames, video_info(path, name).rate_hz)


def iter_stereo_videos(left, right, chunk: int = 32,
                       max_frames: int | None = None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """A stereo pair of video files, chunk by chunk (`iter_video` for each, in step).

    Args:
        left: the left video file.
        right: the right video file.
        chunk: the most frames per yielded pair, >= 1.
        max_frames: read at most this many frames of each (None: all).

    Returns:
        An iterator of (left (t, H, W, 3), right (t, H, W, 3)) uint8 RGB pairs.

    Raises:
        ValueError: naming `left` or `right` for a file that cannot be read, and `right` when its
            frame size (at the first chunk) or number of frames (when one ends before the other)
            differs from the left video's.
    """
    a = iter_video(left, chunk, max_frames, name="left")
    b = iter_video(right, chunk, max_frames, name="right")

    def pairs():
        n_left = n_right = 0
        for x in a:
            y = next(b, None)
            n_left += len(x)
            n_right += 0 if y is None else len(y)
            if y is not None and x.shape[1:] != y.shape[1:]:
                raise ValueError(f"right: frames of {y.shape[2]}x{y.shape[1]} pixels, the left video's "
                                 f"are {x.shape[2]}x{x.shape[1]}")
            if y is None or len(y) != len(x):
                n_left += sum(len(c) for c in a)
                n_right += sum(len(c) for c in b)
                raise ValueError(f"right: {n_right} frames, the left video has {n_left}")
            yield x, y
        rest = sum(len(c) for c in b)
        if rest:
            raise ValueError(f"right: {n_right + rest} frames, the left video has {n_left}")

    return pairs()


def load_stereo_videos(left, right, max_frames: int | None = None) -> StereoFrames:
    """A stereo pair of video files, frame by frame (`iter_stereo_videos`, stacked).

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
    pairs = list(iter_stereo_videos(left, right, 256, max_frames))
    return StereoFrames(np.concatenate([p[0] for p in pairs]), np.concatenate([p[1] for p in pairs]),
                        video_info(left, "left").rate_hz)
