"""Validation of user batches at the public boundary (numpy in, outside jit).

Every public function that takes user data goes through `check_batch` / `check_vectors` /
`check_labels` / `check_class_labels`, so bad input (length 0, NaN features, label out of range,
mismatched batch sizes) is a `ValueError` naming the argument, never a silent NaN. Features are
checked and converted by `lfd_common.pad_sequences`, so they follow its one dtype policy (the compute
dtype: float32 unless x64 is enabled; values overflowing it are rejected). Padding (frames at
`t >= lengths[b]`) is not checked and is zeroed, so whatever a caller leaves there cannot reach the
jitted code.

Shapes: B batch, T (padded) time, D features, N vectors.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from lfd_common import as_array, frame_mask, pad_sequences


def check_batch(
    X: Any,
    lengths: Any = None,
    *,
    n_features: int | None = None,
    name: str = "X",
    lengths_name: str = "lengths",
) -> tuple[np.ndarray, np.ndarray]:
    """Validate a padded batch of feature sequences.

    X: (B, T, D) real, finite on real frames. A single sequence (T, D) is not accepted here;
    callers wrap it. lengths: (B,) ints in [1, T], or None for "all T".
    Returns (X in the compute dtype with padding zeroed, lengths int32).
    """
    X = as_array(X, name, ndim=3, dtype=None, finite=False, nonempty=False)
    return pad_sequences(X, lengths, dim=n_features, name=name, lengths_name=lengths_name)


def check_vectors(X: Any, *, n_features: int | None = None, name: str = "X") -> np.ndarray:
    """Validate N feature vectors X (N, D) (finite, N, D >= 1); returned in the compute dtype.

    Checked as one sequence of N frames, so that vectors and sequences share one dtype policy.
    """
    X = as_array(X, name, ndim=2, dtype=None, finite=False, nonempty=False)
    return pad_sequences(X, dim=n_features, name=name)[0][0]


def check_labels(y: Any, lengths: np.ndarray, n_labels: int, name: str = "y") -> np.ndarray:
    """Validate per-frame labels y (B, T) ints in [0, n_labels) on real frames; padding is set to 0."""
    lengths = np.asarray(lengths)
    B = lengths.shape[0]
    raw = as_array(y, name, ndim=2, dtype=None, finite=False)
    if raw.shape[0] != B:
        raise ValueError(f"{name}: expected {B} label sequences (the batch size of X), got {raw.shape[0]}")
    T = raw.shape[1]
    if T < int(lengths.max()):
        raise ValueError(f"{name}: expected at least {int(lengths.max())} labels per sequence, got {T}")
    mask = frame_mask(lengths, T)
    real = raw[mask]
    if np.issubdtype(real.dtype, np.floating):
        if not np.all(np.isfinite(real)) or not np.all(real == np.round(real)):
            raise ValueError(f"{name}: expected integer labels, got non-integral values")
    elif not np.issubdtype(real.dtype, np.integer):
        raise ValueError(f"{name}: expected integer labels, got dtype {raw.dtype}")
    real = real.astype(np.int64)
    if real.size and (real.min() < 0 or real.max() >= n_labels):
        bad = real[(real < 0) | (real >= n_labels)][0]
        raise ValueError(f"{name}: labels must be in [0, {n_labels}), got {int(bad)}")
    out = np.zeros(raw.shape, np.int32)
    out[mask] = real
    return out


def check_class_labels(y: Any, n_seq: int, n_labels: int, name: str = "y") -> np.ndarray:
    """Validate one label per sequence: (B,) ints in [0, n_labels)."""
    arr = as_array(y, name, shape=(n_seq,), dtype=np.int64)
    if arr.min() < 0 or arr.max() >= n_labels:
        bad = arr[(arr < 0) | (arr >= n_labels)][0]
        raise ValueError(f"{name}: labels must be in [0, {n_labels}), got {int(bad)}")
    return arr.astype(np.int32)
