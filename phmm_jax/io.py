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

from lfd_common import ArraySpec, ModelCodec, check_int, load_model, save_model
from phmm_jax.model import HMM, HMMConfig, allowed_transitions
from phmm_jax.parametric import PHMM

# Continue + exit probabilities of a reachable pseudo-state must sum to 1 within this (float32 round-off).
_NORMALISATION_TOL = 1e-4


@dataclasses.dataclass(frozen=True)
class PHMMStructure:
    """The static structure of a `PHMM`: the local HMMs' structure and the grid (g_1, ..., g_d)."""

    hmm: HMMConfig
    grid_shape: tuple[int, ...]

    def __post_init__(self):
        if not isinstance(self.hmm, HMMConfig):
            raise ValueError(f"hmm: expected an HMMConfig, got {type(self.hmm).__name__}")
        if not isinstance(self.grid_shape, tuple) or not self.grid_shape:
            raise ValueError(f"grid_shape: expected a non-empty tuple of grid sizes, got {self.grid_shape!r}")
        for g in self.grid_shape:
            check_int(g, "grid_shape", min_value=2)


def _hmm_template(config: HMMConfig, lead: tuple[int, ...] = ()) -> HMM:
    n, p = config.n_states, config.n_pseudo
    return HMM(ArraySpec((*lead, n, "D")), ArraySpec((*lead, n, "D", "D")),
               ArraySpec((*lead, n, p), finite=False), ArraySpec((*lead, n, p), finite=False), config)


def _reachable(config: HMMConfig, cont: np.ndarray, exits: np.ndarray) -> np.ndarray:
    """(..., N, P) bool: pseudo-states some path from the start (0, 0) can be on."""
    reach = np.zeros(cont.shape, bool)
    entered = np.ones(cont.shape[:-2], bool)
    for i in range(config.n_states):
        reach[..., i, 0] = entered
        for j in range(1, config.n_pseudo):
            reach[..., i, j] = reach[..., i, j - 1] & (cont[..., i, j - 1] > 0)
        entered = np.any(reach[..., i, :] & (exits[..., i, :] > 0), axis=-1)
    return reach


def check_hmm(hmm: HMM) -> None:
    """Raise `ValueError` unless `hmm`'s arrays (any leading axes) are a valid model of its structure.

    Covariances symmetric positive definite (diagonal for covariance_type "diag"); transitions the
    structure forbids exactly -inf (`model.allowed_transitions`); on every pseudo-state a path can
    reach, continue + exit probabilities sum to 1; and some path can end (exit the last state).
    """
    config = hmm.config
    cov = np.asarray(hmm.covariances, np.float64)
    if not np.allclose(cov, np.swapaxes(cov, -1, -2), rtol=1e-5, atol=1e-8):
        raise ValueError("covariances: not symmetric")
    if config.covariance_type == "diag" and np.any(cov * (1 - np.eye(cov.shape[-1])) != 0):
        raise ValueError('covariances: covariance_type "diag" but off-diagonal entries are not zero')
    if cov.size and np.min(np.linalg.eigvalsh(cov)) <= 0:
        raise ValueError("covariances: not positive definite (an eigenvalue <= 0)")
    log_cont, log_exit = np.asarray(hmm.log_cont, np.float64), np.asarray(hmm.log_exit, np.float64)
    may_continue, may_exit = allowed_transitions(config)
    for name, values, allowed in (("log_cont", log_cont, may_continue), ("log_exit", log_exit, may_exit)):
        if np.any(values > _NORMALISATION_TOL) or np.any(np.isfinite(values[..., ~allowed])):
            raise ValueError(f"{name}: log-probabilities must be <= 0 and -inf where the structure forbids them")
    cont, exits = np.exp(log_cont), np.exp(log_exit)
    reach = _reachable(config, cont, exits)
    total = cont + exits
    if np.any(reach & (np.abs(total - 1.0) > _NORMALISATION_TOL)):
        raise ValueError("log_cont, log_exit: continue and exit probabilities of a pseudo-state do not sum to 1")
    if not np.all(np.any(reach[..., -1, :] & (exits[..., -1, :] > 0), axis=-1)):
        raise ValueError("log_exit: no path can leave the last state, so every sequence has probability 0")


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
