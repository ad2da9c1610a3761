"""The hand at the end of the arm: where a skin blob is a bare forearm and hand together, the hand is
the part of the blob farthest from the body (LfD 2009 §III-A tracks "hand blobs"; on a real person
with bare forearms the skin blob is the forearm and the hand, whose centroid lies mid-forearm).

Per frame and hand target (`hand_ends`): the blob the tracker took for the hand (`Tracks.blob`), its
ellipse (second moments, `blobs` conventions: a filled ellipse with semi-axes a >= b has cov eigenvalues
a^2 / 4 and b^2 / 4), and a reference point on the body (the tracked face). A blob elongated by at
least `min_elongation` (a / b) is an arm: its pixels within `end_widths` times its width (2 b) of the
pixel farthest from the reference make the hand, whose centroid is the hand's position. A compact blob
(a hand alone), a blob shared with another target (the tracker splits those), a frame without a blob or
a lost reference keep the tracker's position.

Shapes: T frames, H x W pixels, M targets.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from hog_jax.video._src.tracking import Tracks
from lfd_common import as_array, check_int, check_real

__all__ = ["HandEndOptions", "hand_ends"]


@dataclasses.dataclass(frozen=True)
class HandEndOptions:
    """Where an arm blob's hand is (`hand_ends`), validated on construction.

    Attributes:
        min_elongation: a blob whose major semi-axis is at least this many times its minor one is an
            arm (a hand alone, fingers together, is about 1.5), > 1.
        end_widths: the hand's length in widths of the arm blob (2 b, the minor axis), > 0.

    Raises:
        ValueError: naming the field for a value out of range.
    """

    min_elongation: float = 2.0
    end_widths: float = 1.0

    def __post_init__(self):
        check_real(self.min_elongation, "min_elongation", min_value=1.0, exclusive_min=True)
        check_real(self.end_widths, "end_widths", min_value=0.0, exclusive_min=True)


def _hand_end(labels, slot, shared, position, reference, reference_lost, min_elongation, end_widths):
    """One frame, one hand target: the hand's (x, y)."""
    H, W = labels.shape
    mask = (labels == slot + 1) & (slot >= 0)
    ys, xs = jnp.mgrid[:H, :W]
    w = mask.astype(jnp.float32)
    area = jnp.maximum(jnp.sum(w), 1.0)
    cx, cy = jnp.sum(w * xs) / area, jnp.sum(w * ys) / area
    dx, dy = xs - cx, ys - cy
    sxx, sxy, syy = jnp.sum(w * dx * dx) / area, jnp.sum(w * dx * dy) / area, jnp.sum(w * dy * dy) / area
    half_gap = jnp.sqrt(((sxx - syy) / 2) ** 2 + sxy * sxy)
    major, minor = (sxx + syy) / 2 + half_gap, jnp.maximum((sxx + syy) / 2 - half_gap, 1e-6)
    is_arm = jnp.sqrt(major / minor) >= min_elongation
    distance = jnp.where(mask, jnp.hypot(xs - reference[0], ys - reference[1]), -jnp.inf)
    end = mask & (distance >= jnp.max(distance) - end_widths * 4.0 * jnp.sqrt(minor))  # width 2 b = 4 sqrt(minor)
    e = end.astype(jnp.float32)
    n_end = jnp.maximum(jnp.sum(e), 1.0)
    point = jnp.stack([jnp.sum(e * xs) / n_end, jnp.sum(e * ys) / n_end])
    use = jnp.any(mask) & is_arm & ~shared & ~reference_lost
    return jnp.where(use, point, position)


@jax.jit
def _hand_ends(labels, slots, shared, positions, references, reference_lost, min_elongation, end_widths):
    per_target = jax.vmap(_hand_end, in_axes=(None, 0, 0, 0, None, None, None, None))
    return jax.vmap(per_target, in_axes=(0, 0, 0, 0, 0, 0, None, None))(
        labels, slots, shared, positions, references, reference_lost, min_elongation, end_widths)


def hand_ends(labels: Int[ArrayLike, "T H W"], tracks: Tracks, hands: Sequence[int], reference: int,
              options: HandEndOptions = HandEndOptions()) -> Float[Array, "T N 2"]:
    """The hand targets' positions at the far end of their arm blobs (module docstring).

    Args:
        labels: (T, H, W) the blob labels the tracker saw (`connected_blobs(...).labels`: 0 none, k + 1
            slot k).
        tracks: the `Tracks` of those blobs (leading axis T).
        hands: the N hand targets' indices (e.g. `HAND`, `OTHER_HAND`).
        reference: the body target's index whose position the arm points away from (e.g. `FACE`).
        options: the `HandEndOptions`.

    Returns:
        (T, N, 2) float32 (x, y) pixels: the hand's centre where its blob is an arm, else the tracker's
        position.

    Raises:
        ValueError: naming the argument for labels that are not (T, H, W) integers matching the tracks'
            T, target indices out of range, or options that are not a `HandEndOptions`.
    """
    lab = as_array(labels, "labels", ndim=3, dtype=None)
    if not np.issubdtype(lab.dtype, np.integer):
        raise ValueError(f"labels: expected integer blob labels, got {lab.dtype}")
    if not isinstance(tracks, Tracks):
        raise ValueError(f"tracks: expected a Tracks, got {type(tracks).__name__}")
    T, M = np.shape(tracks.blob)
    if lab.shape[0] != T:
        raise ValueError(f"labels: expected {T} frames (the tracks'), got {lab.shape[0]}")
    index = [check_int(h, "hands", min_value=0, max_value=M - 1) for h in hands]
    if not index:
        raise ValueError("hands: expected at least one target index")
    ref = check_int(reference, "reference", min_value=0, max_value=M - 1)
    if not isinstance(options, HandEndOptions):
        raise ValueError(f"options: expected a HandEndOptions, got {type(options).__name__}")
    pick = lambda a: jnp.asarray(a)[:, np.asarray(index)]  # noqa: E731
    return _hand_ends(jnp.asarray(lab, jnp.int32), pick(tracks.blob), pick(tracks.merged),
                      pick(tracks.position).astype(jnp.float32), jnp.asarray(tracks.position)[:, ref].astype(jnp.float32),
                      jnp.asarray(tracks.lost)[:, ref], jnp.float32(options.min_elongation),
                      jnp.float32(options.end_widths))
