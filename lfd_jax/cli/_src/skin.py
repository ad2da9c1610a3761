"""The skin colour model of `lfd-jax grasp` and `lfd-jax video`: the one skin model of stills and video
(`hog_jax.SkinModel`), read from a file (`hog_jax.save_skin_model`) or fitted on the real labelled pixels
of a data folder (`lfd_jax.fit_real_skin_model`: the UCI Skin Segmentation file, and the HGR hand photos
when the folder holds them)."""
from __future__ import annotations

from pathlib import Path

import hog_jax
from lfd_jax._src.skin import UCI_FILE, fit_real_skin_model


def uci_file(folder: Path) -> Path:
    """folder/skin_nonskin_uci.tsv; FileNotFoundError saying what to pass when it is absent."""
    path = Path(folder) / UCI_FILE
    if not path.is_file():
        raise FileNotFoundError(f"no skin pixels at {path}: pass --skin-data DIR holding {UCI_FILE} "
                                "(UCI Skin Segmentation layout: a header line, then 'B G R label' per pixel)")
    return path


def skin_model(skin_model_file: Path | None, skin_data: Path) -> hog_jax.SkinModel:
    """The file `skin_model_file` (`hog_jax.save_skin_model`), else the model fitted on the real pixels of
    `skin_data` (`lfd_jax.fit_real_skin_model`)."""
    if skin_model_file is not None:
        return hog_jax.load_skin_model(skin_model_file)
    uci_file(skin_data)
    return fit_real_skin_model(skin_data)
