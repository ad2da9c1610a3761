"""Rules for skin-coloured pixels that are not skin (wood, packaging, jam), beside the skin model.

Shapes: B frames, H x W pixels.

A chroma model (GRASP §III-A) calls every pixel of skin chroma skin. Three per-pixel rules, each
learnt from the true skin pixels of labelled photos (`fit_skin_rules`) and each an option (a bound
left at its default turns the rule off), veto pixels that skin does not produce:

* luma: Y / 255 (BT.601) outside [min_luma, max_luma]: near black or blown out, where chroma is noise;
* saturation: the chroma distance from grey, |(Cr, Cb) / 255 - (128, 128) / 255|, above
  max_saturation (saturated reds of packaging and jam share skin's hue, not its saturation);
* texture: the standard deviation of Y / 255 over a window x window box (edges replicated) above
  max_texture (grain and print; skin is smooth at this scale).

In video a fourth rule uses the background model (LEVELSET TR §3.2): a pixel whose background
colour is skin-coloured and which still looks like its background is the static scene (a wooden
table seen from the first frame), not a person (`static_skin`).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Real

from hog_jax._src.segment import SkinModel, log_ratio, rgb_to_chroma
from lfd_common import as_array, check_int, check_real

__all__ = ["SkinRules", "fit_skin_rules", "skin_rule_mask", "static_skin"]

RULES = ("luma", "saturation", "texture")


class SkinRules(NamedTuple):
    """Bounds that a skin pixel keeps; the defaults turn every rule off.

    Attributes:
        min_luma: lowest Y / 255 of skin (default 0: off).
        max_luma: highest Y / 255 of skin (default 1: off).
        max_saturation: largest chroma distance from grey, in (Cr, Cb) / 255 (default inf: off).
        max_texture: largest local standard deviation of Y / 255 (default inf: off).
        window: the side of the texture window, odd, >= 3 (default 5).
    """

    min_luma: float = 0.0
    max_luma: float = 1.0
    max_saturation: float = math.inf
    max_texture: float = math.inf
    window: int = 5


def _check_rules(rules: SkinRules) -> SkinRules:
    if not isinstance(rules, SkinRules):
        raise ValueError(f"rules: expected a SkinRules, got {type(rules).__name__}")
    check_real(rules.min_luma, "rules.min_luma", min_value=0.0, max_value=1.0)
    check_real(rules.max_luma, "rules.max_luma", min_value=rules.min_luma, max_value=1.0)
    for name in ("max_saturation", "max_texture"):
        if not getattr(rules, name) >= 0.0:
            raise ValueError(f"rules.{name}: expected a bound >= 0 (inf: off), got {getattr(rules, name)}")
    window = check_int(rules.window, "rules.window", min_value=3, max_value=63)
    if window % 2 == 0:
        raise ValueError(f"rules.window: expected an odd side, got {window}")
    return rules


def _features(frames, window: int):
    """(luma, saturation, texture) per pixel of (B, H, W, 3) RGB frames, each (B, H, W)."""
    luma = (frames @ jnp.array([0.299, 0.587, 0.114], jnp.float32)) / 255.0
    saturation = jnp.linalg.norm(rgb_to_chroma(frames) - 128.0 / 255.0, axis=-1)
    h = window // 2
    padded = jnp.pad(luma, ((0, 0), (h, h), (h, h)), mode="edge")
    box = lambda a: jax.lax.reduce_window(a, 0.0, jax.lax.add, (1, window, window), (1, 1, 1), "VALID") / window ** 2
    mean, second = box(padded), box(padded ** 2)
    texture = jnp.sqrt(jnp.maximum(second - mean ** 2, 0.0))
    return luma, saturation, texture


_features_jit = jax.jit(_features, static_argnames=("window",))


@jax.jit
def _rule_mask(rules: SkinRules, luma, saturation, texture):
    return ((luma >= rules.min_luma) & (luma <= rules.max_luma) & (saturation <= rules.max_saturation)
            & (texture <= rules.max_texture))


def _frames(frames, name: str = "frames") -> np.ndarray:
    arr = as_array(frames, name, ndim=4, dtype=np.float32, min_value=0, max_value=255)
    if arr.shape[-1] != 3:
        raise ValueError(f"{name}: expected (B, H, W, 3) RGB frames, got shape {arr.shape}")
    return arr


def skin_rule_mask(rules: SkinRules, frames: Real[ArrayLike, "B H W 3"]) -> Bool[Array, "B H W"]:
    """Where each rule lets a pixel be skin (and it with a skin model's mask).

    Args:
        rules: the `SkinRules` (`fit_skin_rules`, or bounds of one's own).
        frames: (B, H, W, 3) RGB frames in [0, 255].

    Returns:
        (B, H, W) bool: True where luma, saturation and texture are within the bounds.

    Raises:
        ValueError: naming the argument for frames of the wrong shape or range, or bounds out of range.
    """
    rules = _check_rules(rules)
    arr = _frames(frames)
    feats = _features_jit(jnp.asarray(arr), int(rules.window))
    bounds = SkinRules(*(jnp.float32(v) for v in rules[:4]), jnp.int32(rules.window))
    return _rule_mask(bounds, *feats)


def fit_skin_rules(frames: Real[ArrayLike, "B H W 3"], skin: Bool[ArrayLike, "B H W"],
                   rules: tuple[str, ...] = RULES, quantile: float = 0.01, window: int = 5) -> SkinRules:
    """Rule bounds from the true skin pixels of labelled photos: each keeps all but `quantile` of them.

    min_luma is the `quantile` quantile of the skin pixels' Y / 255, max_luma the 1 - `quantile` one;
    max_saturation and max_texture the 1 - `quantile` quantiles of their saturation and local standard
    deviation (window x window). A rule not named in `rules` keeps its off default.

    Args:
        frames: (B, H, W, 3) RGB photos in [0, 255] (pad smaller photos and leave the padding out of `skin`).
        skin: (B, H, W) bool, the true skin pixels (at least one).
        rules: which rules to fit, a subset of ("luma", "saturation", "texture").
        quantile: the share of skin pixels each rule may lose on its side, in [0, 0.5).
        window: the texture window's side, odd, >= 3.

    Returns:
        The `SkinRules`.

    Raises:
        ValueError: naming the argument for frames or masks of the wrong shape, no skin pixel, an
            unknown rule, or a quantile or window out of range.
    """
    arr = _frames(frames)
    mask = as_array(skin, "skin", shape=arr.shape[:3], dtype=bool)
    if not mask.any():
        raise ValueError("skin: expected at least one skin pixel")
    unknown = set(rules) - set(RULES)
    if unknown or isinstance(rules, str):
        raise ValueError(f"rules: expected names among {RULES}, got {rules!r}")
    q = check_real(quantile, "quantile", min_value=0.0, max_value=0.5)
    if q >= 0.5:
        raise ValueError(f"quantile: expected a value in [0, 0.5), got {quantile}")
    off = SkinRules(window=window)
    _check_rules(off)
    luma, saturation, texture = (np.asarray(f)[mask] for f in _features_jit(jnp.asarray(arr), int(window)))
    return SkinRules(
        min_luma=float(np.quantile(luma, q)) if "luma" in rules else off.min_luma,
        max_luma=float(np.quantile(luma, 1 - q)) if "luma" in rules else off.max_luma,
        max_saturation=float(np.quantile(saturation, 1 - q)) if "saturation" in rules else off.max_saturation,
        max_texture=float(np.quantile(texture, 1 - q)) if "texture" in rules else off.max_texture,
        window=int(window))


@jax.jit
def _static(model: SkinModel, frames, background, threshold, max_difference):
    background_skin = log_ratio(model, background) > threshold                      # (H, W)
    unchanged = jnp.max(jnp.abs(frames - background), axis=-1) <= max_difference     # (B, H, W)
    return background_skin & unchanged


def static_skin(model: SkinModel, frames: Real[ArrayLike, "B H W 3"], background: Real[ArrayLike, "H W 3"],
                threshold: float | None = None, max_difference: float = 30.0) -> Bool[Array, "B H W"]:
    """Skin-coloured static scene: pixels whose background is skin-coloured and which look like it.

    A pixel is static skin-coloured scene where the skin model calls the background's colour skin
    (log ratio > threshold) and the frame's colour is within `max_difference` of the background's in
    every channel (the background model's mean, LEVELSET TR §3.2: a table seen from the first frame).
    Take these pixels out of the skin mask (`skin & ~static_skin(...)`); a hand over the table
    differs from the table's colour, so it stays.

    Args:
        model: the `SkinModel`.
        frames: (B, H, W, 3) RGB frames in [0, 255].
        background: (H, W, 3) the background's RGB (e.g. the mean of the background model), [0, 255].
        threshold: the log-ratio threshold (default the model's own).
        max_difference: the largest per-channel difference from the background, in [0, 255].

    Returns:
        (B, H, W) bool, True on static skin-coloured scene.

    Raises:
        ValueError: naming the argument for arrays of the wrong shape or range, a non-finite
            threshold, or max_difference out of range.
    """
    arr = _frames(frames)
    bg = as_array(background, "background", shape=(arr.shape[1], arr.shape[2], 3), dtype=np.float32,
                  min_value=0, max_value=255)
    thr = model.threshold if threshold is None else jnp.float32(check_real(threshold, "threshold"))
    diff = check_real(max_difference, "max_difference", min_value=0.0, max_value=255.0)
    return _static(model, jnp.asarray(arr), jnp.asarray(bg), thr, jnp.float32(diff))
