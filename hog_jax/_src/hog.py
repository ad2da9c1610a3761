"""Histograms of oriented gradients: the GRASP pyramid (eq. 1, §IV) and the flat grid of LfD 2009.

Shapes: B images, H rows, W columns, C = n_bins orientation bins, D feature length.

Gradient (both variants): central differences as in Dalal & Triggs and scikit-image,
    gx[r, c] = I[r + 1, c] - I[r - 1, c]   (x points DOWN, along rows)
    gy[r, c] = I[r, c + 1] - I[r, c - 1]   (y points RIGHT, along columns)
with gx = 0 on the first and last row and gy = 0 on the first and last column.

Orientation:
* ``"grasp"`` (GRASP eq. 1, ECCV 2008): Phi = arctan(gy / gx) taken modulo pi, so Phi in [0, pi).
  Bin c covers [c pi / C, (c + 1) pi / C); its centre is (c + 1/2) pi / C (pi/8, 3pi/8, ... for C = 4,
  as in GRASP Fig. 4). The range is cyclic (0 and pi are the same orientation).
* ``"abs"`` (LfD 2009): Phi = arctan(|gy| / |gx|) in [0, pi/2]; C bins of width pi / (2 C); not cyclic
  (Phi = pi/2 falls in the last bin).
A pixel with a zero gradient has no orientation and never votes (also with count weighting).

Cells: a side of S pixels split into n cells has cell borders at floor(i S / n), i = 0..n, so every
pixel belongs to exactly one cell, cells differ in size by at most one pixel when n does not divide
S, and the borders of level l + 1 are a subset of those of level l (a coarse cell is exactly the
union of 2 x 2 finer cells).

Layouts:
* ``"pyramid"`` (GRASP): levels l = 1..L, level l has 2^(L-l) x 2^(L-l) cells; D = C sum_l 4^(L-l).
* ``"grid"`` (LfD 2009): one L x L grid; D = C L^2.
Feature order: levels finest first (l = 1, ..., L), within a level cells row-major, then bins:
index = offset(l) + (i n + j) C + c.

Options (`HOGConfig`, defaults in brackets): orientation ["grasp"], weighting ["magnitude"]
(gradient magnitude hypot(gx, gy)) or "count" (one vote per pixel with a non-zero gradient),
binning ["hard"] or "soft" (linear interpolation between the two nearest bin centres, cyclic for
"grasp"), normalize ["global"]: each histogram divided by the total vote of the image, so every
level sums to 1 (invariant to contrast), "cell": each cell histogram divided by its own total (L1;
an empty cell stays 0), or "none" (raw sums). A mask (B, H, W) excludes pixels from voting; the
gradient is still computed from the image as given (segmented images have a black background, so
the hand's outline votes from the pixels on the hand side).

Range: any finite float32 image is accepted. An image whose largest |I| lies outside [2^-40, 2^60]
(where gx^2 + gy^2 would overflow or underflow float32) is first multiplied by a power of two that
brings it into [1, 2): exact, and the features do not change ("global" and "cell" normalisation and
"count" weighting are invariant to a positive scale); with normalize="none" and magnitude weighting
the raw sums are scaled back, and a `ValueError` names `images` when they do not fit float32.
Images inside the range are not touched (bit-identical results, no extra work).
"""
from __future__ import annotations

import math
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh
from jaxtyping import Array, ArrayLike, Bool, Float, Real

from lfd_common import as_array, check_choice, check_int
from lfd_common import check_mesh, map_batch

__all__ = ["HOGConfig", "hog", "hog_dim", "gradients", "orientation"]


class HOGConfig(NamedTuple):
    """HOG options (hashable: a static jit argument; GRASP eq. 1, §IV; LfD 2009).

    Attributes:
        n_bins: orientation bins C (GRASP: 4).
        n_levels: pyramid levels L, 1..12 (GRASP: 3), or the side of the grid.
        layout: "pyramid" (GRASP: levels l = 1..L with 2^(L-l) x 2^(L-l) cells, D = C sum_l 4^(L-l))
            or "grid" (LfD 2009: one L x L grid, D = C L^2). Features are ordered levels finest
            first, cells row-major, then bins.
        orientation: "grasp" (GRASP eq. 1: Phi = arctan(gy / gx) mod pi in [0, pi), bin c covering
            [c pi / C, (c + 1) pi / C), cyclic) or "abs" (LfD 2009: arctan(|gy| / |gx|) in [0, pi/2],
            not cyclic). A pixel with a zero gradient never votes.
        weighting: "magnitude" (the gradient magnitude hypot(gx, gy)) or "count" (one vote per pixel
            with a non-zero gradient).
        binning: "hard" or "soft" (linear interpolation between the two nearest bin centres, cyclic
            for "grasp").
        normalize: "global" (each histogram divided by the image's total vote, so every level sums
            to 1: invariant to contrast), "cell" (each cell histogram by its own total, L1; an empty
            cell stays 0) or "none" (raw sums).
    """

    n_bins: int = 4
    n_levels: int = 3
    layout: str = "pyramid"
    orientation: str = "grasp"
    weighting: str = "magnitude"
    binning: str = "hard"
    normalize: str = "global"


