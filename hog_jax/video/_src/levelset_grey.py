"""Two-region grey-level front end for the competing level sets (`levelset`): Chan-Vese region
models, so that the method compares with scikit-image's `chan_vese` on the same frames.

Shapes: B frames, H x W pixels; two regions (R = 2).

What it computes: each region k of the current partition (labels == k) is modelled by the mean c_k
of its grey levels (``gaussian=False``: e_k = -(I - c_k)^2, Chan & Vese 1999 with lambda_1 =
lambda_2 = 1, i.e. Gaussians of one shared, fixed variance) or by its mean and variance
(``gaussian=True``: e_k = log N(I; c_k, v_k), v_k floored at `VAR_FLOOR`). The grey image is first
rescaled to [0, 1] (as scikit-image does). The models are re-estimated from the partition every
`refit_every` iterations inside the evolution (`LevelSetOptions`), and the scores drive eq. 7 with
the options, scales and stopping rule of `levelset`. An empty region gets the statistics of the
whole frame. Differences from scikit-image's `chan_vese` (same energy for ``gaussian=False``,
curvature weight mu_skimage = alpha / 2): the compact delta of eq. 6 instead of
eps / (pi (eps^2 + phi^2)) (so fronts move only near the contour, and new contours do not
nucleate far from one), an explicit Euler step with the eq. 11 regulariser instead of Getreuer's
semi-implicit step, two scales, and the stopping rule on the contour length instead of the change
of phi.

Cold start: the region models of scikit-image's checkerboard partition (squares of 5 pixels at
the first scale, sin(pi y / 5) sin(pi x / 5) > 0) score the frame, and the level sets start as the
signed distances of the argmax partition of those scores (`levelset.init_level_sets`'s rule). With
two near-equal means from the checkerboard this is a threshold at their midpoint: the fixed point
scikit-image's global evolution heads to, reached here at once.
"""
from __future__ import annotations

import dataclasses
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int, Real

from hog_jax.video._src.levelset_evolution import (LevelSetOptions, LevelSetResult, LevelSetStructure,
                                                   clip_scores, labels_of, partition_sdf, run)
from lfd_common import as_array

__all__ = ["VAR_FLOOR", "chan_vese_scores", "chan_vese_segment"]

VAR_FLOOR = 1e-4  # a region's grey-level variance floor (sigma >= 0.01 of the [0, 1] range)


@partial(jax.jit, static_argnames=("gaussian",))
def chan_vese_scores(grey: Float[ArrayLike, "*batch H W"], labels: Int[ArrayLike, "*batch H W"],
                     gaussian: bool = False) -> Float[Array, "*batch 2 H W"]:
    """The Chan-Vese region scores of two grey-level regions (jitted; no input checks).

    Each region k of the partition (labels == k) is modelled by the mean c_k of its grey levels
    (e_k = -(I - c_k)^2: Chan & Vese 1999 with lambda_1 = lambda_2 = 1) or, with `gaussian`, by its
    mean and variance (e_k = log N(I; c_k, v_k), v_k floored at `VAR_FLOOR`). An empty region gets the
    statistics of the whole frame.

    Args:
        grey: (..., H, W) grey levels.
        labels: (..., H, W) the partition (0 and 1; other labels belong to neither region).
        gaussian: use the mean and the variance (static).

    Returns:
        (..., 2, H, W) scores e_k for LEVELSET TR eq. 7.
    """
    grey = jnp.asarray(grey, jnp.float32)
    labels = jnp.asarray(labels)
    masks = (labels[..., None, :, :] == jnp.arange(2)[:, None, None]).astype(jnp.float32)  # (..., 2, H, W)
    count = jnp.sum(masks, axis=(-2, -1))
    g = grey[..., None, :, :]

    def region_mean(f):  # (..., 2, H, W) -> (..., 2, 1, 1); an empty region takes the whole frame's
        inside = jnp.sum(f * masks, axis=(-2, -1)) / jnp.maximum(count, 1.0)
        return jnp.where(count > 0, inside, jnp.mean(f, axis=(-2, -1)))[..., None, None]

    sq = (g - region_mean(jnp.broadcast_to(g, masks.shape))) ** 2
    if not gaussian:
        return -sq
    var = jnp.maximum(region_mean(sq), VAR_FLOOR)
    return -sq / (2.0 * var) - 0.5 * jnp.log(2.0 * jnp.pi * var)


