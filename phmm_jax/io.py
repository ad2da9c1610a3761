"""Saving and loading HMMs and PHMMs through `lfd_common`'s `.npz` persistence."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from lfd_common import load_arrays, save_arrays
from phmm_jax.model import HMM, HMMConfig
from phmm_jax.parametric import PHMM

_FIELDS = ("means", "covariances", "log_cont", "log_exit")
_KINDS = {HMM: "phmm_jax.HMM", PHMM: "phmm_jax.PHMM"}


def save(path: str | Path, model: HMM | PHMM) -> Path:
    """Write an `HMM` or a `PHMM` to `path` (.npz with schema version and config). Returns the path."""
    hmm = model.local if isinstance(model, PHMM) else model
    if not isinstance(hmm, HMM):
        raise ValueError(f"model: expected an HMM or a PHMM, got {type(model).__name__}")
    config = {"hmm": dataclasses.asdict(hmm.config)}
    if isinstance(model, PHMM):
        config["grid_shape"] = list(model.grid_shape)
    arrays = {name: np.asarray(getattr(hmm, name)) for name in _FIELDS}
    return save_arrays(path, _KINDS[type(model)], arrays, config)


def load(path: str | Path) -> HMM | PHMM:
    """Read a model written by `save`; raises `ValueError` for a corrupt or foreign file."""
    for cls, kind in _KINDS.items():
        try:
            arrays, config, _ = load_arrays(path, kind)
        except ValueError as err:
            if "expected a" in str(err) and "holds a" in str(err):
                continue
            raise
        missing = [name for name in _FIELDS if name not in arrays]
        if missing or "hmm" not in config:
            raise ValueError(f"path: {path} is an incomplete {kind} file (missing {missing or ['config']})")
        try:
            hmm_config = HMMConfig(**config["hmm"])
        except (TypeError, ValueError) as err:
            raise ValueError(f"path: {path} has an invalid HMM config ({err})") from err
        hmm = HMM(*(jnp.asarray(arrays[name]) for name in _FIELDS), hmm_config)
        return PHMM(hmm, tuple(config["grid_shape"])) if cls is PHMM else hmm
    raise ValueError(f"path: {path} holds neither a phmm_jax.HMM nor a phmm_jax.PHMM")
