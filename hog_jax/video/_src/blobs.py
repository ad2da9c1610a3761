"""Blobs as ellipses: connected components of binary masks and their first and second moments
(LEVELSET TR §3.7: "objects, hands and head can be modelled as ellipses"; LfD 2009 §III-A).

Pixel coordinates, used by every image-side module of the tracker: a point is (x, y) = (column, row),
pixel (row r, column c) has its centre at (x, y) = (c, r) (integer coordinates), y points down. The
moments are those of the pixel centres (as `cv2.moments`): area = sum of the weights, centroid = the
weighted mean of (x, y), cov = the weighted second central moments / area (2, 2). A uniformly filled
ellipse with semi-axes a >= b has cov eigenvalues a^2 / 4 and b^2 / 4, so `ellipse_axes` returns
2 sqrt(eigenvalues) and the angle of the major axis from +x towards +y.

Shapes: T frames, H x W pixels, K blob slots per frame.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from hog_jax._src.segment import label_components
from lfd_common import as_array, check_int

__all__ = ["Blobs", "Ellipse", "EllipseAxes", "connected_blobs", "ellipse_axes", "mask_ellipse", "weighted_moments"]


class Ellipse(NamedTuple):
    """A blob as an ellipse: its area and first and second moments (LEVELSET TR §3.7).

    Points are (x, y) = (column, row) of pixel centres, y down; the moments are those of the pixel
    centres (as `cv2.moments`).

    Attributes:
        area: (...) the sum of the weights.
        centroid: (..., 2) the weighted mean (x, y); 0 where not found.
        cov: (..., 2, 2) the weighted second central moments / area; 0 where not found.
        found: (...) area > 0 (where False the centroid and cov are 0, never NaN).
    """

    area: Float[Array, "*batch"]
    centroid: Float[Array, "*batch 2"]
    cov: Float[Array, "*batch 2 2"]
    found: Bool[Array, "*batch"]


class EllipseAxes(NamedTuple):
    """The axes and orientation of ellipses (`ellipse_axes`).

    Attributes:
        semi_axes: (..., 2) major then minor, pixels: 2 sqrt of the cov eigenvalues (a uniformly filled
            ellipse with semi-axes a >= b has eigenvalues a^2 / 4 and b^2 / 4).
        angle: (...) the major axis's angle from +x towards +y, radians in (-pi/2, pi/2].
    """

    semi_axes: Float[Array, "*batch 2"]
    angle: Float[Array, "*batch"]


class Blobs(NamedTuple):
    """The connected components of T masks, at most K per frame, largest first (ties: OpenCV's order).

    Leading axes (T,) or (B, T) for a batch of videos.

    Attributes:
        labels: (T, H, W) uint8: 0 background (and components not kept), k + 1 for slot k.
        area: (T, K) pixels.
        centroid: (T, K, 2) (x, y).
        cov: (T, K, 2, 2) second central moments / area.
        valid: (T, K) bool; False slots are padding (area, centroid and cov 0).
        n_components: (T,) int32, the components found before the truncation to K and the `min_area`
            filter.
    """

    labels: Int[Array, "*T H W"]
    area: Float[Array, "*T K"]
    centroid: Float[Array, "*T K 2"]
    cov: Float[Array, "*T K 2 2"]
    valid: Bool[Array, "*T K"]
    n_components: Int[Array, "*T"]


def ellipse_from_sums(origin: Float[Array, "*batch 2"], area, sx, sy, sxx, sxy, syy) -> Ellipse:
    """The `Ellipse` from pixel sums (each (...,)) of w, w d, w d d^T with d = (x, y) - origin; zeros
    (found False) where the area is 0. Sums about a point near the centroid keep float32 accurate."""
    found = area > 0
    inv = jnp.where(found, 1.0 / jnp.where(found, area, 1.0), 0.0)
    mx, my = sx * inv, sy * inv
    cxy = sxy * inv - mx * my
    cov = jnp.stack([jnp.stack([sxx * inv - mx * mx, cxy], -1), jnp.stack([cxy, syy * inv - my * my], -1)], -2)
    centroid = jnp.where(found[..., None], origin + jnp.stack([mx, my], -1), 0.0)
    return Ellipse(area, centroid, cov, found)


def weighted_moments(weights: Float[Array, "*batch H W"]) -> Ellipse:
    """The `Ellipse` of non-negative pixel weights (traceable; LEVELSET TR §3.7).

    Two passes (the centroid, then the second moments about it), so that float32 keeps the
    covariance of a small blob far from the origin.

    Args:
        weights: (..., H, W) non-negative weights.

    Returns:
        An `Ellipse` with the leading axes; an all-zero weight image gives found False and zeros.
    """
    H, W = weights.shape[-2:]
    ys = jnp.arange(H, dtype=weights.dtype)[:, None]
    xs = jnp.arange(W, dtype=weights.dtype)[None, :]
    area = jnp.sum(weights, axis=(-2, -1))
    first = ellipse_from_sums(jnp.zeros(area.shape + (2,), weights.dtype), area,
                              jnp.sum(weights * xs, axis=(-2, -1)), jnp.sum(weights * ys, axis=(-2, -1)), 0, 0, 0)
    dx = xs - first.centroid[..., 0, None, None]
    dy = ys - first.centroid[..., 1, None, None]
    sums = [jnp.sum(weights * v, axis=(-2, -1)) for v in (dx, dy, dx * dx, dx * dy, dy * dy)]
    return ellipse_from_sums(first.centroid, area, *sums)


_weighted_moments = jax.jit(weighted_moments)


def mask_ellipse(masks: Bool[ArrayLike, "T H W"], weights: Float[ArrayLike, "T H W"] | None = None) -> Ellipse:
    """The ellipse (area, centroid, second moments) of each whole mask (LEVELSET TR §3.7).

    Args:
        masks: (T, H, W) boolean (or 0/1) masks.
        weights: optional (T, H, W) non-negative per-pixel weights (a soft mask): the moments are those
            of masks * weights.

    Returns:
        An `Ellipse` with leading axis T; an empty mask (or zero weights) gives found False, area 0,
        centroid and cov 0.

    Raises:
        ValueError: naming the argument for masks that are not (T, H, W) or not 0/1, and for negative
            or non-finite weights or weights of another shape.
    """
    m = as_array(masks, "masks", ndim=3, dtype=None)
    if m.dtype != bool:
        if not np.isin(m, (0, 1)).all():
            raise ValueError("masks: expected a boolean (or 0/1) array")
        m = m.astype(bool)
    w = np.asarray(m, np.float32)
    if weights is not None:
        w = w * as_array(weights, "weights", shape=m.shape, dtype=np.float32, min_value=0.0)
    return _weighted_moments(jnp.asarray(w))


@jax.jit
def ellipse_axes(cov: Float[ArrayLike, "*batch 2 2"]) -> EllipseAxes:
    """Semi-axes and orientation of the ellipses of symmetric 2 x 2 moment matrices (jitted).

    Args:
        cov: (..., 2, 2) second central moments.

    Returns:
        `EllipseAxes`: semi-axes (..., 2) (2 sqrt of the eigenvalues, major first) and the major
        axis's angle (...).
    """
    cov = jnp.asarray(cov, jnp.float32)
    a, b, c = cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 1]
    half_gap = jnp.sqrt(((a - c) / 2) ** 2 + b**2)  # closed-form eigenvalues: no eigh on (T, K) tiny matrices
    mid = (a + c) / 2
    major = jnp.maximum(mid + half_gap, 0.0)
    minor = jnp.maximum(mid - half_gap, 0.0)
    angle = 0.5 * jnp.arctan2(2 * b, a - c)
    return EllipseAxes(2.0 * jnp.sqrt(jnp.stack([major, minor], -1)), angle)


_CHUNK_PIXELS = 1 << 25  # frames per OpenCV call: its int32 label image stays ~128 MB


def connected_blobs(masks: Bool[ArrayLike, "*T H W"], max_blobs: int = 8, min_area: int = 1) -> Blobs:
    """The 8-connected components of binary masks as padded ellipse arrays (LEVELSET TR §3.7).

    LfD 2009 §III-A's hand and face blobs: the `max_blobs` largest components of at least `min_area`
    pixels per frame (OpenCV, many frames per call). The moments are exact (float64 sums over each
    component's pixels), returned in float32; labels are uint8.

    Args:
        masks: (T, H, W) or (B, T, H, W) boolean (or 0/1) masks.
        max_blobs: K, the slots per frame, 1..255.
        min_area: the smallest component kept, pixels, >= 1.

    Returns:
        `Blobs` with the leading axes of the masks.

    Raises:
        ValueError: naming the argument for masks that are not at least 3-D, not 0/1 or empty,
            max_blobs outside 1..255, or min_area < 1.
    """
    m = as_array(masks, "masks", dtype=None)
    if m.ndim < 3:
        raise ValueError(f"masks: expected (T, H, W) or (B, T, H, W) masks, got shape {m.shape}")
    if m.dtype != bool and not np.isin(m, (0, 1)).all():
        raise ValueError("masks: expected a boolean (or 0/1) array")
    K = check_int(max_blobs, "max_blobs", min_value=1, max_value=255)
    min_area = check_int(min_area, "min_area", min_value=1)
    lead, (H, W) = m.shape[:-2], m.shape[-2:]
    flat = m.reshape(-1, H, W).astype(bool)
    step = max(1, _CHUNK_PIXELS // (H * W))
    parts = [_frame_blobs(flat[i:i + step], K, min_area) for i in range(0, flat.shape[0], step)]
    labels, area, centroid, cov, valid, count = (np.concatenate(p) for p in zip(*parts))
    return Blobs(jnp.asarray(labels.reshape(*lead, H, W)), jnp.asarray(area.reshape(*lead, K), jnp.float32),
                 jnp.asarray(centroid.reshape(*lead, K, 2), jnp.float32),
                 jnp.asarray(cov.reshape(*lead, K, 2, 2), jnp.float32), jnp.asarray(valid.reshape(*lead, K)),
                 jnp.asarray(count.reshape(lead)))


def _frame_blobs(masks: np.ndarray, K: int, min_area: int):
    """`Blobs` fields as NumPy arrays for bool masks (T, H, W): one OpenCV call, moments by bincount."""
    T = masks.shape[0]
    labels, stats = label_components(masks)
    n = stats.shape[0]
    fb, fr, fc = np.nonzero(labels)
    lab = labels[fb, fr, fc]
    area, sx, sy, sxx, sxy, syy = (np.bincount(lab, weights=v, minlength=n).astype(np.float64)
                                   for v in (None, fc, fr, fc * fc, fc * fr, fr * fr))
    frame = np.full(n, -1)
    frame[lab] = fb
    count = np.bincount(frame[1:], minlength=T).astype(np.int32) if n > 1 else np.zeros(T, np.int32)
    ids = np.flatnonzero((np.arange(n) > 0) & (area >= min_area))
    ids = ids[np.lexsort((-area[ids], frame[ids]))]  # by frame, then largest first (a stable sort)
    rank = np.arange(ids.size) - np.searchsorted(frame[ids], frame[ids], side="left")
    ids, rank = ids[rank < K], rank[rank < K]
    slot = np.zeros(n, np.uint8)
    slot[ids] = rank + 1
    f, a = frame[ids], area[ids]
    cx, cy = sx[ids] / a, sy[ids] / a
    vxy = sxy[ids] / a - cx * cy
    out_area, out_c, out_cov = np.zeros((T, K)), np.zeros((T, K, 2)), np.zeros((T, K, 2, 2))
    out_area[f, rank] = a
    out_c[f, rank] = np.stack([cx, cy], -1)
    out_cov[f, rank] = np.stack([np.stack([sxx[ids] / a - cx * cx, vxy], -1),
                                 np.stack([vxy, syy[ids] / a - cy * cy], -1)], -2)
    valid = np.zeros((T, K), bool)
    valid[f, rank] = True
    return slot[labels], out_area, out_c, out_cov, valid, count
