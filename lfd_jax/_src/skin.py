"""Skin models fitted on one's own labelled skin pixels: the UCI Skin Segmentation file reader and the
chroma skin model with its decision threshold chosen on held-out pixels (GRASP §III-A: the hand is the
largest skin region; the threshold is the log-likelihood ratio above which a pixel is skin)."""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import jax
import numpy as np

from hog_jax import SkinModel, fit_skin_model, skin_log_ratio
from lfd_common import check_int, check_real

UCI_FILE = "skin_nonskin_uci.tsv"


def load_uci_pixels(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Labelled pixels from a file in the UCI Skin Segmentation layout.

    The file has a header line, then one pixel per line: `B G R label` (the colour columns in the
    order blue, green, red, as the UCI documentation says), label 1 skin, 2 non-skin.

    Args:
        path: the file.

    Returns:
        (rgb (N, 3) float32 in R, G, B order, is_skin (N,) bool).

    Raises:
        ValueError: naming `path` when the file is missing or its lines are not `B G R label`.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"path: no file at {path}")
    table = np.loadtxt(path, skiprows=1, dtype=np.int64)
    if table.ndim != 2 or table.shape[1] != 4 or not np.isin(table[:, 3], (1, 2)).all():
        raise ValueError(f"path: {path}: expected lines of B G R label (label 1 or 2), got shape {table.shape}")
    return table[:, [2, 1, 0]].astype(np.float32), table[:, 3] == 1


def best_iou_threshold(log_ratio: np.ndarray, is_skin: np.ndarray) -> tuple[float, float]:
    """The threshold of the rule "skin where log_ratio > t" with the largest skin IoU on labelled pixels.

    Exact over every distinct value: the pixels are sorted once and counted by cumulative sums.

    Args:
        log_ratio: (N,) skin / non-skin log-likelihood ratios of labelled pixels.
        is_skin: (N,) bool, the labels.

    Returns:
        (threshold, IoU). The threshold is the midpoint between the last value called skin and the
        next lower one (the lowest value - 1 when everything is skin, the highest + 1 when nothing is).

    Raises:
        ValueError: when the arrays are empty, differ in size or hold no skin pixel.
    """
    ratio, is_skin = np.asarray(log_ratio, np.float64).ravel(), np.asarray(is_skin, bool).ravel()
    if ratio.size == 0 or ratio.size != is_skin.size or not is_skin.any():
        raise ValueError("log_ratio, is_skin: expected equally many pixels, some of them skin")
    order = np.argsort(-ratio, kind="stable")
    ratio, is_skin = ratio[order], is_skin[order]
    tp = np.concatenate([[0], np.cumsum(is_skin)])  # calling the k highest pixels skin, k = 0..N
    fp = np.arange(ratio.size + 1) - tp
    iou = tp / (is_skin.sum() + fp)
    cut = np.concatenate([[True], ratio[:-1] > ratio[1:], [True]])  # k between two distinct values
    k = int(np.argmax(np.where(cut, iou, -1.0)))
    upper = ratio[k - 1] if k > 0 else ratio[0] + 2.0
    lower = ratio[k] if k < ratio.size else ratio[-1] - 2.0
    return float(0.5 * (upper + lower)), float(iou[k])


class ThresholdedSkin(NamedTuple):
    """A skin model fitted on labelled pixels and the pixels held out to choose its threshold.

    Attributes:
        model: the `hog_jax.SkinModel` (its own `threshold` field as fitted).
        threshold: the chosen log-ratio threshold (the IoU-best on the held-out pixels, or the given one).
        best_threshold: the IoU-best threshold on the held-out pixels.
        best_iou: the held-out skin IoU at `best_threshold`.
        held_out_log_ratio: (V,) the held-out pixels' log-likelihood ratios.
        held_out_is_skin: (V,) bool, their labels.
        n_fit: the number of pixels the model was fitted on.
    """

    model: SkinModel
    threshold: float
    best_threshold: float
    best_iou: float
    held_out_log_ratio: np.ndarray
    held_out_is_skin: np.ndarray
    n_fit: int


def fit_thresholded_skin(rgb: np.ndarray, is_skin: np.ndarray, seed: int = 0, validation_fraction: float = 0.2,
                         n_components: int = 4, n_background: int = 4, n_iter: int = 100,
                         threshold: float | None = None) -> ThresholdedSkin:
    """A chroma skin model (`hog_jax.fit_skin_model`) with its threshold chosen on held-out pixels.

    The pixels are split at random (`seed`) into a fitting part and a held-out `validation_fraction`;
    the threshold is the IoU-best on the held-out pixels (`best_iou_threshold`; unfiltered: single
    pixels have no neighbours), or `threshold` when given.

    Args:
        rgb: (N, 3) pixels, R, G, B in [0, 255].
        is_skin: (N,) bool labels.
        seed: the split's and the mixtures' seed.
        validation_fraction: the share of pixels held out, in (0, 1).
        n_components: skin mixture components.
        n_background: background mixture components.
        n_iter: EM iterations of each mixture.
        threshold: a fixed log-ratio threshold instead of the held-out choice.

    Returns:
        A `ThresholdedSkin`.

    Raises:
        ValueError: naming the argument for pixels of the wrong shape or without both labels, and for
            settings out of range.
    """
    rgb, is_skin = np.asarray(rgb, np.float32), np.asarray(is_skin)
    if rgb.ndim != 2 or rgb.shape[1] != 3 or not len(rgb) or not np.isfinite(rgb).all():
        raise ValueError(f"rgb: expected finite (N, 3) pixels with N > 0, got shape {rgb.shape}")
    if is_skin.shape != (len(rgb),) or is_skin.dtype != bool:
        raise ValueError(f"is_skin: expected ({len(rgb)},) bool labels, got {is_skin.shape} {is_skin.dtype}")
    if not 0.0 < check_real(validation_fraction, "validation_fraction") < 1.0:
        raise ValueError(f"validation_fraction: expected a fraction in (0, 1), got {validation_fraction}")
    for name, value in (("n_components", n_components), ("n_background", n_background), ("n_iter", n_iter)):
        check_int(value, name, min_value=1)
    order = np.random.default_rng(seed).permutation(len(rgb))
    n_validation = int(round(validation_fraction * len(rgb)))
    held_out, fit = order[:n_validation], order[n_validation:]
    if not is_skin[fit].any() or is_skin[fit].all() or not is_skin[held_out].any():
        raise ValueError("is_skin: expected skin and non-skin pixels in both the fitting and the held-out part")
    model = fit_skin_model(jax.random.key(seed), rgb[fit][is_skin[fit]], rgb[fit][~is_skin[fit]],
                           n_components=n_components, n_background=n_background, n_iter=n_iter)
    ratio = np.asarray(skin_log_ratio(model, rgb[held_out]))
    best, best_iou = best_iou_threshold(ratio, is_skin[held_out])
    chosen = best if threshold is None else float(check_real(threshold, "threshold"))
    return ThresholdedSkin(model, chosen, best, best_iou, ratio, is_skin[held_out], len(fit))