def _check_config(config: HOGConfig) -> HOGConfig:
    if not isinstance(config, HOGConfig):
        raise ValueError(f"config: expected a HOGConfig, got {type(config).__name__}")
    check_int(config.n_bins, "config.n_bins", min_value=1)
    check_int(config.n_levels, "config.n_levels", min_value=1, max_value=12)
    check_choice(config.layout, "config.layout", ("pyramid", "grid"))
    check_choice(config.orientation, "config.orientation", ("grasp", "abs"))
    check_choice(config.weighting, "config.weighting", ("magnitude", "count"))
    check_choice(config.binning, "config.binning", ("hard", "soft"))
    check_choice(config.normalize, "config.normalize", ("global", "cell", "none"))
    return config


def _cells_per_side(config: HOGConfig) -> list[int]:
    """Cells per side of each level, finest first."""
    if config.layout == "grid":
        return [config.n_levels]
    return [2 ** (config.n_levels - l) for l in range(1, config.n_levels + 1)]


def hog_dim(config: HOGConfig = HOGConfig()) -> int:
    """The HOG feature length D = C x (total number of cells).

    Args:
        config: the HOG options (`HOGConfig`).

    Returns:
        D.

    Raises:
        ValueError: naming the field for an invalid config.
    """
    _check_config(config)
    return config.n_bins * sum(n * n for n in _cells_per_side(config))


def gradients(images: Float[Array, "*batch H W"]) -> tuple[Float[Array, "*batch H W"], Float[Array, "*batch H W"]]:
    """Central differences (..., H, W) -> (gx down the rows, gy along the columns), zero at borders."""
    zr = jnp.zeros_like(images[..., :1, :])
    zc = jnp.zeros_like(images[..., :, :1])
    gx = jnp.concatenate([zr, images[..., 2:, :] - images[..., :-2, :], zr], axis=-2)
    gy = jnp.concatenate([zc, images[..., :, 2:] - images[..., :, :-2], zc], axis=-1)
    return gx, gy


def orientation(gx: Float[Array, "*batch H W"], gy: Float[Array, "*batch H W"],
                kind: str = "grasp") -> Float[Array, "*batch H W"]:
    """Phi per pixel: "grasp" arctan(gy/gx) mod pi in [0, pi); "abs" arctan(|gy|/|gx|) in [0, pi/2]."""
    if kind == "abs":
        return jnp.arctan2(jnp.abs(gy), jnp.abs(gx))
    phi = jnp.arctan2(gy, gx)
    phi = jnp.where(phi < 0, phi + jnp.pi, phi)
    return jnp.where(phi >= jnp.pi, phi - jnp.pi, phi)


def _bin_masks(gx, gy, config: HOGConfig) -> list[jax.Array]:
    """Hard binning without trigonometry: one boolean (..., H, W) mask per bin.

    For "grasp" the direction is folded into the upper half plane (Phi in [0, pi)); Phi >= theta_k
    iff cos(theta_k) gy - sin(theta_k) gx >= 0 with theta_k = k span / C. For "abs" (|gx|, |gy|) lies
    in the first quadrant (span pi/2). Bin c is "beyond border c and not beyond border c + 1".
    """
    C = config.n_bins
    if config.orientation == "abs":
        x, y = jnp.abs(gx), jnp.abs(gy)
        span = math.pi / 2
    else:
        flip = (gy < 0) | ((gy == 0) & (gx < 0))
        x, y = jnp.where(flip, -gx, gx), jnp.where(flip, -gy, gy)
        span = math.pi
    beyond = [None] + [math.cos(span * k / C) * y - math.sin(span * k / C) * x >= 0 for k in range(1, C)] + [None]
    masks = []
    for c in range(C):
        m = jnp.ones(gx.shape, bool) if beyond[c] is None else beyond[c]
        if beyond[c + 1] is not None:
            m = m & ~beyond[c + 1]
        masks.append(m)
    return masks


