"""A skin model adapted to each frame: MAP-EM from the global skin model.

Shapes: B frames, H x W pixels, N = H W, G_s / G_b skin / background components, P = 2 chroma.

A skin model fitted on other hands and other scenes (`fit_skin_model`) is a prior, not the truth of
one frame: the hand in it has its own tone under its own light, and the background its own colours.
`adapt_skin_model` re-estimates, per frame, both mixtures and the share of skin pixels by EM over all
the frame's pixels (chroma), with the global mixtures as conjugate priors (maximum a posteriori
adaptation, Gauvain & Lee 1994; Reynolds et al. 2000): a component that n_k pixels' responsibility
falls on moves its weight, mean and covariance from the prior's towards the frame's statistics by
n_k / (n_k + r), r the `relevance` (in pixels). Background components that take a flat clutter
colour become tight around it, so skin-coloured clutter loses the likelihood ratio it had under the
broad global background model; skin components follow the frame's hand. The E step uses the joint
mixture of skin (prior weight π) and background (1 - π); π is re-estimated each iteration. Frames
are processed one after another by `lax.map` (an iteration holds N x (G_s + G_b) responsibilities),
each iteration vectorised over pixels. Covariances are 2 x 2, factored in closed form (no LAPACK call,
see `segment.whiten`).
"""
from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Real

from hog_jax._src.segment import (GMM, Segmentation, SkinModel, log_ratio, whiten, crop_components,
    median3, rgb_to_chroma)
from lfd_common import as_array, check_int, check_real

__all__ = ["adapt_skin_model", "segment_adapted"]


def _chol2(cov):
    """Lower Cholesky factors of (..., 2, 2) symmetric positive-definite matrices, in closed form."""
    l00 = jnp.sqrt(cov[..., 0, 0])
    l10 = cov[..., 1, 0] / l00
    l11 = jnp.sqrt(jnp.maximum(cov[..., 1, 1] - l10 ** 2, 1e-12))
    zero = jnp.zeros_like(l00)
    return jnp.stack([jnp.stack([l00, zero], -1), jnp.stack([l10, l11], -1)], -2)


def _component_log_probs(gmm: GMM, x):
    """(N, G) log w_g + log N(x_n; mu_g, Sigma_g) for chroma x (N, P)."""
    maha = jnp.sum(whiten(gmm.chols, x[:, None, :] - gmm.means) ** 2, axis=-1)
    logdet = jnp.sum(jnp.log(jnp.diagonal(gmm.chols, axis1=-2, axis2=-1)), axis=-1)
    return gmm.log_weights - 0.5 * maha - logdet - 0.5 * x.shape[-1] * jnp.log(2 * jnp.pi)


def _map_update(prior: GMM, resp, x, relevance, reg) -> GMM:
    """MAP M step of one mixture: responsibilities (N, G) of pixels x (N, P), prior mixture `prior`."""
    n = resp.sum(0)                                                  # (G,)
    sx = resp.T @ x                                                  # (G, P)
    sxx = jnp.einsum("ng,ni,nj->gij", resp, x, x)                    # (G, P, P)
    mu0 = prior.means
    second0 = prior.chols @ jnp.swapaxes(prior.chols, -1, -2) + mu0[:, :, None] * mu0[:, None, :]
    mean = (sx + relevance * mu0) / (n + relevance)[:, None]
    second = (sxx + relevance * second0) / (n + relevance)[:, None, None]
    cov = second - mean[:, :, None] * mean[:, None, :] + reg * jnp.eye(x.shape[-1])
    G = n.shape[0]
    w = n + relevance * G * jnp.exp(prior.log_weights)
    return GMM(jnp.log(w / w.sum()), mean, _chol2(cov))


@partial(jax.jit, static_argnames=("n_iter", "adapt_skin"))
def _adapt(model: SkinModel, chroma, n_iter: int, relevance, reg, adapt_skin: bool):
    def one(x):
        def step(_, state):
            skin, background, log_pi = state
            ls = _component_log_probs(skin, x) + log_pi
            lb = _component_log_probs(background, x) + jnp.log1p(-jnp.exp(log_pi))
            resp = jax.nn.softmax(jnp.concatenate([ls, lb], axis=1), axis=1)
            g = skin.log_weights.shape[0]
            share = jnp.clip(resp[:, :g].sum() / x.shape[0], 1e-4, 1.0 - 1e-4)
            return (_map_update(model.skin, resp[:, :g], x, relevance, reg) if adapt_skin else skin,
                    _map_update(model.background, resp[:, g:], x, relevance, reg), jnp.log(share))

        skin, background, _ = jax.lax.fori_loop(0, n_iter, step, (model.skin, model.background, jnp.log(0.5)))
        return SkinModel(skin, background, model.threshold)

    return jax.lax.map(one, chroma)


