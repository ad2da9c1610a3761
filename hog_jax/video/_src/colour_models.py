"""Person and background colour models with the number of components chosen by BIC (level-set TR
§3.4, eq. 8), for the competing level sets (TR §3.2, eq. 7).

Shapes: T frames, H x W pixels, N pixels, d colour dimensions (3 for "rgb", 2 for "chroma"), G the
largest candidate number of components, R = 2 regions (person, background).

* `fit_gmm_bic(key, x, candidates)`: full-covariance GMMs of every candidate size t, fitted by the EM of
  `segment.fit_gmm` (the same kernel, run with its first t of G components active so that all sizes and
  restarts share one compilation and run as one `vmap`), each the best of `n_init` k-means++ starts by
  likelihood; the chosen one minimises eq. 8, BIC = -2 ln L + k ln N.
  k, the number of free parameters: t d means + t d (d + 1) / 2 covariances + (t - 1) weights (the
  weights sum to 1), `param_count="exact"`, the default. The TR gives k = t (d + 1)(d + 2) / 2, which
  is the same count with t weights instead of t - 1 (`param_count="tr"`): it adds ln N to every
  candidate's BIC alike, so both choose the same t; the exact count is the default because it is the
  one BIC is defined with.
* `fit_person_background_models(key, frames, person_masks)`: the TR's protocol. The frames after the
  person enters, with the person's pixels (the moving regions, from the background model, TR §3.4),
  give a person GMM and a background GMM, each chosen by BIC; pixels are subsampled (at most
  `max_pixels` per region, the same number for both so that one compiled EM serves both).
* `region_log_likelihoods(models, frames)`: log p(colour | region) per pixel, (T, R, H, W), the e_i of
  eq. 7 for the person and the background.

Colour space: "rgb" (R, G, B / 255, the default: the TR models the person's clothing colour) or "chroma"
((Cr, Cb) / 255 as the skin model of `segment`, luma dropped). Densities of different spaces are not
comparable: regions that compete in eq. 7 should share one space.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int, Key, Real

from hog_jax._src.checks import check_key
from hog_jax._src.segment import GMM, em, gmm_log_prob, rgb_to_chroma
from lfd_common import as_array, check_choice, check_int, check_real

__all__ = ["BICScores", "ColourFit", "ColourModels", "ColourStructure", "REGIONS", "bic", "fit_gmm_bic",
           "fit_person_background_models", "gmm_n_params", "region_log_likelihoods"]

REGIONS = ("person", "background")
_SPACES = {"rgb": 3, "chroma": 2}


@dataclasses.dataclass(frozen=True)
class ColourStructure:
    """What defines the models: the chosen number of components of each mixture and the colour space."""

    n_person_components: int
    n_background_components: int
    space: str = "rgb"

    def __post_init__(self):
        check_int(self.n_person_components, "n_person_components", min_value=1)
        check_int(self.n_background_components, "n_background_components", min_value=1)
        check_choice(self.space, "space", tuple(_SPACES))


class ColourModels(NamedTuple):
    """The person's and the background's colour mixtures (a `segment.GMM` each)."""

    person: GMM
    background: GMM


class BICScores(NamedTuple):
    """Per candidate (C,): the number of components, eq. 8's BIC, ln L (the best start's) and k."""

    candidates: Int[Array, " C"]
    bic: Float[Array, " C"]
    log_likelihood: Float[Array, " C"]
    n_params: Int[Array, " C"]


class ColourFit(NamedTuple):
    """`fit_person_background_models`' result: the structure, the models and both BIC tables."""

    structure: ColourStructure
    models: ColourModels
    person_scores: BICScores
    background_scores: BICScores


def gmm_n_params(t: int, d: int, param_count: str = "exact") -> int:
    """Free parameters of a full-covariance GMM of t components in d dimensions: "exact" t d + t d (d + 1)
    / 2 + (t - 1); "tr" the TR's t (d + 1)(d + 2) / 2 (t weights: one more)."""
    check_int(t, "t", min_value=1)
    check_int(d, "d", min_value=1)
    check_choice(param_count, "param_count", ("exact", "tr"))
    if param_count == "tr":
        return t * (d + 1) * (d + 2) // 2
    return t * d + t * d * (d + 1) // 2 + (t - 1)


def bic(log_likelihood: float, n_params: int, n_points: int) -> float:
    """Eq. 8: -2 ln L + k ln N."""
    return -2.0 * float(log_likelihood) + n_params * math.log(n_points)


def _numpy_rng(key) -> np.random.Generator:
    """A NumPy generator seeded by a jax.random key (typed or raw): subsampling and seeding are
    deterministic from the key."""
    raw = jax.random.key_data(key) if jax.dtypes.issubdtype(key.dtype, jax.dtypes.prng_key) else key
    return np.random.default_rng(np.asarray(raw))