def _soft_weights(gx, gy, config: HOGConfig) -> list[jax.Array]:
    """Linear interpolation between bin centres: weight of bin c = max(0, 1 - |t - c|), t in bin units.

    "grasp" is cyclic (the distance is taken modulo C); for "abs" t is clamped to [0, C - 1], so
    orientations beyond the outer bin centres vote fully for the outer bin.
    """
    C = config.n_bins
    cyclic = config.orientation == "grasp"
    span = math.pi if cyclic else math.pi / 2
    t = orientation(gx, gy, config.orientation) * (C / span) - 0.5
    if not cyclic:
        t = jnp.clip(t, 0.0, C - 1.0)
    out = []
    for c in range(C):
        d = jnp.abs(t - c)
        if cyclic:
            d = jnp.minimum(d, C - d)
        out.append(jnp.maximum(0.0, 1.0 - d))
    return out


def _votes(images, mask, config: HOGConfig) -> list[jax.Array]:
    """Per-pixel votes, one (B, H, W) array per bin (kept apart so that XLA fuses each with its reduction)."""
    gx, gy = gradients(images)
    if config.weighting == "magnitude":
        weight = jnp.sqrt(gx * gx + gy * gy)
    else:
        weight = ((gx != 0) | (gy != 0)).astype(images.dtype)
    if mask is not None:
        weight = jnp.where(mask, weight, 0.0)
    if config.binning == "hard":
        return [jnp.where(m, weight, 0.0) for m in _bin_masks(gx, gy, config)]
    return [w * weight for w in _soft_weights(gx, gy, config)]


def _assignment(size: int, n: int) -> np.ndarray:
    """(n, size) 0/1 matrix: pixel p is in cell i iff floor(i size / n) <= p < floor((i + 1) size / n)."""
    borders = (np.arange(n + 1) * size) // n
    cell = np.searchsorted(borders, np.arange(size), side="right") - 1
    return (cell[None, :] == np.arange(n)[:, None]).astype(np.float32)


