"""The three skin segmentations compared on the real photos, batched.

* ours: `hog_jax`'s skin model, as `hog_jax.segment` makes its skin mask: log p_skin - log
  p_background of the (Cr, Cb) chroma > threshold, then the 3 x 3 median filter three times
  (`hog_jax.median3`; edges re-replicated after each pass, so padded photos filter as unpadded ones);
* YCrCb rule: the fixed chroma box Cr in [133, 173], Cb in [77, 127] of Chai & Ngan, "Face
  segmentation using skin-color map in videophone applications", IEEE TCSVT 9(4), 1999 (the recipe
  usually written as `cv2.inRange(cv2.cvtColor(img, cv2.COLOR_BGR2YCrCb), (0, 133, 77), (255, 173,
  127))`), on OpenCV's 8-bit YCrCb computed here in JAX with OpenCV's fixed-point arithmetic (so that
  it equals cv2.inRange bit for bit); reported raw and with the same median filter as ours;
* GrabCut (Rother, Kolmogorov & Blake, SIGGRAPH 2004; `cv2.grabCut`) started from our mask:
  probable foreground where ours says skin, probable background elsewhere, a few iterations.
"""
from __future__ import annotations

import cv2
import jax
import jax.numpy as jnp
import numpy as np

from experiments.peers.ycrcb import ycrcb_rule
from hog_jax import median3

MEDIAN_PASSES = 3  # as hog_jax.segment (GRASP: the 3 x 3 median filter applied three times)
def replicate_edges(masks: jax.Array, rows: jax.Array, cols: jax.Array) -> jax.Array:
    """(B, H, W): each photo's pixels outside its (h, w) replaced by its last row / column (`rows`
    (B, H) and `cols` (B, W) from `experiments.data.hand_photos.PhotoBatch`)."""
    return masks[jnp.arange(masks.shape[0])[:, None, None], rows[:, :, None], cols[:, None, :]]


@jax.jit
def filtered(raw: jax.Array, rows: jax.Array, cols: jax.Array) -> jax.Array:
    """The median filter of `hog_jax.segment` (MEDIAN_PASSES 3 x 3 passes) of padded masks (B, H, W),
    equal on every real pixel to filtering each unpadded photo alone (replicated borders)."""
    mask = raw
    for _ in range(MEDIAN_PASSES):
        mask = replicate_edges(median3(mask, 1), rows, cols)
    return mask


@jax.jit
def ours_masks(log_ratio: jax.Array, threshold: jax.Array, rows: jax.Array, cols: jax.Array) -> jax.Array:
    """Our skin masks (B, H, W): log ratio > threshold, median filtered."""
    return filtered(log_ratio > threshold, rows, cols)


@jax.jit
def ycrcb_masks(rgb: jax.Array, rows: jax.Array, cols: jax.Array) -> tuple[jax.Array, jax.Array]:
    """(raw, filtered) YCrCb-rule masks (B, H, W) of padded RGB photos (B, H, W, 3)."""
    raw = ycrcb_rule(rgb)
    return raw, filtered(raw, rows, cols)


@jax.jit
def curve_counts(log_ratio: jax.Array, thresholds: jax.Array, rows: jax.Array, cols: jax.Array,
                 truth: jax.Array, valid: jax.Array) -> jax.Array:
    """(T, 3) pooled (true positive, false positive, false negative) pixel counts of our filtered
    masks at each of T thresholds (one threshold at a time: memory of one batch of masks)."""
    def at(threshold):
        mask = ours_masks(log_ratio, threshold, rows, cols) & valid
        return jnp.stack([jnp.sum(mask & truth), jnp.sum(mask & ~truth), jnp.sum(~mask & truth)])
    return jax.lax.map(at, thresholds)


def grabcut(bgr: np.ndarray, seed: np.ndarray, iterations: int) -> tuple[np.ndarray, bool]:
    """(mask (h, w) bool, ran): `cv2.grabCut` from the bool mask `seed` (probable foreground where
    True, probable background elsewhere; colour GMMs of OpenCV's default 5 components). GrabCut needs
    pixels of both kinds: for an all-True or all-False seed it does not run and the seed is returned
    with ran False."""
    if seed.all() or not seed.any():
        return seed.copy(), False
    labels = np.where(seed, cv2.GC_PR_FGD, cv2.GC_PR_BGD).astype(np.uint8)
    background, foreground = np.zeros((1, 65)), np.zeros((1, 65))
    cv2.grabCut(bgr, labels, None, background, foreground, iterations, cv2.GC_INIT_WITH_MASK)
    return (labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD), True
