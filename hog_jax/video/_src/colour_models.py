"""Person and background colour models with the number of components chosen by BIC (LEVELSET TR
§3.4, eq. 8), for the competing level sets (TR §3.2, eq. 7).

Shapes: T frames, H x W pixels, N pixels, d colour dimensions (3 for "rgb", 2 for "chroma"), G the
largest candidate number of components, R = 2 regions (person, background).

* `fit_gmm_bic(key, x, options)`: full-covariance GMMs of every candidate size t, fitted by the EM
  of `hog_jax.fit_gmm` (the same kernel, run with its first t of G components active so that all
  sizes and restarts share one compilation and run as one `vmap`), each the best of `n_init`
  k-means++ starts by likelihood; the chosen one minimises eq. 8, BIC = -2 ln L + k ln N.
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

Colour space: "rgb" (R, G, B / 255, the default: the TR models the person's clothing colour) or
"chroma" ((Cr, Cb) / 255 as the skin model of `hog_jax.segment`, luma dropped). Densities of
different spaces are not comparable: regions that compete in eq. 7 should share one space.
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

__all__ = ["BICOptions", "BICScores", "ColourFit", "ColourModels", "ColourStructure", "REGIONS", "bic", "fit_gmm_bic",
           "fit_person_background_models", "gmm_n_params", "region_log_likelihoods"]

REGIONS = ("person", "background")
_SPACES = {"rgb": 3, "chroma": 2}


@dataclasses.dataclass(frozen=True)
class ColourStructure:
    """What defines the person and background colour models (LEVELSET TR §3.4).

    Attributes:
        n_person_components: components of the person's mixture (chosen by BIC), >= 1.
        n_background_components: components of the background's mixture, >= 1.
        space: the colour space, "rgb" or "chroma".

    Raises:
        ValueError: naming the field for a count < 1 or an unknown space.
    """

    n_person_components: int
    n_background_components: int
    space: str = "rgb"

    def __post_init__(self):
        check_int(self.n_person_components, "n_person_components", min_value=1)
        check_int(self.n_background_components, "n_background_components", min_value=1)
        check_choice(self.space, "space", tuple(_SPACES))


class ColourModels(NamedTuple):
    """The person's and the background's colour mixtures (LEVELSET TR §3.4).

    Attributes:
        person: the person's `hog_jax.GMM`.
        background: the background's `hog_jax.GMM`.
    """

    person: GMM
    background: GMM


class BICScores(NamedTuple):
    """The BIC table of the candidate sizes (LEVELSET TR eq. 8).

    Attributes:
        candidates: (C,) the numbers of components tried.
        bic: (C,) eq. 8's BIC = -2 ln L + k ln N (inf where EM gave no finite likelihood).
        log_likelihood: (C,) ln L of the best start.
        n_params: (C,) k, the free parameters.
    """

    candidates: Int[Array, " C"]
    bic: Float[Array, " C"]
    log_likelihood: Float[Array, " C"]
    n_params: Int[Array, " C"]


class ColourFit(NamedTuple):
    """The result of `fit_person_background_models`.

    Attributes:
        structure: the `ColourStructure` (the chosen sizes and the space).
        models: the `ColourModels`.
        person_scores: the person's `BICScores`.
        background_scores: the background's `BICScores`.
    """

    structure: ColourStructure
    models: ColourModels
    person_scores: BICScores
    background_scores: BICScores


def gmm_n_params(t: int, d: int, param_count: str = "exact") -> int:
    """The free parameters k of a full-covariance GMM (LEVELSET TR eq. 8).

    Args:
        t: components, >= 1.
        d: dimensions, >= 1.
        param_count: "exact": t d means + t d (d + 1) / 2 covariances + (t - 1) weights (the weights
            sum to 1); "tr": the TR's t (d + 1)(d + 2) / 2 (t weights: one more).

    Returns:
        k.

    Raises:
        ValueError: naming the argument for t or d < 1 or an unknown param_count.
    """
    check_int(t, "t", min_value=1)
    check_int(d, "d", min_value=1)
    check_choice(param_count, "param_count", ("exact", "tr"))
    if param_count == "tr":
        return t * (d + 1) * (d + 2) // 2
    return t * d + t * d * (d + 1) // 2 + (t - 1)


def bic(log_likelihood: float, n_params: int, n_points: int) -> float:
    """The Bayesian information criterion of LEVELSET TR eq. 8: -2 ln L + k ln N.

    Args:
        log_likelihood: ln L.
        n_params: k.
        n_points: N.

    Returns:
        BIC, as a float.
    """
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


@dataclasses.dataclass(frozen=True)
class BICOptions:
    """How the colour GMMs are fitted and their sizes chosen by BIC (LEVELSET TR §3.4, eq. 8).

    Validated on construction; the candidates are stored sorted.

    Attributes:
        candidates: the numbers of components t to try: distinct positive integers.
        n_iter: EM iterations per start, >= 1.
        n_init: k-means++ starts per candidate, >= 1 (the best by likelihood is kept).
        reg: added to every covariance's diagonal, > 0.
        param_count: the parameter count k of eq. 8 (`gmm_n_params`): "exact" (t - 1 free weights,
            the one BIC is defined with) or "tr" (the TR's count, t weights; it adds ln N to every
            candidate alike, so both choose the same t).

    Raises:
        ValueError: naming the field for empty, non-positive or repeated candidates or another value
            out of range.
    """

    candidates: Sequence[int] = (1, 2, 3, 4, 5)
    n_iter: int = 100
    n_init: int = 3
    reg: float = 1e-5
    param_count: str = "exact"

    def __post_init__(self):
        object.__setattr__(self, "candidates", _check_candidates(self.candidates))
        check_int(self.n_iter, "n_iter", min_value=1)
        check_int(self.n_init, "n_init", min_value=1)
        check_real(self.reg, "reg", min_value=0.0, exclusive_min=True)
        check_choice(self.param_count, "param_count", ("exact", "tr"))


def _check_bic_options(options) -> BICOptions:
    if not isinstance(options, BICOptions):
        raise ValueError(f"options: expected a BICOptions, got {type(options).__name__}")
    return options


def fit_gmm_bic(key: Key[Array, ""], x: Float[ArrayLike, "N d"],
                options: BICOptions = BICOptions()) -> tuple[GMM, BICScores]:
    """The GMM whose number of components has the lowest BIC (LEVELSET TR §3.4, eq. 8).

    Every candidate size t is fitted by the EM of `hog_jax.fit_gmm` (full covariances) as the best,
    by likelihood, of `options.n_init` runs from k-means++ seeds; the chosen one minimises eq. 8,
    BIC = -2 ln L + k ln N. All sizes and starts share one compilation and run as one `vmap`.

    Args:
        key: a `jax.random` key.
        x: (N, d) points.
        options: the candidates and the EM options (`BICOptions`).

    Returns:
        The chosen `GMM` and the BIC table (`BICScores`) of every candidate.

    Raises:
        ValueError: naming the argument for a key that is not a `jax.random` key, empty or
            non-finite x, N not above the largest candidate's parameter count, or options that are
            not a `BICOptions`.
    """
    check_key(key, "key")
    x = as_array(x, "x", ndim=2, dtype=np.float32, min_value=-1e12, max_value=1e12)
    o = _check_bic_options(options)
    return _fit_bic(key, x, o.candidates, o.n_iter, o.n_init, o.reg, o.param_count, "x")


def _features(rgb, space: str):
    return rgb_to_chroma(rgb) if space == "chroma" else jnp.asarray(rgb, jnp.float32) / 255.0


def _check_video(frames, name: str) -> np.ndarray:
    arr = as_array(frames, name, ndim=4, dtype=np.float32, min_value=0, max_value=255)
    if arr.shape[-1] != 3:
        raise ValueError(f"{name}: expected (T, H, W, 3) RGB frames, got shape {arr.shape}")
    return arr


def fit_person_background_models(key: Key[Array, ""], frames: Real[ArrayLike, "T H W 3"],
                                 person_masks: Bool[ArrayLike, "T H W"], options: BICOptions = BICOptions(), *,
                                 max_pixels: int = 20000, space: str = "rgb",
                                 ignore: Bool[ArrayLike, "T H W"] | None = None,
                                 ghost_quantile: float | None = None) -> ColourFit:
    """The person's and the background's colour GMMs, each sized by BIC (LEVELSET TR §3.4, eq. 8).

    The TR's protocol: the frames after the person has entered, with the person's pixels (the moving
    regions, from the background model), give a person GMM and a background GMM (`fit_gmm_bic`).
    Each region is subsampled without replacement to n = min(max_pixels, person pixels, background
    pixels) pixels, the same number for both so that one compiled EM serves both.

    The background is fitted first. On real video the person is often in view from the first frame,
    so the background model has learnt the person where they sat and reports the wall they uncover as
    moving (a *ghost*); taught as the person, the wall's colour would stay "person" for good. So a
    moving pixel whose colour the background GMM explains as well as the background's own pixels (its
    log-density at least the `ghost_quantile` quantile of theirs) teaches neither model. The person is
    then fitted on min(n, the pixels left) of the rest; where the rule would leave too few pixels for
    BIC's largest candidate, every moving pixel teaches the person (the TR's rule).

    Args:
        key: a `jax.random` key (the subsampling and the fits).
        frames: (T, H, W, 3) RGB frames in [0, 255].
        person_masks: (T, H, W) bool, the person's pixels.
        options: the candidates and the EM options (`BICOptions`).
        max_pixels: the most pixels per region, >= 1.
        space: the colour space, "rgb" (R, G, B / 255: the TR models the person's clothing colour)
            or "chroma" ((Cr, Cb) / 255, as the skin model). Densities of different spaces are not
            comparable: regions that compete in eq. 7 should share one space.
        ignore: (T, H, W) bool, pixels that teach neither model (e.g. the skin, which has its own).
        ghost_quantile: in (0, 1), the ghost rule's quantile (0.01 for real video,
            `VideoOptions.real_video()`), or None for the TR's rule (every moving pixel teaches the
            person).

    Returns:
        A `ColourFit`: the structure, the models and both BIC tables.

    Raises:
        ValueError: naming the argument for a key that is not a `jax.random` key, bad frames, masks
            of another shape or with values other than 0/1, a region too small for BIC over the
            candidates (`person_masks`), options that are not a `BICOptions`, max_pixels < 1, an
            unknown space or a ghost_quantile outside (0, 1).
    """
    check_key(key, "key")
    arr = _check_video(frames, "frames")
    masks = as_array(person_masks, "person_masks", dtype=None)
    if masks.shape != arr.shape[:3]:
        raise ValueError(f"person_masks: expected shape {arr.shape[:3]} (one per frame), got {masks.shape}")
    if masks.dtype != bool and not np.all((masks == 0) | (masks == 1)):
        raise ValueError("person_masks: expected a boolean mask (or 0/1), got other values")
    masks = masks.astype(bool)
    keep = np.ones_like(masks) if ignore is None else ~as_array(ignore, "ignore", shape=masks.shape, dtype=bool)
    o = _check_bic_options(options)
    cands = o.candidates
    n_max = check_int(max_pixels, "max_pixels", min_value=1)
    check_choice(space, "space", tuple(_SPACES))
    if ghost_quantile is not None:
        if not 0.0 < check_real(ghost_quantile, "ghost_quantile") < 1.0:
            raise ValueError(f"ghost_quantile: expected a quantile in (0, 1) or None, got {ghost_quantile}")
    flat = arr.reshape(-1, 3)
    regions = [np.flatnonzero((masks & keep).reshape(-1)), np.flatnonzero((~masks & keep).reshape(-1))]
    n = min(n_max, *(len(r) for r in regions))
    need = gmm_n_params(cands[-1], _SPACES[space], o.param_count)
    if n <= need:
        counts = ", ".join(f"{len(r)} {name}" for r, name in zip(regions, REGIONS))
        raise ValueError(f"person_masks: {counts} pixels; BIC over up to {cands[-1]} components needs more than "
                         f"{need} pixels in each region")
    k_sample, k_person, k_background = jax.random.split(key, 3)
    rng = _numpy_rng(k_sample)
    features = lambda index: np.asarray(_features(flat[index], space))  # noqa: E731
    fit = lambda k, x: _fit_bic(k, x, cands, o.n_iter, o.n_init, o.reg, o.param_count, "person_masks")  # noqa: E731
    seen = features(rng.choice(regions[1], n, replace=False))
    background, b_scores = fit(k_background, seen)
    person_region = regions[0]
    if ghost_quantile is not None:
        floor = np.quantile(np.asarray(gmm_log_prob(background, seen)), ghost_quantile)
        explained = np.asarray(gmm_log_prob(background, features(person_region))) >= floor
        if (~explained).sum() > need:
            person_region = person_region[~explained]
    person, p_scores = fit(k_person, features(rng.choice(person_region, min(n, len(person_region)), replace=False)))
    structure = ColourStructure(int(person.log_weights.shape[0]), int(background.log_weights.shape[0]), space)
    return ColourFit(structure, ColourModels(person, background), p_scores, b_scores)


@jax.jit
def _log_likelihoods(models: ColourModels, x):
    return jnp.stack([gmm_log_prob(models.person, x), gmm_log_prob(models.background, x)], axis=1)


def region_log_likelihoods(models: ColourModels, frames: Real[ArrayLike, "T H W 3"],
                           space: str = "rgb") -> Float[Array, "T R H W"]:
    """log p(colour | region) of every pixel under the person's and the background's mixtures.

    The e_i of LEVELSET TR eq. 7 for the person and the background (`REGIONS` order of this module:
    person, background).

    Args:
        models: the `ColourModels`.
        frames: (T, H, W, 3) RGB frames in [0, 255].
        space: the models' colour space (a `ColourFit.structure.space`).

    Returns:
        (T, 2, H, W) float32 log-likelihoods.

    Raises:
        ValueError: naming the argument for frames that are not (T, H, W, 3) in [0, 255], an unknown
            space, or a space of another dimension than the models'.
    """
    arr = _check_video(frames, "frames")
    check_choice(space, "space", tuple(_SPACES))
    d = int(models.person.means.shape[-1])
    if d != _SPACES[space]:
        raise ValueError(f"space: the models have {d} colour dimensions, {space!r} has {_SPACES[space]}")
    return _log_likelihoods(models, _features(jnp.asarray(arr), space))
