"""Hand segmentation by skin colour (GRASP §III-A; skin GMM as LEVELSET TR §3.3).

Shapes: B frames, H x W pixels, N training pixels, P = 2 chroma channels, G mixture components,
S output side.

Pipeline (`segment`):
1. chroma: (Cr, Cb) of ITU-R BT.601 YCrCb (as OpenCV's `COLOR_RGB2YCrCb`), scaled to [0, 1]; the
   luma is dropped so the model is insensitive to brightness;
2. per-pixel log-likelihood ratio  log p_skin(c) - log p_background(c), both Gaussian mixtures
   (4 full-covariance components each by default) fitted by EM (`fit_gmm`, jitted, fixed iterations);
3. skin = ratio > threshold (0 by default: equal priors);
4. a 3 x 3 median filter applied three times (GRASP): on a binary mask the median is the majority
   of the 9 pixels; borders replicate (as `cv2.medianBlur`); batched in JAX;
5. connected components (8-connectivity, OpenCV, one call for the whole batch stacked with blank
   separator rows); the component containing or nearest to the frame's seed point (row, col), or the
   largest when no seed is given;
6. its bounding box, grown by `margin` (a fraction of its larger side) on every side and made
   square (so the hand keeps its aspect ratio), is cropped from the grayscale frame
   (0.299 R + 0.587 G + 0.114 B, scaled to [0, 1]) with the pixels outside the component set to 0
   (black background, as GRASP's segmented images), and resampled to S x S (bilinear, antialiased;
   batched in JAX); the component mask is resampled likewise (kept where > 0.5) so that `hog` can
   exclude the background; the same box of the grey frame without the mask is returned too (`context`:
   what is around the hand, e.g. the held object, for a recogniser that uses it).
A frame without skin gives found = False, a zero image, an all-False mask and box (-1, -1, -1, -1).

Persistence (`save_skin_model` / `load_skin_model`): a `SkinModel` is its structure (`SkinStructure`:
the components of each mixture, the chroma space) plus its arrays, stored by `lfd_common.save_model`
under the kind "hog_jax.SkinModel"; loading checks every array's shape against the structure, that
every covariance is positive definite (its Cholesky factor lower triangular with a positive diagonal)
and that each mixture's weights sum to 1.
"""
from __future__ import annotations

import dataclasses
import warnings
from functools import partial
from pathlib import Path
from typing import NamedTuple

import cv2
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int, Key, Real

from hog_jax._src.checks import check_key
from lfd_common import ArraySpec, ModelCodec, as_array, check_choice, check_int, check_real, load_model, save_model

__all__ = [
    "GMM", "Segmentation", "SkinModel", "SkinStructure", "crop_components", "fit_gmm", "fit_skin_model",
    "gmm_log_prob", "load_skin_model",
    "median3", "rgb_to_chroma", "save_skin_model", "segment", "skin_features", "skin_log_ratio",
]


class GMM(NamedTuple):
    """A Gaussian mixture with full covariances.

    Attributes:
        log_weights: (G,) log mixture weights (-inf for an inactive component).
        means: (G, P) component means.
        chols: (G, P, P) lower Cholesky factors of the covariances.
    """

    log_weights: Float[Array, " G"]
    means: Float[Array, "G P"]
    chols: Float[Array, "G P P"]


class SkinModel(NamedTuple):
    """Skin and background colour mixtures over chroma, and the decision threshold (GRASP §III-A).

    Attributes:
        skin: the skin `GMM` (P = 2 chroma channels).
        background: the background `GMM`.
        threshold: () the log-ratio threshold (0: equal priors).
    """

    skin: GMM
    background: GMM
    threshold: Float[Array, ""]