def _check_candidates(candidates) -> tuple[int, ...]:
    try:
        values = tuple(candidates)
    except TypeError as err:
        raise ValueError(f"candidates: expected a sequence of component counts, got {candidates!r}") from err
    if not values:
        raise ValueError("candidates: must not be empty")
    for v in values:
        check_int(v, "candidates", min_value=1)
    if len(set(values)) != len(values):
        raise ValueError(f"candidates: expected distinct counts, got {values}")
    return tuple(sorted(int(v) for v in values))


def _kmeans_pp(rng: np.random.Generator, x: np.ndarray, G: int) -> np.ndarray:
    """G initial means (G, d) by k-means++ seeding (Arthur & Vassilvitskii 2007): the first a random
    point, each next one drawn with probability proportional to its squared distance from the nearest
    mean chosen so far. EM from distinct random points (`fit_gmm`'s start) often puts two means in one
    well-separated cluster and stays there, and BIC then prefers one component too many. In NumPy:
    G passes over the points, negligible beside EM, and it keeps random-number code out of the
    compiled program (which it made several times slower to compile)."""
    means = [x[rng.integers(len(x))]]
    d2 = np.sum((x - means[0]) ** 2, axis=1, dtype=np.float64)
    for _ in range(1, G):
        total = d2.sum()
        i = rng.choice(len(x), p=d2 / total) if total > 0 else rng.integers(len(x))
        means.append(x[i])
        d2 = np.minimum(d2, np.sum((x - means[-1]) ** 2, axis=1, dtype=np.float64))
    return np.stack(means)


def _fit_candidates(key, x, means, actives, n_iter, reg):
    """EM for every (candidate, start): means (S, G, d) the starts' seeds, actives (C,) the candidate
    sizes -> G-component GMMs (the first `active` fitted) with (C, S) leading axes and their
    log-likelihoods ln L (C, S)."""
    def one(m, n_active):
        gmm = em(key, x, m.shape[0], n_iter, reg, n_active, m)
        return gmm, jnp.sum(gmm_log_prob(gmm, x))

    return jax.vmap(jax.vmap(one, in_axes=(0, None)), in_axes=(None, 0))(means, actives)


_fit_candidates_jit = jax.jit(_fit_candidates)


def _fit_bic(key, x: np.ndarray, candidates: tuple[int, ...], n_iter: int, n_init: int, reg: float,
             param_count: str, name: str) -> tuple[GMM, BICScores]:
    N, d = x.shape
    g_max = candidates[-1]
    k_max = gmm_n_params(g_max, d, param_count)
    if N <= k_max:
        raise ValueError(f"{name}: {N} points cannot support BIC over up to {g_max} components in {d} dimensions "
                         f"(k = {k_max} parameters); give more points or fewer candidates")
    rng = _numpy_rng(key)
    means = np.stack([_kmeans_pp(rng, x, g_max) for _ in range(n_init)])
    gmms, ll = _fit_candidates_jit(key, jnp.asarray(x), jnp.asarray(means), jnp.asarray(candidates, jnp.int32),
                                   jnp.int32(n_iter), jnp.float32(reg))
    ll = np.asarray(ll, np.float64)
    start = np.argmax(np.where(np.isfinite(ll), ll, -np.inf), axis=1)  # the best start of each candidate
    best_ll = ll[np.arange(len(candidates)), start]
    k = np.array([gmm_n_params(t, d, param_count) for t in candidates])
    scores = np.array([bic(v, kk, N) if np.isfinite(v) else np.inf for v, kk in zip(best_ll, k)])
    if not np.isfinite(scores).any():
        raise ValueError(f"{name}: EM gave no finite likelihood for any candidate (degenerate points?)")
    c = int(np.argmin(scores))
    t = candidates[c]  # the first t components are the fitted ones; selected in NumPy (no small jit calls)
    chosen = GMM(*(jnp.asarray(np.asarray(a)[c, start[c], :t]) for a in gmms))
    return chosen, BICScores(jnp.asarray(candidates, jnp.int32), jnp.asarray(scores), jnp.asarray(best_ll),
                             jnp.asarray(k, jnp.int32))


def _check_fit_options(n_iter, n_init, reg, param_count):
    check_int(n_iter, "n_iter", min_value=1)
    check_int(n_init, "n_init", min_value=1)
    check_real(reg, "reg", min_value=0.0, exclusive_min=True)
    check_choice(param_count, "param_count", ("exact", "tr"))


def fit_gmm_bic(key: Key[Array, ""], x: Float[ArrayLike, "N d"], candidates: Sequence[int] = (1, 2, 3, 4, 5),
                n_iter: int = 100, n_init: int = 3, reg: float = 1e-5,
                param_count: str = "exact") -> tuple[GMM, BICScores]:
    """The GMM of the candidate size with the lowest BIC (eq. 8) for points x (N, d), and the BIC table.

    Each candidate t is the best (by likelihood) of `n_init` EM runs of `n_iter` iterations from
    k-means++ seeds (`segment.fit_gmm`'s EM, `reg` added to every covariance). ValueError naming the argument
    for empty or non-finite x, candidates that are empty, not positive integers or repeated, N not above
    the largest candidate's parameter count, bad options or a key that is not a jax.random key."""
    check_key(key, "key")
    x = as_array(x, "x", ndim=2, dtype=np.float32, min_value=-1e12, max_value=1e12)
    cands = _check_candidates(candidates)
    _check_fit_options(n_iter, n_init, reg, param_count)
    return _fit_bic(key, x, cands, n_iter, n_init, reg, param_count, "x")


