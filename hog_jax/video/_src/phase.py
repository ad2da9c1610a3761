"""Gradient phase Psi of Gaussian-blurred grey images (LfD 2009 §III-B; `phase_segmentation`'s module
docstring): on whole frames (`frame_phase`, behind `gradient_phase`) and on crops around a window
(`crop_phase`, what `segment_objects` computes), the two equal value for value.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int, Real

__all__ = ["crop_phase", "frame_phase", "gaussian_kernel"]


def gaussian_kernel(sigma: float) -> np.ndarray:
    """Normalised samples of a Gaussian at the integers (the blur before the phase, LfD 2009 §III-B).

    Args:
        sigma: the standard deviation, pixels, > 0.

    Returns:
        (2 r + 1,) float32 weights summing to 1, radius r = round(4 sigma) (scipy's default).
    """
    radius = int(4.0 * sigma + 0.5)
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    k = np.exp(-0.5 * (x / sigma) ** 2)
    return (k / k.sum()).astype(np.float32)


def _convolve(padded, kernel):
    """Separable valid-mode convolution: (H + 2r, W + 2r) -> (H, W) for a kernel of radius r."""
    H, W = padded.shape[0] - len(kernel) + 1, padded.shape[1] - len(kernel) + 1
    rows = sum(kernel[i] * padded[i:i + H, :] for i in range(len(kernel)))
    return sum(kernel[i] * rows[:, i:i + W] for i in range(len(kernel)))


def _blur(image, kernel):
    """Separable Gaussian blur of (H, W) with symmetric padding (d c b a | a b c d)."""
    return _convolve(jnp.pad(image, (len(kernel) - 1) // 2, mode="symmetric"), kernel)


def _psi(gy, gx):
    """Psi = arctan(gy / gx) in degrees, modulo 180 (an orientation)."""
    return _wrap(jnp.degrees(jnp.arctan2(gy, gx)))


@jax.jit
def frame_phase(images, kernel):
    """Psi (B, H, W) of whole grey images (B, H, W): symmetric padding, jnp.gradient's borders."""
    return jax.vmap(lambda image: _psi(*jnp.gradient(_blur(image, kernel))))(images)


def _wrap(d):
    """Degrees modulo 180 into [-90, 90)."""
    return jnp.mod(d + 90.0, 180.0) - 90.0


def _reflect(index, n: int):
    """Indices of the symmetric padding (d c b a | a b c d | d c b a ...) into an axis of n samples."""
    m = jnp.mod(index, 2 * n)
    return jnp.where(m < n, m, 2 * n - 1 - m)


def _gradient(b, index, n: int):
    """jnp.gradient along axis 0 at the inner rows of b (one extra row on each side), rows `index` of
    an axis of n samples: central differences, one-sided at rows 0 and n - 1."""
    lo, mid, hi = b[:-2], b[1:-1], b[2:]
    index = index[:, None]
    return jnp.where(index == 0, hi - mid, jnp.where(index == n - 1, mid - lo, (hi - lo) * 0.5))


def crop_phase(image: Real[Array, "H W"], centre: Int[Array, " 2"], half: tuple[int, int],
               kernel: Float[ArrayLike, " K"]) -> Float[Array, "h w"]:
    """The gradient phase Psi of a window of an image, computed on a crop only (LfD 2009 §III-B).

    The window of `gradient_phase(image)`: the crop has a margin of the kernel's radius plus the
    gradient's one pixel; its samples beyond the image are those of the full frame's symmetric
    padding, and the gradient is one-sided at the image's first and last rows and columns, so every
    value is the same arithmetic on the same numbers as the full-frame computation. Traceable; no
    input checks.

    Args:
        image: (H, W) a grey image.
        centre: (2,) int the window's centre (row, column).
        half: (hh, hw) the window's half sizes (static).
        kernel: (2 r + 1,) the blur (`gaussian_kernel`).

    Returns:
        (2 hh + 1, 2 hw + 1) Psi in degrees in [-90, 90), NaN outside the image.
    """
    H, W = image.shape
    r = (kernel.shape[0] - 1) // 2
    rows = centre[0] + jnp.arange(-half[0] - r - 1, half[0] + r + 2)
    cols = centre[1] + jnp.arange(-half[1] - r - 1, half[1] + r + 2)
    crop = image[_reflect(rows, H)[:, None], _reflect(cols, W)[None, :]].astype(jnp.float32)
    blurred = _convolve(crop, kernel)  # (h + 2, w + 2)
    rows, cols = rows[r + 1:-r - 1], cols[r + 1:-r - 1]
    psi = _psi(_gradient(blurred[:, 1:-1], rows, H), _gradient(blurred[1:-1].T, cols, W).T)
    inside = ((rows >= 0) & (rows < H))[:, None] & ((cols >= 0) & (cols < W))[None, :]
    return jnp.where(inside, psi, jnp.nan)
