"""Numerical pieces of the level sets (`levelset`): the smoothed Heaviside and delta of eqs. 5-6,
central-difference operators with replicated borders (TR §5), curvature, contour length, exact
signed distances, max over the other regions, and resampling between the two scales.

Shapes: R regions, H x W pixels; operators act on the last two axes.
"""
from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

__all__ = ["contour_length", "curvature", "dirac", "heaviside", "signed_distance"]

_ETA = 1e-6  # added to |grad phi|^2 in the unit normal: 0/0 -> 0, never NaN; and where the central
# difference vanishes (a ridge of phi) float32 rounding of up to ~1e-5 must not pick a direction


def _half_angle(phi, epsilon):
    """(x, sin(pi x / 2), cos(pi x / 2)) for x = phi / epsilon clipped to [-1, 1], the sine and cosine
    by their Taylor polynomials on [-pi/2, pi/2] (error < 1e-9): eqs. 5-6 need nothing else, and
    XLA:CPU's sin and cos (range reduction for any argument) cost ten times as much."""
    x = jnp.clip(jnp.asarray(phi) / epsilon, -1.0, 1.0)
    y = 0.5 * jnp.pi * x
    u = y * y
    sin = cos = 0.0
    for k in range(7, -1, -1):  # Horner in u = y^2: sin y = y sum (-u)^k / (2k+1)!, cos y = sum (-u)^k / (2k)!
        sin = sin * u + (-1) ** k / math.factorial(2 * k + 1)
        cos = cos * u + (-1) ** k / math.factorial(2 * k)
    return x, y * sin, cos


@jax.jit
def heaviside(phi: Float[ArrayLike, "*shape"], epsilon: float = 1.5) -> Float[Array, "*shape"]:
    """The smoothed Heaviside of LEVELSET TR eq. 5 (jitted).

    0 below -epsilon, 1 above epsilon, else 1/2 + phi / (2 epsilon) + sin(pi phi / epsilon) / (2 pi).

    Args:
        phi: level-set values of any shape.
        epsilon: the half-width, pixels, > 0.

    Returns:
        H(phi), of the shape of `phi`.
    """
    x, sin, cos = _half_angle(phi, epsilon)
    return 0.5 + 0.5 * x + sin * cos / jnp.pi


@jax.jit
def dirac(phi: Float[ArrayLike, "*shape"], epsilon: float = 1.5) -> Float[Array, "*shape"]:
    """The smoothed delta of LEVELSET TR eq. 6, the derivative of eq. 5's Heaviside (jitted).

    0 outside [-epsilon, epsilon], else (1 + cos(pi phi / epsilon)) / (2 epsilon)
    = cos^2(pi phi / (2 epsilon)) / epsilon.

    Args:
        phi: level-set values of any shape.
        epsilon: the half-width, pixels, > 0.

    Returns:
        delta(phi), of the shape of `phi`.
    """
    _, _, cos = _half_angle(phi, epsilon)
    return cos * cos / epsilon


def pad_edge(f, rows: bool = True, cols: bool = True):
    """f (..., H, W) with its first and last rows (`rows`) and then columns (`cols`) repeated once
    outside: the replicated border (Neumann condition) of the central differences. One padded copy
    whose slices are the shifted neighbours: XLA:CPU fuses slices into their consumers, where a
    concatenation per shift was a copy of the whole array each (the same bits, a faster step)."""
    if rows:
        f = jnp.concatenate([f[..., :1, :], f, f[..., -1:, :]], axis=-2)
    if cols:
        f = jnp.concatenate([f[..., :1], f, f[..., -1:]], axis=-1)
    return f


def _neighbours(f):
    """(f[i + 1, j], f[i - 1, j], f[i, j + 1], f[i, j - 1]) over the last two axes, replicated border."""
    p = pad_edge(f)
    return p[..., 2:, 1:-1], p[..., :-2, 1:-1], p[..., 1:-1, 2:], p[..., 1:-1, :-2]


def gradient(f):
    """Central differences (d/drow, d/dcol) over the last two axes, replicated border."""
    below, above, right, left = _neighbours(f)
    return (below - above) / 2.0, (right - left) / 2.0


def laplacian(f):
    below, above, right, left = _neighbours(f)  # the same padded copy as `gradient`'s (XLA's CSE)
    return below + above + right + left - 4.0 * f


def unit_normal(phi):
    """grad phi / |grad phi| and |grad phi| (with the _ETA floor) by central differences."""
    gy, gx = gradient(phi)
    sq = gy * gy + gx * gx + _ETA
    inv = jax.lax.rsqrt(sq)
    return gy * inv, gx * inv, sq * inv


def divergence(ny, nx):
    """d ny / drow + d nx / dcol, central differences, replicated border (each padded along its own axis)."""
    rows, cols = pad_edge(ny, cols=False), pad_edge(nx, rows=False)
    return (rows[..., 2:, :] - rows[..., :-2, :]) / 2.0 + (cols[..., 2:] - cols[..., :-2]) / 2.0


