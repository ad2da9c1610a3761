"""The skin model under a scene's light: gray-world gains (Buchsbaum 1980) and the skin model seen
through them (a von Kries diagonal transform of RGB).

A skin model fitted on photos under near-neutral light (`lfd_jax.fit_real_skin_model`) does not see
skin under a strongly coloured light: on a warm, palette-dithered camera clip the hands' pixels sit
many standard deviations from every skin component. Gray world estimates the light of a scene from
the mean of its pixels (the scene's average is taken to be gray) and gives per-channel gains g that
would make it so. `balanced_skin_model(model, g)` is the model of the pixels x whose balanced colour
g * x the original model describes: for a (Cr, Cb, Y) model, whose features u = A x + c are affine
in RGB, the balanced features are M (u - c) + c with M = A diag(g) A^-1, so each component
N(mu, S) becomes N(M^-1 (mu - c) + c, M^-1 S M^-T), exactly, the density carrying the Jacobian
|det M| = prod(g). Applied to a model once, it costs nothing per pixel.

Gray world needs a scene that is not dominated by skin: the frames of a recording whose person is a
part of the view. On close-up photos of a hand (HGR) it takes the hand's tone for the light and
removes it (the mask IoU of the one skin model fell from 0.84 to 0.21 on validation photos), so it
is an option of the video front end (`VideoOptions.white_balance`), not of still photos.
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float, Real

from hog_jax._src.segment import GMM, SkinModel
from lfd_common import as_array

__all__ = ["YCRCB_FROM_RGB", "balanced_skin_model", "gray_world_gains"]

# (Cr, Cb, Y) from RGB, both / 255 (BT.601 with OpenCV's coefficients, `hog_jax.skin_features`); the
# features are YCRCB_FROM_RGB @ rgb + YCRCB_OFFSET
YCRCB_FROM_RGB = np.array([[0.713 * (1 - 0.299), -0.713 * 0.587, -0.713 * 0.114],
                           [-0.564 * 0.299, -0.564 * 0.587, 0.564 * (1 - 0.114)],
                           [0.299, 0.587, 0.114]])
YCRCB_OFFSET = np.array([128.0, 128.0, 0.0]) / 255.0
CLIPPED = 250.0  # pixels with a channel at or above this are saturated and say nothing of the light


def gray_world_gains(frames: Real[ArrayLike, "*B H W 3"]) -> Float[np.ndarray, "3"]:
    """Per-channel gains that make the mean colour of `frames` gray (Buchsbaum 1980).

    Pixels with a saturated channel (>= 250) are left out. The gains keep the mean's average level:
    g_c = mean_k(m_k) / m_c for the channel means m.

    Args:
        frames: (..., H, W, 3) RGB in [0, 255], finite.

    Returns:
        (3,) float64 gains, positive.

    Raises:
        ValueError: naming `frames` for a last axis other than 3, values out of range or non-finite,
            no unsaturated pixel, or a channel that is black on every unsaturated pixel.
    """
    arr = as_array(frames, "frames", dtype=np.float64, min_value=0, max_value=255)
    if arr.ndim < 3 or arr.shape[-1] != 3:
        raise ValueError(f"frames: expected (..., H, W, 3) RGB, got shape {arr.shape}")
    pixels = arr.reshape(-1, 3)
    pixels = pixels[(pixels < CLIPPED).all(axis=1)]
    if not len(pixels):
        raise ValueError("frames: every pixel is saturated (a channel >= 250); gray world has nothing to measure")
    means = pixels.mean(axis=0)
    if (means <= 0).any():
        raise ValueError(f"frames: channel means {means.round(3).tolist()}: a black channel has no gray-world gain")
    return means.mean() / means


def _balanced_mixture(gmm: GMM, to_balanced: np.ndarray) -> GMM:
    back = np.linalg.inv(to_balanced)
    means = (np.asarray(gmm.means, np.float64) - YCRCB_OFFSET) @ back.T + YCRCB_OFFSET
    chols = np.asarray(gmm.chols, np.float64)
    covs = back @ chols @ np.swapaxes(chols, -1, -2) @ back.T
    dtype = gmm.means.dtype
    return GMM(gmm.log_weights, jnp.asarray(means, dtype), jnp.asarray(np.linalg.cholesky(covs), dtype))


def balanced_skin_model(model: SkinModel, gains: Float[ArrayLike, "3"]) -> SkinModel:
    """The skin model of pixels whose colour times `gains` the model describes (module docstring).

    For every RGB pixel x: `skin_log_ratio(balanced, x) == skin_log_ratio(model, gains * x)`, and each
    mixture's log-density of x's features is the original's at gains * x plus sum(log gains).

    Args:
        model: a `SkinModel` over (Cr, Cb, Y) / 255 (`fit_skin_model(..., luma=True)`).
        gains: (3,) positive finite per-channel (R, G, B) gains, e.g. `gray_world_gains`.

    Returns:
        The balanced `SkinModel`, the threshold kept.

    Raises:
        ValueError: naming the argument for a model without the luma channel (a (Cr, Cb) model's
            chroma of g * x depends on the luma it dropped) or gains that are not 3 positive finite values.
    """
    if not isinstance(model, SkinModel):
        raise ValueError(f"model: expected a hog_jax.SkinModel, got {type(model).__name__}")
    if model.skin.means.shape[-1] != 3:
        raise ValueError("model: white balance needs a (Cr, Cb, Y) skin model (fit_skin_model(..., luma=True)); "
                         f"this one has {model.skin.means.shape[-1]} channels")
    g = as_array(gains, "gains", dtype=np.float64, shape=(3,), min_value=0)
    if (g <= 0).any():
        raise ValueError(f"gains: expected 3 positive values, got {g.tolist()}")
    to_balanced = YCRCB_FROM_RGB @ np.diag(g) @ np.linalg.inv(YCRCB_FROM_RGB)
    return SkinModel(_balanced_mixture(model.skin, to_balanced), _balanced_mixture(model.background, to_balanced),
                     model.threshold)
