"""Competing level sets as users call them (LEVELSET TR §3.1-3.2, eqs. 5-7 and 11; §3.7; §5): the
cold start, independent frames and videos, on one device or with the videos split over a mesh.

Shapes: B videos (or independent frames), T frames, R regions (R >= 2), H x W pixels.

The evolution itself (eq. 7 with eq. 11's regulariser, the stopping rule, the two scales, warm
starts) is `levelset_evolution`'s; `levelset_sharded` runs its kernel over a device mesh.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh
from jaxtyping import Array, ArrayLike, Float

from hog_jax.video._src.levelset_evolution import (FIXED, LevelSetOptions, LevelSetResult, LevelSetStructure,
                                                   clip_scores, evolve_kernel, partition_sdf, run)
from hog_jax.video._src.levelset_sharded import sharded_kernel
from lfd_common import as_array, check_real

__all__ = ["evolve", "init_level_sets", "segment_video"]


def _check_scores(scores, structure: LevelSetStructure, ndims: tuple[int, ...]) -> np.ndarray:
    """(..., R, H, W) float32 scores; -inf allowed, NaN / +inf / a wrong shape a ValueError."""
    if not isinstance(structure, LevelSetStructure):
        raise ValueError(f"structure: expected a LevelSetStructure, got {type(structure).__name__}")
    arr = as_array(scores, "scores", ndim=ndims, dtype=np.float32, finite=False)
    bad = np.isnan(arr) | (arr == np.inf)
    if bad.any():
        raise ValueError(f"scores: contains {int(bad.sum())} NaN or +inf value(s) (-inf, log 0, is accepted)")
    want = (structure.n_regions, *structure.shape)
    if arr.shape[-3:] != want:
        raise ValueError(f"scores: expected trailing axes (R, H, W) = {want} (the structure), got {arr.shape}")
    return arr


def init_level_sets(scores: Float[ArrayLike, "*batch R H W"],
                    max_log_ratio: float = 10.0) -> Float[Array, "*batch R H W"]:
    """Cold-start level sets from region scores (LEVELSET TR eqs. 4-7 assume signed distances).

    Each score is first floored at the pixel's best score minus `max_log_ratio` (a pixel where
    every region scores -inf gets 0 for all); then each phi_i is the signed Euclidean distance (to
    pixel edges, `signed_distance`) of region i of the partition argmax_i e_i(x). For R = 2 this
    gives phi_2 = -phi_1.

    Args:
        scores: (..., R, H, W) region scores e_i = log p_i; -inf (log 0) is valid.
        max_log_ratio: the score floor below the pixel's best score, > 0 (nats).

    Returns:
        (..., R, H, W) float32 level sets, positive inside each region.

    Raises:
        ValueError: `scores` with fewer than 3 axes, R < 2, NaN or +inf values; `max_log_ratio` <= 0.
    """
    arr = as_array(scores, "scores", dtype=np.float32, finite=False)
    if arr.ndim < 3 or arr.shape[-3] < 2 or np.isnan(arr).any() or (arr == np.inf).any():
        raise ValueError(f"scores: expected (..., R, H, W) with R >= 2 and no NaN or +inf, got shape {arr.shape}")
    r = check_real(max_log_ratio, "max_log_ratio", min_value=0.0, exclusive_min=True)
    return _init_many(jnp.asarray(arr.reshape(-1, *arr.shape[-3:])), np.float32(r)).reshape(arr.shape)


@jax.jit
def _init_many(scores, max_log_ratio):
    return jax.vmap(lambda e: partition_sdf(clip_scores(e, max_log_ratio)))(scores)


def evolve(structure: LevelSetStructure, scores: Float[ArrayLike, "*batch R H W"],
           phi0: Float[ArrayLike, "*batch R H W"] | None = None,
           options: LevelSetOptions = LevelSetOptions()) -> LevelSetResult:
    """Segment independent frames by R competing level sets (LEVELSET TR eq. 7 with eq. 11, §5).

    Each explicit Euler step moves phi_i by
    delta(phi_i) (e_i - max_{j != i, H(phi_j) > 0} e_j + alpha/2 kappa(phi_i))
    + mu (laplacian(phi_i) - kappa(phi_i)), on the coarse scale of `structure` first (alpha divided
    by the size ratio), then the fine one, each until the contour length stops changing
    (`LevelSetOptions`). Where no other region is present the competitor is the max over all j != i.

    Args:
        structure: R, the frame shape and the coarse scale (`LevelSetStructure`).
        scores: (R, H, W) or (B, R, H, W) region scores e_i = log p_i; -inf (log 0) is valid, and
            every score is floored at the pixel's best minus `options.max_log_ratio`.
        phi0: start level sets of the shape of `scores`, or None: the cold start of
            `init_level_sets` at the first scale.
        options: the evolution options (`LevelSetOptions`).

    Returns:
        A `LevelSetResult` without or with the batch axis: labels (argmax of the positive phi_i, -1
        on boundaries, TR §3.2), the level sets, the iterations per scale and whether the length
        rule stopped the final scale.

    Raises:
        ValueError: naming the argument for a structure that is not a `LevelSetStructure`, scores of
            a wrong shape (R other than the structure's), NaN or +inf scores, a phi0 of another
            shape, or bad options (naming the field).
    """
    arr = _check_scores(scores, structure, (3, 4))
    batched = arr.ndim == 4
    x = arr if batched else arr[None]
    return run(structure, FIXED, x[:, None], phi0, options, batched, frames=True)


def segment_video(structure: LevelSetStructure, scores: Float[ArrayLike, "*batch T R H W"],
                  phi0: Float[ArrayLike, "*batch R H W"] | None = None,
                  options: LevelSetOptions = LevelSetOptions(), *, mesh: Mesh | None = None) -> LevelSetResult:
    """Segment a video of region scores, each frame starting from the previous frame's level sets.

    The warm start of LEVELSET TR §3.7 (a `lax.scan` over frames, `vmap` over videos); each frame
    evolves as in `evolve`. A region absent from a frame has no front and cannot reappear by itself
    (`LevelSetOptions.reseed_margin` re-seeds it from the scores).

    Args:
        structure: R, the frame shape and the coarse scale (`LevelSetStructure`).
        scores: (T, R, H, W) a video, or (B, T, R, H, W) a batch of videos, of region scores.
        phi0: (R, H, W) or (B, R, H, W) level sets before frame 0, or None: frame 0 starts cold.
        options: the evolution options (`LevelSetOptions`).
        mesh: a `jax.sharding.Mesh` to split the videos over (padded to the mesh with copies of
            video 0; the result equals the one-device result; with several processes each passes
            its own videos and gets its own back), or None for one device.

    Returns:
        A `LevelSetResult` with leading axes (T,) or (B, T).

    Raises:
        ValueError: as `evolve`, for T = 0, and for a `mesh` that is not a `jax.sharding.Mesh`.
    """
    arr = _check_scores(scores, structure, (4, 5))
    batched = arr.ndim == 5
    x = arr if batched else arr[None]
    kernel = evolve_kernel if mesh is None else sharded_kernel(mesh)
    return run(structure, FIXED, x, phi0, options, batched, False, kernel)
