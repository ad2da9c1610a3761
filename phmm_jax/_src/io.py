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
    """The static structure of a `PHMM` (PHMM §III-B): the local HMMs' structure and the grid.

    What a saved PHMM's file stores as JSON.

    Attributes:
        hmm: The `HMMConfig` every local HMM shares.
        grid_shape: (g_1, ..., g_d), grid points per parameter, each >= 2.

    Raises:
        ValueError: Naming the field, for an `hmm` that is not an HMMConfig or a `grid_shape` that
            is not a non-empty tuple of sizes >= 2.
    """

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
    """Write an `HMM` or a `PHMM` to a model file (kind, structure as JSON, one array per leaf).

    The model is checked as `load` checks it, so what `save` writes always loads. Fit options are
    not part of a model and not saved.

    Args:
        path: The file; ".npz" is appended when missing.
        model: The `HMM` or `PHMM`.

    Returns:
        The path of the file written.

    Raises:
        ValueError: Naming `model` when it is neither an HMM nor a PHMM, or its arrays disagree
            with its structure (covariances not positive definite, non-normalised transitions);
            naming `path` when it is not a path.
    """
    return save_model(path, model, CODECS)


def load(path: str | Path) -> HMM | PHMM:
    """Read a model written by `save` (the kind stored in the file says which).

    Args:
        path: The file (".npz" appended when missing, as `save` does).

    Returns:
        The stored `HMM` or `PHMM`, its arrays in the compute dtype.

    Raises:
        FileNotFoundError: The file does not exist.
        ValueError: Naming the file, for a corrupt or foreign file, or one whose arrays disagree
            with its structure (shapes, positive-definite covariances, normalised transitions).
    """
    return load_model(path, CODECS)