def _checkerboard(shape, square: int):
    y = jnp.arange(shape[0], dtype=jnp.float32)[:, None]
    x = jnp.arange(shape[1], dtype=jnp.float32)[None, :]
    cb = jnp.sin(jnp.pi * y / square) * jnp.sin(jnp.pi * x / square) > 0
    return jnp.where(cb, 0, 1)


@dataclasses.dataclass(frozen=True)
class _GreyRegions:
    """The score model of `levelset_evolution.run` for grey frames (H, W) in [0, 1]."""

    gaussian: bool
    square: int = 5
    refits: bool = True

    @staticmethod
    def prepare(grey, o):
        return grey

    def scores(self, grey, phi, o):
        return clip_scores(chan_vese_scores(grey, labels_of(phi), self.gaussian), o.max_log_ratio)

    def init(self, grey, o):
        start = chan_vese_scores(grey, _checkerboard(grey.shape, self.square), self.gaussian)
        return partition_sdf(clip_scores(start, o.max_log_ratio))


def chan_vese_segment(structure: LevelSetStructure, grey: Real[ArrayLike, "*batch H W"],
                      gaussian: bool = False, phi0: Float[ArrayLike, "*batch 2 H W"] | None = None,
                      options: LevelSetOptions = LevelSetOptions()) -> LevelSetResult:
    """Two-region segmentation of grey frames by the competing level sets (LEVELSET TR eq. 7, §5).

    The Chan-Vese region models of `chan_vese_scores`, re-estimated from the partition every
    `options.refit_every` iterations inside the evolution, drive eq. 7 with the options, scales and
    stopping rule of `evolve`, so that the method compares with scikit-image's `chan_vese` on the same
    frames (the same energy for gaussian=False, curvature weight mu_skimage = alpha / 2). Each frame is
    first rescaled to [0, 1]. Cold start: the region models of scikit-image's checkerboard partition
    (squares of 5 pixels at the first scale) score the frame, and the level sets start as the signed
    distances of the argmax partition of those scores.

    Args:
        structure: a `LevelSetStructure` with n_regions = 2.
        grey: (H, W) or (B, H, W) grey frames, any real range.
        gaussian: model each region by its mean and variance, not the mean alone.
        phi0: (2, H, W) or (B, 2, H, W) start level sets, or None for the cold start.
        options: the `LevelSetOptions`.

    Returns:
        A `LevelSetResult` (labels 0, 1 or -1), independent frames.

    Raises:
        ValueError: naming the argument for a structure with n_regions != 2, frames of a wrong shape,
            NaN or inf pixels, a phi0 of another shape, or bad options.
    """
    if not isinstance(structure, LevelSetStructure) or structure.n_regions != 2:
        raise ValueError(f"structure: expected a LevelSetStructure with n_regions=2, got {structure!r}")
    arr = as_array(grey, "grey", ndim=(2, 3), dtype=np.float32)
    if arr.shape[-2:] != structure.shape:
        raise ValueError(f"grey: expected frames of shape {structure.shape} (the structure), got {arr.shape}")
    batched = arr.ndim == 3
    x = arr if batched else arr[None]
    lo = x.min(axis=(1, 2), keepdims=True)
    span = x.max(axis=(1, 2), keepdims=True) - lo
    x = (x - lo) / np.where(span > 0, span, 1.0)
    return run(structure, _GreyRegions(bool(gaussian)), x[:, None], phi0, options, batched, frames=True)
