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

`adapt_to_skin` / `adapt_to_face` adapt the skin mixture alone to pixels known to be one person's
skin (the face found early in a video, the most confident skin blob of a photo): Reynolds et al.
(2000) relevance MAP of the means and weights (optionally the covariances), the background mixture
and the threshold kept; the adapted model then segments that person's every frame.
"""
from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Real

from hog_jax._src.segment import (GMM, Segmentation, SkinModel, log_ratio, whiten, crop_components,
    median3, skin_features)
from lfd_common import as_array, check_int, check_real

__all__ = ["adapt_skin_model", "adapt_to_face", "adapt_to_skin", "segment_adapted"]


def _chol2(cov):
    """Lower Cholesky factors of (..., P, P) symmetric positive-definite matrices: in closed form for
    P = 2 (no LAPACK call), else `jnp.linalg.cholesky`."""
    if cov.shape[-1] != 2:
        return jnp.linalg.cholesky(cov)
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
    P = int(model.skin.means.shape[-1])
    chroma = skin_features(jnp.asarray(arr), P == 3).reshape(arr.shape[0], -1, P)
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


@partial(jax.jit, static_argnames=("n_iter", "adapt_covariances"))
def _reynolds(prior: GMM, x, weight, relevance, n_iter: int, adapt_covariances: bool) -> GMM:
    """Reynolds MAP of a mixture's means and weights (and covariances) from weighted points x (N, P)."""
    w0 = jnp.exp(prior.log_weights)
    mu0 = prior.means
    cov0 = prior.chols @ jnp.swapaxes(prior.chols, -1, -2)
    total = jnp.maximum(weight.sum(), 1e-12)

    def step(_, gmm):
        resp = jax.nn.softmax(_component_log_probs(gmm, x), axis=1) * weight[:, None]   # (N, G)
        n = resp.sum(0)
        ex = (resp.T @ x) / jnp.maximum(n, 1e-12)[:, None]
        alpha = n / (n + relevance)
        mean = alpha[:, None] * ex + (1 - alpha[:, None]) * mu0
        w = alpha * n / total + (1 - alpha) * w0
        if adapt_covariances:
            exx = jnp.einsum("ng,ni,nj->gij", resp, x, x) / jnp.maximum(n, 1e-12)[:, None, None]
            second = alpha[:, None, None] * exx + (1 - alpha[:, None, None]) * (cov0 + mu0[:, :, None] * mu0[:, None, :])
            chols = _chol2(second - mean[:, :, None] * mean[:, None, :])
        else:
            chols = prior.chols
        return GMM(jnp.log(w / w.sum()), mean, chols)

    return jax.lax.fori_loop(0, n_iter, step, prior)


def adapt_to_skin(model: SkinModel, skin_rgb: Real[ArrayLike, "N 3"], relevance: float = 16.0, n_iter: int = 1,
                  adapt_covariances: bool = False) -> SkinModel:
    """The skin mixture adapted to one person's skin pixels by relevance MAP (Reynolds et al. 2000).

    With responsibilities gamma_nk of the skin mixture's components for the pixels' chroma x_n,
    n_k = sum_n gamma_nk, E_k = sum_n gamma_nk x_n / n_k and alpha_k = n_k / (n_k + r):
    mu_k' = alpha_k E_k + (1 - alpha_k) mu_k and w_k' proportional to alpha_k n_k / N + (1 - alpha_k) w_k
    (Reynolds, Quatieri & Dunn, "Speaker verification using adapted Gaussian mixture models", DSP
    10, 2000, eqs. 11-14); with `adapt_covariances` the second moments likewise. `n_iter` > 1 repeats
    the step with responsibilities under the adapted mixture (MAP-EM), always towards the prior. The
    background mixture and the threshold are kept (GRASP §III-A's ratio with the person's own skin).

    Args:
        model: the `SkinModel` (the prior).
        skin_rgb: (N, 3) RGB in [0, 255], pixels known to be the person's skin.
        relevance: r > 0, in pixels: a component moves halfway to its data once r pixels fall on it.
        n_iter: MAP steps, >= 1 (Reynolds: 1).
        adapt_covariances: whether the covariances adapt too.

    Returns:
        The adapted `SkinModel` (the same shapes as `model`).

    Raises:
        ValueError: naming the argument for pixels of the wrong shape or range, relevance <= 0,
            n_iter < 1, or adapt_covariances not a bool.
    """
    rgb = as_array(skin_rgb, "skin_rgb", shape=(None, 3), dtype=np.float32, min_value=0, max_value=255)
    relevance = check_real(relevance, "relevance", min_value=0.0, exclusive_min=True, max_value=1e12)
    n_iter = check_int(n_iter, "n_iter", min_value=1)
    if not isinstance(adapt_covariances, (bool, np.bool_)):
        raise ValueError(f"adapt_covariances: expected a bool, got {type(adapt_covariances).__name__}")
    size = 1 << max(int(np.ceil(np.log2(len(rgb)))), 4)  # padded (weight 0) to a power of two: few compilations
    x = skin_features(jnp.asarray(np.pad(rgb, ((0, size - len(rgb)), (0, 0)))), model.skin.means.shape[-1] == 3)
    weight = jnp.asarray(np.arange(size) < len(rgb), jnp.float32)
    skin = _reynolds(model.skin, x, weight, jnp.float32(relevance), n_iter, bool(adapt_covariances))
    return SkinModel(skin, model.background, model.threshold)


