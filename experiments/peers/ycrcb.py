"""The fixed YCrCb skin rule, the classic peer of learnt skin models: Cr in [133, 173] and Cb in
[77, 127] (Chai & Ngan, "Face segmentation using skin-color map in videophone applications", IEEE TCSVT
9(4), 1999; the recipe usually written as `cv2.inRange(cv2.cvtColor(img, cv2.COLOR_BGR2YCrCb),
(0, 133, 77), (255, 173, 127))`), on OpenCV's 8-bit YCrCb computed in JAX with OpenCV's fixed-point
arithmetic, so that it equals cv2.inRange bit for bit, batched.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

CR_RANGE = (133, 173)  # Chai & Ngan 1999, the skin-colour map's R_Cr
CB_RANGE = (77, 127)   # and R_Cb, both inclusive (as cv2.inRange)
# OpenCV's RGB -> YCrCb for 8-bit images (imgproc color_yuv: fixed point with 14 fractional bits)
_SHIFT = 14
_Y_COEFFS = (4899, 9617, 1868)  # round(2^14 * (0.299, 0.587, 0.114))
_CR_COEFF, _CB_COEFF = 11682, 9241  # round(2^14 * 0.713), round(2^14 * 0.564)


def ycrcb_u8(rgb: jax.Array) -> jax.Array:
    """(..., 3) int32 (Y, Cr, Cb) of integer RGB (..., 3) in [0, 255], exactly as OpenCV's
    `COLOR_RGB2YCrCb` on uint8: Y rounded first, then Cr = (R - Y) 0.713 + 128 and Cb = (B - Y) 0.564
    + 128 in 14-bit fixed point, rounded and saturated to [0, 255]."""
    c = jnp.asarray(rgb).astype(jnp.int32)
    r, g, b = c[..., 0], c[..., 1], c[..., 2]
    half, offset = 1 << (_SHIFT - 1), 128 << _SHIFT
    y = (r * _Y_COEFFS[0] + g * _Y_COEFFS[1] + b * _Y_COEFFS[2] + half) >> _SHIFT
    cr = ((r - y) * _CR_COEFF + offset + half) >> _SHIFT
    cb = ((b - y) * _CB_COEFF + offset + half) >> _SHIFT
    return jnp.clip(jnp.stack([y, cr, cb], axis=-1), 0, 255)


def ycrcb_rule(rgb: jax.Array) -> jax.Array:
    """(...) bool: Cr in CR_RANGE and Cb in CB_RANGE (inclusive) for integer RGB (..., 3)."""
    ycc = ycrcb_u8(rgb)
    cr, cb = ycc[..., 1], ycc[..., 2]
    return (cr >= CR_RANGE[0]) & (cr <= CR_RANGE[1]) & (cb >= CB_RANGE[0]) & (cb <= CB_RANGE[1])
