"""Sequences in, checked and padded: the boundary between user data and jitted code."""
from __future__ import annotations

from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np

from lfd_common import as_array
from phmm_jax.model import HMMConfig


def float_dtype():
    """The floating dtype JAX computes in now (float64 under `jax.enable_x64`)."""
    return jnp.result_type(float)


def pad_sequences(X, lengths=None, dim: int | None = None, name: str = "X") -> tuple[np.ndarray, np.ndarray]:
    """Check sequences and return them padded: X (B, T, D) float64 and lengths (B,) int32.

    X: a (B, T, D) array (with `lengths` for unequal lengths, default all T), a single (T, D)
    sequence, or a list of (T_b, D) arrays. Padded frames are zeroed (they may hold NaN on input:
    only frames t < length are checked). `dim`: the expected D.
    """
    if isinstance(X, Sequence) and not isinstance(X, np.ndarray) and len(X) and np.ndim(X[0]) == 2:
        if lengths is not None:
            raise ValueError("lengths: give either a list of sequences or a padded array with lengths, not both")
        seqs = [as_array(x, f"{name}[{b}]", ndim=2) for b, x in enumerate(X)]
        widths = {s.shape[1] for s in seqs}
        if len(widths) != 1:
            raise ValueError(f"{name}: sequences have different feature dimensions {sorted(widths)}")
        lengths = np.array([len(s) for s in seqs], np.int32)
        padded = np.zeros((len(seqs), int(lengths.max()), widths.pop()))
        for b, s in enumerate(seqs):
            padded[b, : len(s)] = s
        X = padded
    else:
        X = as_array(X, name, ndim=(2, 3), finite=False, nonempty=False)
        if X.ndim == 2:
            X = X[None]
    batch, n_frames, n_dims = X.shape
    if batch == 0:
        raise ValueError(f"{name}: the batch is empty")
    if n_frames == 0 or n_dims == 0:
        raise ValueError(f"{name}: must not be empty, got shape {X.shape}")
    if dim is not None and n_dims != dim:
        raise ValueError(f"{name}: expected feature dimension D={dim}, got {n_dims}")
    if lengths is None:
        lengths = np.full(batch, n_frames, np.int32)
    else:
        lengths = as_array(lengths, "lengths", shape=(batch,), dtype=np.int32, min_value=1, max_value=n_frames)
    valid = np.arange(n_frames)[None, :] < lengths[:, None]
    if not np.all(np.isfinite(X[valid])):
        bad = int(np.sum(~np.isfinite(X[valid])))
        raise ValueError(f"{name}: contains {bad} NaN or infinite value(s) within the sequence lengths")
    return np.where(valid[..., None], X, 0.0), lengths


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
    X = np.zeros((len(padded), n_seq, n_frames, n_dims.pop()))
    lengths = np.zeros((len(padded), n_seq), np.int32)
    weights = np.zeros((len(padded), n_seq))
    for k, (x, ln) in enumerate(padded):
        fill = np.arange(n_seq) % x.shape[0]
        X[k, :, : x.shape[1]] = x[fill]
        lengths[k] = ln[fill]
        weights[k, : x.shape[0]] = 1.0
    return X, lengths, weights