def adapt_skin_model(model: SkinModel, frames: Real[ArrayLike, "B H W 3"], n_iter: int = 5,
                     relevance: float = 256.0, adapt_skin: bool = True, reg: float = 1e-5) -> SkinModel:
    """Per-frame skin models, adapted to each frame by MAP-EM from a global one (GRASP §III-A's model).

    Both mixtures and the share of skin pixels are re-estimated per frame by EM over all the frame's
    pixels (chroma), with the global mixtures as conjugate priors (maximum a posteriori adaptation,
    Gauvain & Lee 1994; Reynolds et al. 2000): a component that n_k pixels' responsibility falls on
    moves its weight, mean and covariance from the prior's towards the frame's statistics by
    n_k / (n_k + r). Background components that take a flat clutter colour become tight around it,
    so skin-coloured clutter loses the likelihood ratio it had under the broad global model.

    Args:
        model: the global `SkinModel` (`fit_skin_model`), the prior.
        frames: (B, H, W, 3) RGB frames in [0, 255].
        n_iter: MAP-EM iterations, >= 1.
        relevance: r > 0, in pixels.
        adapt_skin: False keeps the skin mixture as it is (only the background mixture and the skin
            share adapt).
        reg: the covariance floor, in (0, 1].

    Returns:
        A `SkinModel` whose every array has a leading B axis (`segment_adapted` segments with it).

    Raises:
        ValueError: naming the argument for frames of the wrong shape or range, n_iter < 1,
            relevance <= 0, adapt_skin not a bool, or reg out of range.
    """
    arr = as_array(frames, "frames", ndim=4, dtype=np.float32, min_value=0, max_value=255)
    if arr.shape[-1] != 3:
        raise ValueError(f"frames: expected (B, H, W, 3) RGB frames, got shape {arr.shape}")
    n_iter = check_int(n_iter, "n_iter", min_value=1)
    relevance = check_real(relevance, "relevance", min_value=0.0, exclusive_min=True, max_value=1e12)
    if not isinstance(adapt_skin, (bool, np.bool_)):
        raise ValueError(f"adapt_skin: expected a bool, got {type(adapt_skin).__name__}")
    reg = check_real(reg, "reg", min_value=0.0, exclusive_min=True, max_value=1.0)
    chroma = rgb_to_chroma(jnp.asarray(arr)).reshape(arr.shape[0], -1, 2)
    return _adapt(model, chroma, n_iter, jnp.float32(relevance), jnp.float32(reg), bool(adapt_skin))


@jax.jit
def _adapted_masks(models: SkinModel, frames):
    ratio = jax.vmap(log_ratio)(models, frames)                     # (B, H, W)
    return median3(ratio > models.threshold[:, None, None], 3)


def segment_adapted(model: SkinModel, frames: Real[ArrayLike, "B H W 3"],
                    seed_points: Real[ArrayLike, "B 2"] | None = None, out_size: int = 64,
                    margin: float = 0.1, n_iter: int = 5, relevance: float = 256.0,
                    adapt_skin: bool = True) -> Segmentation:
    """`segment` with each frame's own adapted skin model (`adapt_skin_model`) in step 2.

    Every other step is as `segment` (median filter, the seeded component, the square crop), so the
    two differ only in the skin model.

    Args:
        model: the global `SkinModel`.
        frames: (B, H, W, 3) RGB frames in [0, 255].
        seed_points: (B, 2) (row, col) per frame, or None (the largest component).
        out_size: S, the side of the crops.
        margin: box growth as a fraction of its larger side.
        n_iter: MAP-EM iterations (`adapt_skin_model`).
        relevance: r > 0, in pixels (`adapt_skin_model`).
        adapt_skin: whether the skin mixture adapts too (`adapt_skin_model`).

    Returns:
        A `Segmentation`.

    Raises:
        ValueError: naming the argument, as `adapt_skin_model` and `crop_components`.
    """
    models = adapt_skin_model(model, frames, n_iter, relevance, adapt_skin)
    arr = np.asarray(frames, np.float32)
    skin = np.asarray(_adapted_masks(models, jnp.asarray(arr)))
    gray = (arr @ np.array([0.299, 0.587, 0.114], np.float32)) / 255.0
    seeds = None if seed_points is None else as_array(seed_points, "seed_points", shape=(arr.shape[0], 2))
    return crop_components(gray, skin, seeds, out_size, margin)
