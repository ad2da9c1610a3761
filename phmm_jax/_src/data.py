"""Sequences in, checked and padded: the boundary between user data and jitted code.

Padding and the dtype policy are `lfd_common.pad_sequences`'s (the compute dtype, values that
overflow it rejected); what is specific to these models lives here: a sequence must fit the paths
the structure allows (`check_feasible`), and PHMM training stacks one group of sequences per grid
corner (`stack_groups`).
"""
from __future__ import annotations

from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float, Int

from lfd_common import float_dtype, pad_sequences
from phmm_jax._src.model import HMMConfig

# What the public functions accept as sequences (annotations only; `pad_sequences` checks them):
# a padded (B, T, D) array with lengths, one (T, D) sequence, or a list of (T_b, D) arrays.
Sequences = Float[ArrayLike, "B T D"] | Float[ArrayLike, "T D"] | Sequence[Float[ArrayLike, "_T D"]]
Lengths = Int[ArrayLike, " B"] | None


def check_feasible(config: HMMConfig, lengths: np.ndarray, name: str = "lengths") -> None:
    """Raise `ValueError` if a sequence is shorter (longer) than the shortest (longest) allowed path."""
    short = int(lengths.min())
    if short < config.min_length:
        raise ValueError(
            f"{name}: a sequence of {short} frames is shorter than the shortest allowed path "
            f"({config.n_states} states x min_duration {config.min_duration} = {config.min_length} frames)")
    if config.max_length is not None and int(lengths.max()) > config.max_length:
        raise ValueError(
            f"{name}: a sequence of {int(lengths.max())} frames is longer than the longest allowed path "
            f"({config.n_states} states x max_duration {config.max_duration} = {config.max_length} frames)")


def to_device(X: np.ndarray, lengths: np.ndarray):
    """Padded numpy (X, lengths) -> jax arrays in the compute dtype and int32."""
    return jnp.asarray(X, float_dtype()), jnp.asarray(lengths, jnp.int32)


def stack_groups(groups: Sequence, dim: int | None, name: str):
    """Pad several groups of sequences to one (G, B, T, D) array with lengths and weights (G, B).

    Missing sequences in smaller groups get weight 0 and copy a real sequence of their group, so
    they are valid input everywhere and contribute nothing.
    """
    padded = [pad_sequences(g, dim=dim, name=f"{name}[{k}]") for k, g in enumerate(groups)]
    n_seq = max(x.shape[0] for x, _ in padded)
    n_frames = max(x.shape[1] for x, _ in padded)
    n_dims = {x.shape[2] for x, _ in padded}
    if len(n_dims) != 1:
        raise ValueError(f"{name}: groups have different feature dimensions {sorted(n_dims)}")
    X = np.zeros((len(padded), n_seq, n_frames, n_dims.pop()), float_dtype())
    lengths = np.zeros((len(padded), n_seq), np.int32)
    weights = np.zeros((len(padded), n_seq), float_dtype())
    for k, (x, ln) in enumerate(padded):
        fill = np.arange(n_seq) % x.shape[0]
        X[k, :, : x.shape[1]] = x[fill]
        lengths[k] = ln[fill]
        weights[k, : x.shape[0]] = 1.0
    return X, lengths, weights
