"""Pictures of recordings: contact sheets of label maps over frames (the overlay, grey frames and video
files are `lfd_jax`'s)."""
from __future__ import annotations

from pathlib import Path

from experiments.data.video.settings import LABELS
from lfd_common import check_int
from lfd_jax import LABEL_COLOURS, overlay


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
