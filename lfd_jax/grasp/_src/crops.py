"""The hand crops of camera frames (GRASP §III-A): skin segmentation seeded at the frame centre, the
segmented hand cropped square, grey times its mask, and the same box unmasked.

Shapes: N frames of H x W pixels, S x S crops.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

import hog_jax
from lfd_common import as_array, check_choice, check_int

ADAPTATIONS = ("none", "background", "both")


class Crops(NamedTuple):
    """The hand crops of N frames (GRASP §III-A).

    Attributes:
        images: (N, S, S) the grey crop times the hand mask (zero where no hand was found).
        masks: (N, S, S) bool, the hand mask.
        found: (N,) bool; False where no hand was found (the crop is zero).
        context: (N, S, S) the same boxes unmasked (`hog_jax.Segmentation.context`: the held object,
            the background).
    """

    images: np.ndarray
    masks: np.ndarray
    found: np.ndarray
    context: np.ndarray

    def take(self, rows) -> "Crops":
        """The crops of `rows`.

        Args:
            rows: an index, slice or boolean array over the N crops.

        Returns:
            A `Crops` of the selected rows.
        """
        return Crops(*(a[rows] for a in self))


def crops_of(seg) -> Crops:
    """A `hog_jax.Segmentation`'s crops as NumPy arrays.

    Args:
        seg: a `hog_jax.Segmentation` (from `hog_jax.segment` or `hog_jax.segment_adapted`).

    Returns:
        Its `Crops` (images, masks, found, context) as NumPy arrays.
    """
    return Crops(*(np.asarray(a) for a in (seg.images, seg.masks, seg.found, seg.context)))


def segment_frames(skin, frames: np.ndarray, crop_size: int, chunk: int = 64, adaptation: str = "none") -> Crops:
    """Skin segmentation of frames, seeded at the frame centre (where the camera aims) (GRASP §III-A).

    Args:
        skin: the skin model (`hog_jax.fit_skin_model`).
        frames: (N, H, W, 3) RGB frames, N >= 1.
        crop_size: S, the side of the square crops.
        chunk: frames per call (bounds the memory).
        adaptation: "none" (the global skin model), "background" or "both" (`hog_jax.segment_adapted`:
            the background mixture, or both mixtures, adapted to each frame; relevance 64 pixels, 5
            iterations, chosen on validation images by the skin mask's IoU).

    Returns:
        The frames' `Crops`.

    Raises:
        ValueError: `frames` is not a non-empty (N, H, W, 3) array of finite values, `crop_size` or
            `chunk` is not a positive int, or `adaptation` is not one of the three (the message names
            the argument).
    """
    frames = as_array(frames, "frames", shape=(None, None, None, 3), dtype=None)
    check_int(crop_size, "crop_size", min_value=1)
    chunk = check_int(chunk, "chunk", min_value=1)
    check_choice(adaptation, "adaptation", ADAPTATIONS)
    n, h, w, _ = frames.shape
    parts = []
    for i in range(0, n, chunk):
        part = frames[i: i + chunk]
        seeds = np.tile([h / 2.0, w / 2.0], (len(part), 1))
        if adaptation == "none":
            seg = hog_jax.segment(skin, part, seed_points=seeds, out_size=crop_size)
        else:
            seg = hog_jax.segment_adapted(skin, part, seed_points=seeds, out_size=crop_size, n_iter=5, relevance=64.0,
                                          adapt_skin=adaptation == "both")
        parts.append(crops_of(seg))
    return Crops(*(np.concatenate(a) for a in zip(*parts)))