def adapt_to_face(model: SkinModel, frames: Real[ArrayLike, "B H W 3"], face: ArrayLike, relevance: float = 16.0,
                  n_iter: int = 1, adapt_covariances: bool = False, only_skin: bool = True) -> SkinModel:
    """The skin model adapted to the person whose face (or other skin region) is given (`adapt_to_skin`).

    The pixels inside `face` in every frame (a mask, or a box per frame) are the person's skin sample;
    with `only_skin` those the model does not already call skin (hair, eyes, the wall behind a box)
    are left out. The adapted model then segments the whole recording (`skin_log_ratio`).

    Args:
        model: the `SkinModel` (the prior).
        frames: (B, H, W, 3) RGB frames in [0, 255].
        face: (B, H, W) or (H, W) bool mask, or (B, 4) / (4,) int boxes (top, left, bottom, right),
            bottom and right exclusive, clipped to the frame.
        relevance: r > 0, in pixels (`adapt_to_skin`).
        n_iter: MAP steps, >= 1.
        adapt_covariances: whether the covariances adapt too.
        only_skin: keep only the face pixels whose log ratio exceeds the model's threshold.

    Returns:
        The adapted `SkinModel`; `model` itself when no pixel is left to adapt on.

    Raises:
        ValueError: naming the argument for frames or face of the wrong shape or range, and as
            `adapt_to_skin`.
    """
    arr = as_array(frames, "frames", ndim=4, dtype=np.float32, min_value=0, max_value=255)
    B, H, W, C = arr.shape
    if C != 3:
        raise ValueError(f"frames: expected (B, H, W, 3) RGB frames, got shape {arr.shape}")
    f = np.asarray(face)
    if f.dtype == bool and f.shape in ((B, H, W), (H, W)):
        mask = np.broadcast_to(f, (B, H, W))
    elif f.shape in ((4,), (B, 4)) and np.issubdtype(f.dtype, np.integer):
        boxes = np.broadcast_to(f, (B, 4))
        rows, cols = np.arange(H)[None, :, None], np.arange(W)[None, None, :]
        mask = ((rows >= boxes[:, 0, None, None]) & (rows < boxes[:, 2, None, None])
                & (cols >= boxes[:, 1, None, None]) & (cols < boxes[:, 3, None, None]))
    else:
        raise ValueError(f"face: expected a bool mask ({B}, {H}, {W}) or ({H}, {W}), or int boxes ({B}, 4) or "
                         f"(4,), got {f.dtype} {f.shape}")
    if not isinstance(only_skin, (bool, np.bool_)):
        raise ValueError(f"only_skin: expected a bool, got {type(only_skin).__name__}")
    pixels = arr[mask]
    if only_skin and len(pixels):
        pixels = pixels[np.asarray(log_ratio(model, jnp.asarray(pixels))) > float(model.threshold)]
    if not len(pixels):
        return model
    return adapt_to_skin(model, pixels, relevance, n_iter, adapt_covariances)