class Segmentation(NamedTuple):
    """The hand segmented in each frame, cropped square (GRASP §III-A).

    Attributes:
        images: (B, S, S) float32 grayscale crops, background 0.
        masks: (B, S, S) bool, the component within each crop.
        found: (B,) bool, a component was found.
        boxes: (B, 4) int32 (top, left, bottom, right) in frame pixels, bottom and right exclusive (may
            reach outside the frame, which is padded with background); -1 where not found.
        skin: (B, H, W) bool, the filtered skin mask.
        context: (B, S, S) float32, the same boxes of the grey frames unmasked (0 outside the frame and
            where not found): what is around the hand, e.g. the held object.
    """

    images: Float[Array, "B S S"]
    masks: Bool[Array, "B S S"]
    found: Bool[Array, " B"]
    boxes: Int[Array, "B 4"]
    skin: Bool[Array, "B H W"]
    context: Float[Array, "B S S"]


def rgb_to_chroma(rgb: Real[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 2"]:
    """RGB to the chroma of BT.601 YCrCb (OpenCV's coefficients), the skin model's colour space.

    The luma is dropped, so that the skin model is insensitive to brightness (GRASP §III-A).

    Args:
        rgb: (..., 3) RGB in [0, 255].

    Returns:
        (..., 2) (Cr, Cb) / 255.
    """
    rgb = jnp.asarray(rgb, jnp.float32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    y = 0.299 * r + 0.587 * g + 0.114 * b
    cr = (r - y) * 0.713 + 128.0
    cb = (b - y) * 0.564 + 128.0
    return jnp.stack([cr, cb], axis=-1) / 255.0


def skin_features(rgb: Real[ArrayLike, "*batch 3"], luma: bool = False) -> Float[Array, "*batch P"]:
    """The colour a skin model lives in: (Cr, Cb) / 255 (`rgb_to_chroma`, P = 2), or with `luma` also
    Y / 255 of BT.601 (P = 3: a luminance-dependent model, whose chroma may change with brightness).

    Args:
        rgb: (..., 3) RGB in [0, 255].
        luma: whether Y / 255 is the third channel.

    Returns:
        (..., P) features.
    """
    chroma = rgb_to_chroma(rgb)
    if not luma:
        return chroma
    rgb = jnp.asarray(rgb, jnp.float32)
    y = (0.299 * rgb[..., 0] + 0.587 * rgb[..., 1] + 0.114 * rgb[..., 2]) / 255.0
    return jnp.concatenate([chroma, y[..., None]], axis=-1)


def whiten(chols, diff) -> jax.Array:
    """L_g^{-1} d for lower-triangular chols (G, P, P) and diff (..., G, P) -> (..., G, P).

    Forward substitution unrolled over the P (= 2) colour channels, in plain elementwise operations:
    a batched LAPACK triangular solve here deadlocked XLA:CPU's thread pool when the skin and the
    background mixtures were evaluated concurrently (both custom calls waiting on the same two-thread
    pool; seen about one run in three on a 2-core machine).
    """
    columns = []
    for i in range(diff.shape[-1]):
        partial_sum = sum((chols[:, i, j] * columns[j] for j in range(i)), jnp.zeros_like(diff[..., i]))
        columns.append((diff[..., i] - partial_sum) / chols[:, i, i])
    return jnp.stack(columns, axis=-1)


def gmm_log_prob(gmm: GMM, x: Float[ArrayLike, "*batch P"]) -> Float[Array, "*batch"]:
    """The log-density of points under a Gaussian mixture.

    Args:
        gmm: the `GMM`.
        x: (..., P) points.

    Returns:
        (...) log p(x).
    """
    x = jnp.asarray(x)
    P = x.shape[-1]
    diff = x[..., None, :] - gmm.means  # (..., G, P)
    maha = jnp.sum(whiten(gmm.chols, diff) ** 2, axis=-1)  # (..., G)
    logdet = jnp.sum(jnp.log(jnp.diagonal(gmm.chols, axis1=-2, axis2=-1)), axis=-1)
    comp = gmm.log_weights - 0.5 * maha - logdet - 0.5 * P * jnp.log(2 * jnp.pi)
    return jax.nn.logsumexp(comp, axis=-1)


@partial(jax.jit, static_argnames=("n_components",))
def em(key, x, n_components: int, n_iter: int, reg, n_active=None, means=None):
    """EM of `fit_gmm`. n_active (traced, default all G): only the first n_active components are fitted,
    the others keep weight 0 (log weight -inf), so mixtures of several sizes share one compilation;
    means (G, P): initial means (default: G distinct random data points). `hog_jax.video.fit_gmm_bic`
    uses both, vmapped over candidate sizes and k-means++ starts."""
    N, P = x.shape
    G = n_components
    active = jnp.arange(G) < (G if n_active is None else n_active)
    means = x[jax.random.choice(key, N, (G,), replace=False)] if means is None else means
    cov = jnp.cov(x.T, bias=N == 1).reshape(P, P) + reg * jnp.eye(P)  # one point: zero spread, not 0/0
    chols = jnp.broadcast_to(jnp.linalg.cholesky(cov), (G, P, P))
    gmm = GMM(jnp.where(active, -jnp.log(jnp.sum(active)), -jnp.inf), means, chols)

    def step(_, gmm):
        diff = x[:, None, :] - gmm.means
        maha = jnp.sum(whiten(gmm.chols, diff) ** 2, axis=-1)  # (N, G)
        logdet = jnp.sum(jnp.log(jnp.diagonal(gmm.chols, axis1=-2, axis2=-1)), axis=-1)
        logp = gmm.log_weights - 0.5 * maha - logdet
        resp = jax.nn.softmax(logp, axis=1)  # E step
        nk = resp.sum(0) + 1e-10  # M step
        mu = (resp.T @ x) / nk[:, None]
        d = x[:, None, :] - mu
        cov = jnp.einsum("ng,ngi,ngj->gij", resp, d, d) / nk[:, None, None] + reg * jnp.eye(P)
        return GMM(jnp.where(active, jnp.log(nk / N), -jnp.inf), mu, jnp.linalg.cholesky(cov))

    return jax.lax.fori_loop(0, n_iter, step, gmm)


def fit_gmm(key: Key[Array, ""], x: Float[ArrayLike, "N P"], n_components: int = 4, n_iter: int = 100,
            reg: float = 1e-5) -> GMM:
    """A full-covariance Gaussian mixture fitted by EM (the skin model of GRASP §III-A; LEVELSET TR §3.3).

    `n_iter` EM iterations from means at random data points and covariances at the data covariance,
    `reg` added to every covariance's diagonal. `reg` is the covariance floor: a component fitted to one
    point, or to identical points, gets the covariance reg * I (never NaN); with N <= P points the
    covariance cannot be estimated and a `UserWarning` says so.

    Args:
        key: a `jax.random` key.
        x: (N, P) points, |x| <= 1e12.
        n_components: G, in [1, N].
        n_iter: EM iterations, >= 0.
        reg: the covariance floor, > 0.

    Returns:
        The fitted `GMM`.

    Raises:
        ValueError: naming the argument for empty or non-finite x, |x| > 1e12, n_components outside
            [1, N], n_iter < 0, reg <= 0 or a key that is not a `jax.random` key.
    """
    check_key(key, "key")
    x = as_array(x, "x", ndim=2, dtype=np.float32, min_value=-1e12, max_value=1e12)
    return _fit_gmm(key, x, n_components, n_iter, reg, "x", "n_components")


def _fit_gmm(key, x: np.ndarray, n_components, n_iter, reg, x_name: str, g_name: str) -> GMM:
    G = check_int(n_components, g_name, min_value=1, max_value=x.shape[0])
    check_int(n_iter, "n_iter", min_value=0)
    check_real(reg, "reg", min_value=0.0, exclusive_min=True)
    if x.shape[0] <= x.shape[1]:
        warnings.warn(f"{x_name}: {x.shape[0]} point(s) in {x.shape[1]} dimensions cannot define a covariance; "
                      f"it is floored at reg * I = {reg:g} * I", UserWarning, stacklevel=3)
    return em(key, jnp.asarray(x), G, jnp.int32(n_iter), jnp.float32(reg))


def fit_skin_model(key: Key[Array, ""], skin_rgb: Real[ArrayLike, "N 3"], background_rgb: Real[ArrayLike, "M 3"],
                   n_components: int = 4, n_background: int = 4, threshold: float = 0.0,
                   n_iter: int = 100, luma: bool = False) -> SkinModel:
    """Skin and background GMMs on chroma from labelled RGB pixels (GRASP §III-A).

    Each mixture is `fit_gmm` of the pixels' chroma (`rgb_to_chroma`), or with `luma` of (Cr, Cb, Y)
    (`skin_features`; the mixtures' P = 3 says so to every user of the model): from one pixel (or
    identical pixels) a component gets the floor covariance reg * I (a `UserWarning` for N <= P), never NaN.

    Args:
        key: a `jax.random` key.
        skin_rgb: (N, 3) skin pixels, RGB in [0, 255].
        background_rgb: (M, 3) background pixels, RGB in [0, 255].
        n_components: components of the skin mixture, in [1, N].
        n_background: components of the background mixture, in [1, M].
        threshold: the log-ratio threshold of the model (0: equal priors).
        n_iter: EM iterations.
        luma: whether the model includes Y / 255 (a luminance-dependent term).

    Returns:
        A `SkinModel`.

    Raises:
        ValueError: naming the argument for pixels outside [0, 255] or not (N, 3), more components than
            pixels, a non-finite threshold, or a key that is not a `jax.random` key.
    """
    check_key(key, "key")
    skin = as_array(skin_rgb, "skin_rgb", shape=(None, 3), min_value=0, max_value=255)
    bg = as_array(background_rgb, "background_rgb", shape=(None, 3), min_value=0, max_value=255)
    check_real(threshold, "threshold")
    check_int(n_components, "n_components", min_value=1, max_value=skin.shape[0])
    check_int(n_background, "n_background", min_value=1, max_value=bg.shape[0])
    if not isinstance(luma, (bool, np.bool_)):
        raise ValueError(f"luma: expected a bool, got {type(luma).__name__}")
    k1, k2 = jax.random.split(key)
    feats = lambda x: np.asarray(skin_features(x, bool(luma)))
    return SkinModel(_fit_gmm(k1, feats(skin), n_components, n_iter, 1e-5, "skin_rgb", "n_components"),
                     _fit_gmm(k2, feats(bg), n_background, n_iter, 1e-5, "background_rgb", "n_background"),
                     jnp.float32(threshold))


@jax.jit
def log_ratio(model: SkinModel, rgb):
    c = skin_features(rgb, model.skin.means.shape[-1] == 3)
    return gmm_log_prob(model.skin, c) - gmm_log_prob(model.background, c)


def skin_log_ratio(model: SkinModel, rgb: Real[ArrayLike, "*batch 3"]) -> Float[Array, "*batch"]:
    """The skin log-likelihood ratio log p_skin(c) - log p_background(c) per pixel (GRASP §III-A).

    Args:
        model: the `SkinModel`.
        rgb: (..., 3) RGB values in [0, 255].

    Returns:
        (...) log ratios; a pixel is skin where the ratio exceeds the model's threshold.

    Raises:
        ValueError: `rgb` with values outside [0, 255] or a last axis other than 3.
    """
    arr = as_array(rgb, "rgb", dtype=np.float32, min_value=0, max_value=255)
    if arr.shape[-1] != 3:
        raise ValueError(f"rgb: expected a last axis of 3 (R, G, B), got shape {arr.shape}")
    return log_ratio(model, jnp.asarray(arr))


@partial(jax.jit, static_argnames=("times",))
def median3(mask: Bool[ArrayLike, "B H W"], times: int = 3) -> Bool[Array, "B H W"]:
    """The 3 x 3 median filter of binary masks, applied `times` times (GRASP §III-A: three times).

    On a binary mask the median is the majority of the 9 pixels; borders replicate (as
    `cv2.medianBlur`). Jitted; no input checks.

    Args:
        mask: (B, H, W) binary masks.
        times: how many times the filter is applied (static).

    Returns:
        (B, H, W) bool filtered masks.
    """
    def once(m, _):
        p = jnp.pad(m.astype(jnp.int32), ((0, 0), (1, 1), (1, 1)), mode="edge")
        H, W = m.shape[1:]
        s = sum(p[:, i:i + H, j:j + W] for i in range(3) for j in range(3))
        return s >= 5, None

    out, _ = jax.lax.scan(once, jnp.asarray(mask, bool), None, length=times)
    return out


@jax.jit
def _skin_masks(model: SkinModel, frames, threshold):
    return median3(log_ratio(model, frames) > threshold, 3)


def label_components(masks: np.ndarray):
    """Label 8-connected components of all frames with one OpenCV call.

    Returns labels (B, H, W) int32 (0 = background, global ids) and stats (n_labels, 5) rows of
    (left, top, width, height, area) from `cv2.connectedComponentsWithStats`, top in the coordinates
    of the component's own frame.
    """
    B, H, W = masks.shape
    stacked = np.zeros((B, H + 1, W), np.uint8)  # a blank row after every frame separates them
    stacked[:, :H] = masks
    n, labels, stats, _ = cv2.connectedComponentsWithStats(stacked.reshape(B * (H + 1), W), connectivity=8)
    stats = stats.copy()
    stats[:, cv2.CC_STAT_TOP] %= H + 1  # a component never crosses a separator row
    return labels.reshape(B, H + 1, W)[:, :H], stats


@partial(jax.jit, static_argnames=("size",))
def _crops(gray, comp, top, left, side, size: int):
    """Resample the square boxes (top, left, side) of gray (B, H, W) masked by comp, of comp and of gray
    to (B, size, size) each (the mask kept where > 0.5)."""
    def one(g, m, t, l, s):
        scale = size / s
        resample = lambda x: jax.image.scale_and_translate(x, (size, size), (0, 1), jnp.stack([scale, scale]),
                                                           jnp.stack([-t * scale, -l * scale]), "linear",
                                                           antialias=True)
        return resample(g * m), resample(m) > 0.5, resample(g)
    return jax.vmap(one)(gray, comp, top, left, side)


def _chosen_components(labels: np.ndarray, stats: np.ndarray, seeds: np.ndarray | None) -> np.ndarray:
    """(B,) the global component id kept per frame (0: none): the one containing or nearest to the
    frame's seed (row, col), or the largest without seeds; vectorised over all labelled pixels."""
    B = labels.shape[0]
    fb, fr, fc = np.nonzero(labels)
    lab = labels[fb, fr, fc]
    if seeds is None:
        score = stats[lab, cv2.CC_STAT_AREA].astype(np.float64)  # larger is better
    else:
        score = -((fr - seeds[fb, 0]) ** 2 + (fc - seeds[fb, 1]) ** 2)  # nearer is better
    best = np.full(B, -np.inf)
    np.maximum.at(best, fb, score)
    chosen = np.zeros(B, np.int64)
    hit = score == best[fb]
    chosen[fb[hit]] = lab[hit]  # ties: any of the best
    return chosen


def crop_components(gray: Float[ArrayLike, "B H W"], masks: Bool[ArrayLike, "B H W"],
                    seed_points: Real[ArrayLike, "B 2"] | None = None, out_size: int = 64,
                    margin: float = 0.1) -> Segmentation:
    """Steps 5-6 of `segment` on any masks: the chosen component of each frame, cropped square.

    Per frame, the 8-connected component of `masks` containing or nearest to the frame's seed point,
    or the largest without seeds; its bounding box, grown by `margin` and made square, is cropped from
    `gray` with the pixels outside the component set to 0 and resampled to out_size x out_size
    (bilinear, antialiased), with its mask. Used by the video front end on its hand and object masks.

    Args:
        gray: (B, H, W) intensities.
        masks: (B, H, W) bool masks.
        seed_points: (B, 2) (row, col) per frame, or None.
        out_size: S, the side of the crops, >= 1.
        margin: box growth as a fraction of its larger side, >= 0.

    Returns:
        A `Segmentation` (its `skin` is `masks`); a frame without mask pixels gives found False, a zero
        image, an all-False mask and box -1.

    Raises:
        ValueError: naming the argument for non-finite gray, masks or seeds of another shape,
            out_size < 1 or margin < 0.
    """
    g = as_array(gray, "gray", ndim=3, dtype=np.float32)
    m = as_array(masks, "masks", shape=g.shape, dtype=bool)
    S = check_int(out_size, "out_size", min_value=1)
    margin = check_real(margin, "margin", min_value=0.0)
    seeds = None if seed_points is None else as_array(seed_points, "seed_points", shape=(g.shape[0], 2))
    labels, stats = label_components(m)
    chosen = _chosen_components(labels, stats, seeds)
    found = chosen > 0
    left, top = stats[chosen, cv2.CC_STAT_LEFT], stats[chosen, cv2.CC_STAT_TOP]
    w, h = stats[chosen, cv2.CC_STAT_WIDTH], stats[chosen, cv2.CC_STAT_HEIGHT]
    side = np.maximum(np.ceil(np.maximum(w, h) * (1.0 + 2.0 * margin)).astype(np.int64), 1)
    top = top + h // 2 - side // 2
    left = left + w // 2 - side // 2
    comp = labels == np.where(found, chosen, stats.shape[0])[:, None, None]
    imgs, crops, context = _crops(jnp.asarray(g), jnp.asarray(comp, jnp.float32), jnp.asarray(top, jnp.float32),
                         jnp.asarray(left, jnp.float32), jnp.asarray(side, jnp.float32), S)
    f = jnp.asarray(found)
    boxes = np.where(found[:, None], np.stack([top, left, top + side, left + side], 1), -1).astype(np.int32)
    return Segmentation(jnp.where(f[:, None, None], imgs, 0.0), crops & f[:, None, None], f, jnp.asarray(boxes),
                        jnp.asarray(m), jnp.where(f[:, None, None], context, 0.0))


def segment(model: SkinModel, frames: Real[ArrayLike, "B H W 3"], seed_points: Real[ArrayLike, "B 2"] | None = None,
            out_size: int = 64, margin: float = 0.1, threshold: float | None = None) -> Segmentation:
    """Segment the hand in each RGB frame by skin colour (GRASP §III-A).

    1. chroma (Cr, Cb) of BT.601 YCrCb; 2. the per-pixel log-likelihood ratio of the skin and
    background mixtures; 3. skin = ratio > threshold; 4. a 3 x 3 median filter applied three times;
    5. connected components (8-connectivity): the one containing or nearest to the frame's seed
    point, or the largest; 6. its bounding box, grown by `margin` and made square (the hand keeps its
    aspect ratio), cropped from the grey frame (0.299 R + 0.587 G + 0.114 B, / 255) with the pixels
    outside the component set to 0 (black background, as GRASP's segmented images) and resampled to
    S x S, with its mask (so that `hog` can exclude the background).

    Args:
        model: the `SkinModel`.
        frames: (B, H, W, 3) RGB frames, uint8 or real in [0, 255].
        seed_points: (B, 2) (row, col) per frame: the component containing the seed, or with the pixel
            nearest to it, is kept; None: the largest component.
        out_size: S, the side of the crops.
        margin: box growth as a fraction of its larger side.
        threshold: the log-ratio threshold (default: the model's).

    Returns:
        A `Segmentation`; a frame without skin gives found False, a zero image, an all-False mask and
        box (-1, -1, -1, -1).

    Raises:
        ValueError: naming the argument for frames that are not (B, H, W, 3) in [0, 255], seed points
            of another shape, out_size < 1, margin < 0 or a non-finite threshold.
    """
    arr = as_array(frames, "frames", ndim=4, dtype=np.float32, min_value=0, max_value=255)
    B, H, W, ch = arr.shape
    if ch != 3:
        raise ValueError(f"frames: expected (B, H, W, 3) RGB frames, got shape {arr.shape}")
    check_int(out_size, "out_size", min_value=1)
    check_real(margin, "margin", min_value=0.0)
    thr = model.threshold if threshold is None else jnp.float32(check_real(threshold, "threshold"))
    seeds = None if seed_points is None else as_array(seed_points, "seed_points", shape=(B, 2))
    skin = np.asarray(_skin_masks(model, jnp.asarray(arr), thr))
    gray = (arr @ np.array([0.299, 0.587, 0.114], np.float32)) / 255.0
    return crop_components(gray, skin, seeds, out_size, margin)


# ------------------------------------------------------------------------------------ persistence
_CHROMA = "CrCb/255 BT.601"  # what `rgb_to_chroma` computes; a model of another colour space would not fit
_SPACES = {_CHROMA: 2, "CrCbY/255 BT.601": 3}  # colour space -> P (`skin_features` without / with luma)


@dataclasses.dataclass(frozen=True)
class SkinStructure:
    """What defines a `SkinModel`: the components of each mixture and the colour space.

    Attributes:
        n_skin_components: components of the skin mixture, >= 1.
        n_background_components: components of the background mixture, >= 1.
        chroma: the colour space the mixtures live in: "CrCb/255 BT.601" (P = 2, what
            `rgb_to_chroma` computes) or "CrCbY/255 BT.601" (P = 3, `skin_features` with luma).

    Raises:
        ValueError: naming the field for a count < 1 or another colour space.
    """

    n_skin_components: int
    n_background_components: int
    chroma: str = _CHROMA

    def __post_init__(self):
        check_int(self.n_skin_components, "n_skin_components", min_value=1)
        check_int(self.n_background_components, "n_background_components", min_value=1)
        check_choice(self.chroma, "chroma", tuple(_SPACES))


def _structure_of(model: SkinModel) -> SkinStructure:
    space = {p: name for name, p in _SPACES.items()}.get(int(model.skin.means.shape[-1]), _CHROMA)
    return SkinStructure(int(model.skin.log_weights.shape[0]), int(model.background.log_weights.shape[0]), space)


def _gmm_template(n: int, p: int) -> GMM:
    return GMM(ArraySpec((n,)), ArraySpec((n, p)), ArraySpec((n, p, p)))


def _template(structure: SkinStructure) -> SkinModel:
    p = _SPACES[structure.chroma]
    return SkinModel(_gmm_template(structure.n_skin_components, p),
                     _gmm_template(structure.n_background_components, p), ArraySpec(()))


def _check(model: SkinModel) -> None:
    """Positive-definite covariances (lower-triangular Cholesky factors, positive diagonal) and
    normalised mixture weights; ValueError naming the mixture otherwise."""
    for name, gmm in (("skin", model.skin), ("background", model.background)):
        chols = np.asarray(gmm.chols)
        if np.any(np.triu(chols, 1) != 0) or np.any(np.diagonal(chols, axis1=-2, axis2=-1) <= 0):
            raise ValueError(f"{name}: covariances not positive definite (chols must be lower triangular "
                             "with a positive diagonal)")
        total = float(np.exp(np.asarray(gmm.log_weights, np.float64)).sum())
        if abs(total - 1.0) > 1e-3:
            raise ValueError(f"{name}: mixture weights sum to {total:.6g}, expected 1")


SKIN_CODEC = ModelCodec(kind="hog_jax.SkinModel", model_type=SkinModel, structure_type=SkinStructure,
                        structure_of=_structure_of, template=_template, check=_check)


def save_skin_model(path: str | Path, model: SkinModel) -> Path:
    """Write a `SkinModel`: its `SkinStructure` and arrays (`lfd_common.save_model`).

    The model is checked as `load_skin_model` checks it.

    Args:
        path: the file (.npz appended when missing).
        model: the `SkinModel`.

    Returns:
        The path written.

    Raises:
        ValueError: a model whose covariances are not positive definite or whose weights do not sum
            to 1.
    """
    return save_model(path, model, [SKIN_CODEC])


def load_skin_model(path: str | Path) -> SkinModel:
    """Read a `SkinModel` written by `save_skin_model`.

    Loading checks every array's shape against the stored structure, that every covariance is
    positive definite (its Cholesky factor lower triangular with a positive diagonal) and that each
    mixture's weights sum to 1.

    Args:
        path: the file.

    Returns:
        The `SkinModel`.

    Raises:
        FileNotFoundError: a missing file.
        ValueError: naming the file for a corrupt one, another kind, or arrays that disagree with the
            stored structure, covariances that are not positive definite or weights that do not sum
            to 1.
    """
    return load_model(path, [SKIN_CODEC])
