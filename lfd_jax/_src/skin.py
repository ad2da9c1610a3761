"""Skin models fitted on one's own labelled skin pixels: the UCI Skin Segmentation file reader and the
chroma skin model with its decision threshold chosen on held-out pixels (GRASP §III-A: the hand is the
largest skin region; the threshold is the log-likelihood ratio above which a pixel is skin)."""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import cv2
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


def load_mask_pixels(images: list[str | Path], masks: list[str | Path], n_pixels: int = 20000,
                     seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Labelled pixels sampled from photos with skin masks (the HGR layout: mask 0 (black) is skin).

    Every photo gives the same share of `n_pixels` (uniform without replacement within the photo),
    so a large photo does not outweigh the others.

    Args:
        images: the photo files (any format OpenCV reads).
        masks: the mask files in the same order, the same size as their photos, skin where 0.
        n_pixels: pixels in all, >= len(images).
        seed: the sample's seed.

    Returns:
        (rgb (N, 3) float32 in R, G, B order, is_skin (N,) bool).

    Raises:
        ValueError: naming the argument for lists of different lengths or none, unreadable files,
            sizes that differ, or n_pixels < len(images).
    """
    if not len(images) or len(images) != len(masks):
        raise ValueError(f"images, masks: expected equally many files, at least one, got {len(images)} and "
                         f"{len(masks)}")
    n_pixels = check_int(n_pixels, "n_pixels", min_value=len(images))
    rng = np.random.default_rng(seed)
    per = np.diff(np.linspace(0, n_pixels, len(images) + 1).round().astype(int))
    rgb, skin = [], []
    for image, mask, k in zip(images, masks, per):
        bgr, m = cv2.imread(str(image), cv2.IMREAD_COLOR), cv2.imread(str(mask), cv2.IMREAD_GRAYSCALE)
        if bgr is None or m is None:
            raise ValueError(f"images: could not read {image} or its mask {mask}")
        if m.shape != bgr.shape[:2]:
            raise ValueError(f"masks: {mask} is {m.shape}, its photo {bgr.shape[:2]}")
        pick = rng.choice(m.size, min(k, m.size), replace=False)
        rgb.append(bgr.reshape(-1, 3)[pick, ::-1])
        skin.append(m.ravel()[pick] == 0)
    return np.concatenate(rgb).astype(np.float32), np.concatenate(skin)


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


HGR_FOLDER = "hgr_hands"
REAL_SKIN_PERSONS = ("id01", "id02", "id03")


def fit_real_skin_model(data: str | Path, n_pixels: int = 20000, luma: bool = True, threshold: float = 1.0,
                        hgr_persons: tuple[str, ...] = REAL_SKIN_PERSONS, seed: int = 0) -> SkinModel:
    """The one skin model of stills and video, fitted on real labelled pixels (GRASP §III-A).

    Skin and background mixtures (4 components each, `hog_jax.fit_skin_model`) over (Cr, Cb, Y) / 255
    (`luma`) of `n_pixels` / 2 skin and as many non-skin pixels of the UCI Skin Segmentation file
    (faces of many ages and skin tones; all of them where there are fewer) and `n_pixels` pixels of the HGR hand photos of `hgr_persons`
    (hands and forearms on real backgrounds; `load_mask_pixels`), when `data/hgr_hands/` exists. The
    defaults are those `python -m experiments.skin_real --preset model` chose on validation persons of
    HGR and held-out UCI pixels, with the same fitted persons, so its test figures (other HGR persons,
    egocentric kitchen frames) describe this model.

    Args:
        data: the folder holding the UCI file (`UCI_FILE`) and optionally `hgr_hands/` (images/ and
            masks/ of the HGR layout).
        n_pixels: the pixels sampled from each source, >= 2.
        luma: model (Cr, Cb, Y) rather than (Cr, Cb).
        threshold: the log-ratio threshold stored in the model.
        hgr_persons: the HGR person ids (the `idNN` part of the photo names) fitted on.
        seed: the samples' and the mixtures' seed.

    Returns:
        The `SkinModel`, its `threshold` set.

    Raises:
        FileNotFoundError: naming the UCI file when it is absent.
        ValueError: naming the argument for n_pixels < 2, a non-finite threshold, or a UCI file
            without both labels (`data`).
    """
    n_pixels = check_int(n_pixels, "n_pixels", min_value=2)
    threshold = check_real(threshold, "threshold")
    uci = Path(data) / UCI_FILE
    if not uci.is_file():
        raise FileNotFoundError(f"no skin pixels at {uci}: pass the folder holding {UCI_FILE} (UCI Skin Segmentation)")
    rng = np.random.default_rng(seed)
    rgb, is_skin = load_uci_pixels(uci)
    skin_index, other_index = np.flatnonzero(is_skin), np.flatnonzero(~is_skin)
    if not len(skin_index) or not len(other_index):
        raise ValueError(f"data: {uci} needs skin and non-skin pixels")
    skin = [rgb[rng.choice(skin_index, min(n_pixels // 2, len(skin_index)), replace=False)]]
    background = [rgb[rng.choice(other_index, min(n_pixels // 2, len(other_index)), replace=False)]]
    folder = Path(data) / HGR_FOLDER
    names = sorted(p.stem for p in (folder / "images").glob("*.jpg") if any(f"_{i}_" in p.stem for i in hgr_persons))
    if names:
        hrgb, hskin = load_mask_pixels([folder / "images" / f"{n}.jpg" for n in names],
                                       [folder / "masks" / f"{n}.bmp" for n in names], n_pixels, seed)
        skin.append(hrgb[hskin])
        background.append(hrgb[~hskin])
    return fit_skin_model(jax.random.key(seed), np.concatenate(skin), np.concatenate(background), threshold=threshold,
                          luma=luma)