@jax.jit
def curvature(phi: Float[ArrayLike, "*batch H W"]) -> Float[Array, "*batch H W"]:
    """The curvature kappa = div(grad phi / |grad phi|) of LEVELSET TR eqs. 4 and 7 (jitted).

    Central differences with a replicated border (TR §5), over the last two axes. For
    phi = |x - c| - r (a circle's signed distance, positive outside) kappa = 1/|x - c|.

    Args:
        phi: (..., H, W) level sets.

    Returns:
        (..., H, W) kappa.
    """
    ny, nx, _ = unit_normal(jnp.asarray(phi))
    return divergence(ny, nx)


@jax.jit
def contour_length(phi: Float[ArrayLike, "*batch R H W"], epsilon: float = 1.5) -> Float[Array, " *batch"]:
    """The total contour length, LEVELSET TR §5's stopping quantity (jitted).

    sum_i sum_x |grad H(phi_i)| = sum_i sum_x delta(phi_i) |grad phi_i| (the chain rule), in pixels,
    over the last three axes.

    Args:
        phi: (..., R, H, W) level sets.
        epsilon: the half-width of eq. 6, pixels, > 0.

    Returns:
        (...) the lengths.
    """
    phi = jnp.asarray(phi)
    return jnp.sum(dirac(phi, epsilon) * unit_normal(phi)[2], axis=(-3, -2, -1))


# ------------------------------------------------------------------------------ signed distance
def sq_edt(sites):
    """Exact squared Euclidean distance of every pixel to the nearest True of `sites` (..., H, W),
    separable (Felzenszwalb & Huttenlocher: a column pass, then a row pass over its result), each
    1-D lower envelope by brute force: O(H W (H + W)), two fused reductions (cheap to compile; used
    at the coarse scale). (H + W)^2 where there is no site."""
    H, W = sites.shape[-2:]
    big = float((H + W) ** 2)
    r = jnp.arange(H, dtype=jnp.float32)
    g = jnp.min(jnp.where(sites, 0.0, big)[..., None, :, :] + ((r[:, None] - r[None, :]) ** 2)[:, :, None], axis=-2)
    c = jnp.arange(W, dtype=jnp.float32)
    return jnp.minimum(jnp.min(g[..., :, None, :] + (c[:, None] - c[None, :]) ** 2, axis=-1), big)


@jax.jit
def signed_distance(mask: Bool[ArrayLike, "*batch H W"]) -> Float[Array, "*batch H W"]:
    """The exact signed Euclidean distance to a region's edge, positive inside (jitted).

    A pixel's value is its centre's distance to the nearest pixel of the other side, minus half a
    pixel, so the zero level lies between the two pixel centres and the complement's distance is
    exactly the negative: the distance function that LEVELSET TR eqs. 4-7 assume of phi.

    Args:
        mask: (..., H, W) bool regions.

    Returns:
        (..., H, W) float32 distances, at most H + W in magnitude (an empty or full mask).
    """
    m = jnp.asarray(mask, bool)
    inside = jnp.sqrt(sq_edt(~m)) - 0.5
    outside = jnp.sqrt(sq_edt(m)) - 0.5
    return jnp.where(m, inside, -outside)


def max_others(e):
    """max_{j != i} e_j for every i, e (R, ...): R (R - 1) elementwise maxima, one fused loop (R is
    small; an argmax or a tie-aware reduction compiles and runs slower on XLA:CPU)."""
    R = e.shape[0]
    return jnp.stack([functools.reduce(jnp.maximum, [e[j] for j in range(R) if j != i]) for i in range(R)])


@functools.lru_cache(maxsize=64)
def resize_matrix(n: int, m: int) -> np.ndarray:
    """(m, n) weights of jax.image.resize's "linear" antialiased resampling of one axis from n to m
    (its scale_and_translate with a triangle kernel widened by n / m when shrinking), in numpy."""
    inv = n / m
    sample = (np.arange(m) + 0.5) * inv - 0.5
    w = np.maximum(0.0, 1.0 - np.abs(sample[:, None] - np.arange(n)[None, :]) / max(inv, 1.0))
    w /= w.sum(axis=1, keepdims=True)
    return w.astype(np.float32)


def resize(x, hw):
    """jax.image.resize(x, (..., h, w), "linear", antialias=True) as two small matrix products (its
    weights; results agree to ~1e-5 relative, at the borders when enlarging), because the level-set
    loop after it ran about 1.4x faster on XLA:CPU than after jax.image.resize itself (measured; a
    layout choice, we suspect)."""
    rows, cols = resize_matrix(x.shape[-2], hw[0]), resize_matrix(x.shape[-1], hw[1])
    return jnp.einsum("hH,...HW,wW->...hw", rows, x, cols)
