"""Saving and loading HMMs and PHMMs through `lfd_common`'s generic model persistence.

A file holds the kind ("phmm_jax.HMM" or "phmm_jax.PHMM"), the static structure as JSON (the
`HMMConfig`; for a PHMM also the grid shape, `PHMMStructure`) and one array per parameter leaf. On
load, the kind picks the codec, every array is checked against the shape the structure implies
(N states, P pseudo-states, C = Π grid_shape corners, one feature dimension D throughout), and
`check_hmm` rejects what shapes cannot express. Fit options are not part of a model and not saved.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from lfd_common import ArraySpec, ModelCodec, load_model, save_model
from phmm_jax._src.checks import check_grid_shape, check_hmm
from phmm_jax._src.model import HMM, HMMConfig
from phmm_jax._src.parametric import PHMM

__all__ = ["CODECS", "PHMMStructure", "check_hmm", "load", "save"]


@dataclasses.dataclass(frozen=True)
class PHMMStructure:
    """The static structure of a `PHMM`: the local HMMs' structure and the grid (g_1, ..., g_d)."""

    hmm: HMMConfig
    grid_shape: tuple[int, ...]

    def __post_init__(self):
        if not isinstance(self.hmm, HMMConfig):
            raise ValueError(f"hmm: expected an HMMConfig, got {type(self.hmm).__name__}")
        if not isinstance(self.grid_shape, tuple):
            raise ValueError(f"grid_shape: expected a non-empty tuple of grid sizes, got {self.grid_shape!r}")
        check_grid_shape(self.grid_shape)


def _hmm_template(config: HMMConfig, lead: tuple[int, ...] = ()) -> HMM:
    n, p = config.n_states, config.n_pseudo
    return HMM(ArraySpec((*lead, n, "D")), ArraySpec((*lead, n, "D", "D")),
               ArraySpec((*lead, n, p), finite=False), ArraySpec((*lead, n, p), finite=False), config)


CODECS = (
    ModelCodec("phmm_jax.HMM", HMM, HMMConfig, structure_of=lambda hmm: hmm.config,
               template=_hmm_template, check=check_hmm),
    ModelCodec("phmm_jax.PHMM", PHMM, PHMMStructure,
               structure_of=lambda phmm: PHMMStructure(phmm.config, tuple(phmm.grid_shape)),
               template=lambda s: PHMM(_hmm_template(s.hmm, (int(np.prod(s.grid_shape)),)), s.grid_shape),
               check=lambda phmm: check_hmm(phmm.local)),
)


def save(path: str | Path, model: HMM | PHMM) -> Path:
    """Write an `HMM` or a `PHMM` to `path` (".npz" appended when missing); returns the file written.

    The model is checked as `load` checks it, so what `save` writes always loads.
    """
    return save_model(path, model, CODECS)


def load(path: str | Path) -> HMM | PHMM:
    """Read a model written by `save` (the kind stored in the file says which).

    Raises `FileNotFoundError` for a missing file and `ValueError` naming the file for a corrupt or
    foreign one, or one whose arrays disagree with its structure (see `check_hmm`).
    """
    return load_model(path, CODECS)
