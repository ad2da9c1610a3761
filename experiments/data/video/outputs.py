"""Pictures of recordings: the label map over the frames, contact sheets, video files."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from lfd_common import as_array, check_int, check_real
from experiments.data.video.settings import LABELS

# colour of each label value (background: none)
LABEL_COLOURS = np.array([[0, 0, 0], [255, 140, 0], [230, 25, 40], [255, 225, 25], [0, 110, 255], [40, 200, 60],
                          [220, 40, 220]], np.uint8)


_LUMA = np.array([0.299, 0.587, 0.114], np.float32)  # ITU-R BT.601, as cv2.COLOR_RGB2GRAY


def grey(frames) -> np.ndarray:
    """(T, H, W, 3) uint8 RGB -> (T, H, W) uint8 grey (OpenCV's weights, rounded)."""
    arr = _frames(frames, "frames")
    return np.clip(np.rint(arr.astype(np.float32) @ _LUMA), 0, 255).astype(np.uint8)


def _frames(frames, name: str) -> np.ndarray:
    arr = np.asarray(frames)
    if arr.ndim != 4 or arr.shape[-1] != 3 or arr.dtype != np.uint8 or arr.shape[0] == 0:
        raise ValueError(f"{name}: expected (T, H, W, 3) uint8 frames, T > 0, got {arr.dtype} {arr.shape}")
    return arr


def overlay(frames, labels, alpha: float = 0.5) -> np.ndarray:
    """Frames (T, H, W, 3) uint8 with every non-background label (T, H, W) tinted in its
    `LABEL_COLOURS` colour (weight `alpha`) and outlined."""
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


def contact_sheet(frames, labels, path, titles=None, cols: int = 6, alpha: float = 0.5) -> Path:
    """A PNG grid of frames (N, H, W, 3) uint8 with their label maps (N, H, W) overlaid, a legend of
    the labels; `titles` (N,) optional captions. Returns the path written."""
    from experiments.plotting import plt

    images = overlay(frames, labels, alpha)
    cols = check_int(cols, "cols", min_value=1, max_value=50)
    if titles is not None and len(titles) != len(images):
        raise ValueError(f"titles: expected {len(images)} captions, got {len(titles)}")
    n = len(images)
    rows = -(-n // cols)
    h, w = images.shape[1:3]
    fig, axes = plt.subplots(rows, min(cols, n), figsize=(2.6 * min(cols, n), 2.6 * rows * h / w + 0.6), squeeze=False)
    for i, ax in enumerate(axes.ravel()):
        ax.axis("off")
        if i < n:
            ax.imshow(images[i], interpolation="nearest")
            if titles is not None:
                ax.set_title(str(titles[i]), fontsize=8)
    handles = [plt.Rectangle((0, 0), 1, 1, color=LABEL_COLOURS[k] / 255) for k in range(1, len(LABELS))]
    fig.legend(handles, LABELS[1:], loc="lower center", ncol=len(LABELS) - 1, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def write_video(frames, path, fps: float = 25.0) -> Path:
    """Frames (T, H, W, 3) uint8 RGB as an MP4 (OpenCV, codec 'mp4v'); where OpenCV cannot write MP4,
    a GIF (Pillow) next to it (same name, suffix .gif). Returns the path written."""
    import cv2

    frames = _frames(frames, "frames")
    fps = check_real(fps, "fps", min_value=0.1, max_value=240.0)
    path = Path(path).with_suffix(".mp4")
    path.parent.mkdir(parents=True, exist_ok=True)
    h, w = frames.shape[1:3]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    try:
        if writer.isOpened():
            for frame in frames:
                writer.write(np.ascontiguousarray(frame[..., ::-1]))
    finally:
        writer.release()
    if path.exists() and path.stat().st_size > 0:
        return path
    from PIL import Image

    gif = path.with_suffix(".gif")
    images = [Image.fromarray(f) for f in frames]
    images[0].save(gif, save_all=True, append_images=images[1:], duration=int(round(1000 / fps)), loop=0)
    return gif