def _cell_sums(votes, n: int):
    """(B, H, W) -> (B, n, n) sums over the cells of an n x n grid."""
    B, H, W = votes.shape
    if H % n == 0 and W % n == 0:  # a reshape-reduce, which XLA fuses with the vote computation
        return votes.reshape(B, n, H // n, n, W // n).sum(axis=(2, 4))
    rows = jnp.asarray(_assignment(H, n), votes.dtype)
    cols = jnp.asarray(_assignment(W, n), votes.dtype)
    return jnp.einsum("ih,bhw,jw->bij", rows, votes, cols)


def _hog_chunk(images, mask, config: HOGConfig):
    """(b, H, W) -> (b, D): the whole feature computation for one chunk of the batch."""
    sides = _cells_per_side(config)
    finest = jnp.stack([_cell_sums(v, sides[0]) for v in _votes(images, mask, config)], axis=-1)
    levels = [finest]
    for n in sides[1:]:  # coarse cells are unions of 2 x 2 finer cells (nested borders)
        b, _, _, C = levels[-1].shape
        levels.append(levels[-1].reshape(b, n, 2, n, 2, C).sum(axis=(2, 4)))
    b = images.shape[0]
    if config.normalize == "cell":
        levels = [h / jnp.where(h.sum(-1, keepdims=True) > 0, h.sum(-1, keepdims=True), 1.0) for h in levels]
    feats = jnp.concatenate([h.reshape(b, -1) for h in levels], axis=-1)
    if config.normalize == "global":
        total = finest.reshape(b, -1).sum(-1, keepdims=True)
        feats = feats / jnp.where(total > 0, total, 1.0)
    return feats


_CHUNK_PIXELS = 1 << 20  # images per chunk ~ 1 Mpixel / (H W): the working set stays in cache


@partial(jax.jit, static_argnames=("config",))
def _hog_jit(images, mask, config: HOGConfig):
    """(B, H, W) -> (B, D). The batch is processed in chunks with `lax.map` (padded with copies of
    the first image, cut off afterwards): each chunk's working set stays in cache, where one pass over
    the whole batch would not (see `experiments/bench/bench_hog.py` for the measured effect)."""
    B, H, W = images.shape
    chunk = max(1, min(B, _CHUNK_PIXELS // (H * W)))
    n_chunks = -(-B // chunk)
    pad = n_chunks * chunk - B
    shape = (n_chunks, chunk, H, W)
    if pad:
        images = jnp.concatenate([images, jnp.broadcast_to(images[:1], (pad, H, W))], axis=0)
    if mask is None:
        feats = jax.lax.map(lambda a: _hog_chunk(a, None, config), images.reshape(shape))
    else:
        if pad:
            mask = jnp.concatenate([mask, jnp.broadcast_to(mask[:1], (pad, H, W))], axis=0)
        xs = (images.reshape(shape), mask.reshape(shape))
        feats = jax.lax.map(lambda a: _hog_chunk(a[0], a[1], config), xs)
    return feats.reshape(n_chunks * chunk, -1)[:B]


def _hog_shard(images, *mask, config: HOGConfig):
    """`_hog_jit` on one shard's images (B/S, H, W) and, if given, their mask."""
    return _hog_jit(images, mask[0] if mask else None, config)


@jax.jit
def _image_stats(images):
    """Per image: (all finite, max |I|) for a (B, H, W) device array."""
    flat = images.reshape(images.shape[0], -1)
    return jnp.isfinite(flat).all(axis=1), jnp.max(jnp.abs(flat), axis=1)


_SAFE_LO, _SAFE_HI = 2.0**-40, 2.0**60  # max |I| per image for which gradients squared fit float32


def _rescale_exponents(peak: np.ndarray) -> np.ndarray | None:
    """Per image e with peak / 2^e in [1, 2) where peak (max |I|, > 0) is outside the safe range, 0
    elsewhere; None when every image is inside it."""
    out = (peak > _SAFE_HI) | (peak < _SAFE_LO)
    if not out.any():
        return None
    return np.where(out, np.frexp(peak.astype(np.float64))[1] - 1, 0).astype(np.int32)


def _times_pow2(x, e: np.ndarray):
    """x (B, ...) * 2^e[b] per row, exactly (numpy: ldexp; jax: two power-of-two factors, each a
    normal float32)."""
    shape = (-1,) + (1,) * (x.ndim - 1)
    if isinstance(x, np.ndarray):
        return np.ldexp(x, e.reshape(shape)).astype(np.float32, copy=False)
    half = e // 2
    f1 = np.ldexp(np.float32(1), half).astype(np.float32).reshape(shape)
    f2 = np.ldexp(np.float32(1), e - half).astype(np.float32).reshape(shape)
    return x * jnp.asarray(f1) * jnp.asarray(f2)


_STREAM_PIXELS = 1 << 22  # host (numpy) input is sent to the device in chunks of ~4 Mpixel


def _check_images(images):
    """Validate a (B, H, W) batch (numpy or jax) -> (float32 array of the same kind, per-image
    rescale exponents or None; see `_rescale_exponents`)."""
    if isinstance(images, jax.Array):
        if images.ndim not in (2, 3):
            raise ValueError(f"images: expected a 2-D image or a 3-D batch (B, H, W), got shape {images.shape}")
        if images.size == 0:
            raise ValueError(f"images: must not be empty, got shape {images.shape}")
        arr = images.astype(jnp.float32)
        arr = arr[None] if arr.ndim == 2 else arr
        finite, peak = (np.asarray(v) for v in _image_stats(arr))
        nonzero = peak != 0
        source = None
    else:
        arr = as_array(images, "images", ndim=(2, 3), dtype=None, finite=False)
        if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
            raise ValueError(f"images: expected a numeric array, got dtype {arr.dtype}")
        source = arr[None] if arr.ndim == 2 else arr
        with np.errstate(over="ignore"):
            arr = np.asarray(source, np.float32)
        flat = arr.reshape(arr.shape[0], -1)
        hi, lo = flat.max(axis=1), flat.min(axis=1)  # NaN propagates; two passes, no temporaries
        finite, nonzero = np.isfinite(hi) & np.isfinite(lo), (hi != 0) | (lo != 0)
        peak = np.maximum(np.abs(hi), np.abs(lo))
    if not finite.all():
        b = int(np.argmin(finite))
        if source is not None and np.all(np.isfinite(source[b])):
            raise ValueError(f"images: image {b} has values up to {np.max(np.abs(source[b])):.3g}, beyond "
                             f"float32's range ({np.finfo(np.float32).max:.3g})")
        raise ValueError(f"images: image {b} contains NaN or infinite pixels")
    if not nonzero.all():
        raise ValueError(f"images: image {int(np.argmin(nonzero))} is all zero (nothing to describe)")
    return arr, _rescale_exponents(peak)


def hog(images: Real[ArrayLike, "B H W"] | Real[ArrayLike, "H W"], config: HOGConfig = HOGConfig(),
        mask: Bool[ArrayLike, "B H W"] | Bool[ArrayLike, "H W"] | None = None, *, mesh: Mesh | None = None
        ) -> Float[Array, "B D"] | Float[Array, " D"]:
    """HOG features of a batch of grayscale images (GRASP eq. 1, §IV; LfD 2009).

    Gradients are central differences (gx down the rows, gy along the columns, zero on the borders);
    each pixel votes into the orientation bin of its cell at every level; the histograms are
    normalised as `config.normalize` says. Any finite image is accepted: one whose largest |I| lies
    outside [2^-40, 2^60] (where gx^2 + gy^2 would leave float32) is first multiplied by an exact
    power of two, which leaves normalised features unchanged. The computation is one jitted function
    of the batch (compiled once per batch shape and config); a numpy batch is streamed to the device
    in chunks of about 4 Mpixel, a jax array used in place.

    Args:
        images: (B, H, W) real images (numpy or jax), or one (H, W) image. Finite; no image may be all
            zero; H and W at least the cells per side of the finest level.
        config: the HOG options (`HOGConfig`; defaults: GRASP's 4 bins, 3 levels, eq. 1 orientation,
            magnitude weighting, hard binning, global normalisation).
        mask: optional bool array of the images' shape; False pixels do not vote (the gradient is still
            computed from the image as given). Each image needs a True pixel.
        mesh: a `jax.sharding.Mesh`, or None for one device. The images are split over its devices
            (padded to the mesh, the padding cut off); the features equal the one-device features. With
            several processes each passes its own images and gets its own rows.

    Returns:
        (B, D) float32 features, or (D,) for one image; D = `hog_dim(config)`.

    Raises:
        ValueError: naming the argument for an invalid config, images that are not 2-D or 3-D, empty,
            non-numeric, NaN or infinite, all zero or smaller than the finest cells, a mask of another
            shape or with an image without a True pixel, raw (normalize="none") sums that overflow
            float32 (`images`), or a `mesh` that is not a `jax.sharding.Mesh`.
    """
    _check_config(config)
    mesh = check_mesh(mesh)
    single = np.ndim(images) == 2
    arr, shift = _check_images(images)
    B, H, W = arr.shape
    need = max(_cells_per_side(config))
    if H < need or W < need:
        raise ValueError(f"images: {H}x{W} is smaller than the {need}x{need} cells of the finest level")
    m = None
    if mask is not None:
        m = as_array(mask, "mask", dtype=bool)
        if m.ndim == 2 and single:
            m = m[None]
        if m.shape != (B, H, W):
            want = (H, W) if single else (B, H, W)
            raise ValueError(f"mask: expected shape {want}, got {np.shape(mask)}")
        has = m.reshape(B, -1).any(axis=1)
        if not has.all():
            raise ValueError(f"mask: image {int(np.argmin(has))} has no unmasked pixel")
    if shift is not None:  # out of the safe range: computed on arr / 2^shift (exact)
        arr = _times_pow2(arr, -shift)
    if mesh is not None:
        out = map_batch(_hog_shard, mesh, (), (arr,) if m is None else (arr, m), static=(("config", config),))
    elif isinstance(arr, jax.Array):
        out = _hog_jit(arr, None if m is None else jnp.asarray(m), config)
    else:
        out = _hog_stream(arr, m, config)
    if shift is not None and config.normalize == "none" and config.weighting == "magnitude":
        out = _times_pow2(out, shift)  # raw magnitude sums scale with the image
        ok = np.isfinite(np.asarray(out)).all(axis=1)
        if not ok.all():
            raise ValueError(f"images: the raw (normalize='none') gradient sums of image {int(np.argmin(ok))} "
                             "overflow float32; scale the images down or normalise")
    return out[0] if single else out


def _hog_stream(arr: np.ndarray, mask, config: HOGConfig):
    """Host batch -> (B, D) on the device, in fixed-size chunks (the last one padded)."""
    B, H, W = arr.shape
    chunk = max(1, min(B, _STREAM_PIXELS // (H * W)))
    outs = []
    for start in range(0, B, chunk):
        x = arr[start:start + chunk]
        mx = None if mask is None else mask[start:start + chunk]
        short = chunk - x.shape[0]
        if short:
            x = np.concatenate([x, np.broadcast_to(x[:1], (short, H, W))])
            mx = None if mx is None else np.concatenate([mx, np.broadcast_to(mx[:1], (short, H, W))])
        outs.append(_hog_jit(jax.device_put(x), None if mx is None else jax.device_put(mx), config))
    return jnp.concatenate(outs, axis=0)[:B] if len(outs) > 1 else outs[0][:B]