def _features(rgb, space: str):
    return rgb_to_chroma(rgb) if space == "chroma" else jnp.asarray(rgb, jnp.float32) / 255.0


def _check_video(frames, name: str) -> np.ndarray:
    arr = as_array(frames, name, ndim=4, dtype=np.float32, min_value=0, max_value=255)
    if arr.shape[-1] != 3:
        raise ValueError(f"{name}: expected (T, H, W, 3) RGB frames, got shape {arr.shape}")
    return arr


def fit_person_background_models(key: Key[Array, ""], frames: Real[ArrayLike, "T H W 3"],
                                 person_masks: Bool[ArrayLike, "T H W"], candidates: Sequence[int] = (1, 2, 3, 4, 5),
                                 max_pixels: int = 20000, space: str = "rgb", n_iter: int = 100, n_init: int = 3,
                                 reg: float = 1e-5, param_count: str = "exact",
                                 ignore: Bool[ArrayLike, "T H W"] | None = None) -> ColourFit:
    """Person and background GMMs from RGB frames (T, H, W, 3) in [0, 255] (those after the person has
    entered) and the person's pixels (T, H, W) bool (TR §3.4), each with its size chosen by BIC.
    `ignore` (T, H, W) bool: pixels that teach neither model (e.g. the skin, which has its own).

    Each region is subsampled without replacement to n = min(max_pixels, person pixels, background
    pixels) pixels. ValueError naming the argument for bad frames, masks of another shape or with
    values other than 0/1, a region too small for BIC over the candidates (`person_masks`), or bad
    options."""
    check_key(key, "key")
    arr = _check_video(frames, "frames")
    masks = as_array(person_masks, "person_masks", dtype=None)
    if masks.shape != arr.shape[:3]:
        raise ValueError(f"person_masks: expected shape {arr.shape[:3]} (one per frame), got {masks.shape}")
    if masks.dtype != bool and not np.all((masks == 0) | (masks == 1)):
        raise ValueError("person_masks: expected a boolean mask (or 0/1), got other values")
    masks = masks.astype(bool)
    keep = np.ones_like(masks) if ignore is None else ~as_array(ignore, "ignore", shape=masks.shape, dtype=bool)
    cands = _check_candidates(candidates)
    n_max = check_int(max_pixels, "max_pixels", min_value=1)
    check_choice(space, "space", tuple(_SPACES))
    _check_fit_options(n_iter, n_init, reg, param_count)
    flat = arr.reshape(-1, 3)
    regions = [np.flatnonzero((masks & keep).reshape(-1)), np.flatnonzero((~masks & keep).reshape(-1))]
    n = min(n_max, *(len(r) for r in regions))
    need = gmm_n_params(cands[-1], _SPACES[space], param_count)
    if n <= need:
        counts = ", ".join(f"{len(r)} {name}" for r, name in zip(regions, REGIONS))
        raise ValueError(f"person_masks: {counts} pixels; BIC over up to {cands[-1]} components needs more than "
                         f"{need} pixels in each region")
    k_sample, k_person, k_background = jax.random.split(key, 3)
    rng = _numpy_rng(k_sample)
    fits = []
    for region, k_fit in zip(regions, (k_person, k_background)):
        x = np.asarray(_features(flat[rng.choice(region, n, replace=False)], space))
        fits.append(_fit_bic(k_fit, x, cands, n_iter, n_init, reg, param_count, "person_masks"))
    (person, p_scores), (background, b_scores) = fits
    structure = ColourStructure(int(person.log_weights.shape[0]), int(background.log_weights.shape[0]), space)
    return ColourFit(structure, ColourModels(person, background), p_scores, b_scores)


@jax.jit
def _log_likelihoods(models: ColourModels, x):
    return jnp.stack([gmm_log_prob(models.person, x), gmm_log_prob(models.background, x)], axis=1)


def region_log_likelihoods(models: ColourModels, frames: Real[ArrayLike, "T H W 3"],
                           space: str = "rgb") -> Float[Array, "T R H W"]:
    """log p(colour | region) of every pixel of RGB frames (T, H, W, 3) in [0, 255] under the person's
    and the background's mixtures (`REGIONS` order), in the models' colour space `space` (a
    `ColourFit.structure.space`): (T, 2, H, W) float32, the e_i of eq. 7."""
    arr = _check_video(frames, "frames")
    check_choice(space, "space", tuple(_SPACES))
    d = int(models.person.means.shape[-1])
    if d != _SPACES[space]:
        raise ValueError(f"space: the models have {d} colour dimensions, {space!r} has {_SPACES[space]}")
    return _log_likelihoods(models, _features(jnp.asarray(arr), space))
