"""The skin colour models of `lfd-jax grasp` and `lfd-jax video`, fitted on labelled skin pixels in the
UCI Skin Segmentation layout (`lfd_jax.load_uci_pixels`) or read from a file.

The two pipelines model skin differently, so they take different models: the grasp pipeline's
`hog_jax.segment` a chroma `SkinModel` (skin and background mixtures and a threshold), fitted with its
threshold chosen on held-out pixels (`lfd_jax.fit_thresholded_skin`); the video pipeline's region scores
a skin GMM over RGB / 255 (`hog_jax.video.fit_skin`, LEVELSET TR §3.3), which `hog_jax.save_skin_model`
cannot store.
"""
from __future__ import annotations

from pathlib import Path

import jax
import jax.numpy as jnp

import hog_jax
from hog_jax.video import fit_skin
from lfd_jax._src.skin import UCI_FILE, fit_thresholded_skin, load_uci_pixels


def uci_file(folder: Path) -> Path:
    """folder/skin_nonskin_uci.tsv; FileNotFoundError saying what to pass when it is absent."""
    path = Path(folder) / UCI_FILE
    if not path.is_file():
        raise FileNotFoundError(f"no skin pixels at {path}: pass --skin-data DIR holding {UCI_FILE} "
                                "(UCI Skin Segmentation layout: a header line, then 'B G R label' per pixel)")
    return path


def photo_skin_model(skin_model: Path | None, skin_data: Path) -> hog_jax.SkinModel:
    """The chroma skin model of the grasp pipeline: the file `skin_model` (`hog_jax.save_skin_model`),
    else fitted on the UCI pixels of `skin_data` with its threshold chosen on held-out UCI pixels
    (`lfd_jax.fit_thresholded_skin`) and stored in the model."""
    if skin_model is not None:
        return hog_jax.load_skin_model(skin_model)
    rgb, is_skin = load_uci_pixels(uci_file(skin_data))
    fitted = fit_thresholded_skin(rgb, is_skin)
    return fitted.model._replace(threshold=jnp.float32(fitted.threshold))


def video_skin_gmm(skin_data: Path, seed: int = 0) -> hog_jax.GMM:
    """The video pipeline's skin GMM (RGB / 255, 4 components) fitted on the skin pixels of `skin_data`."""
    rgb, is_skin = load_uci_pixels(uci_file(skin_data))
    return fit_skin(jax.random.key(seed), rgb[is_skin])
