"""Validation of user batches at the public boundary (numpy in, outside jit).

Every public function that takes user data goes through `check_batch` / `check_labels`, so bad
input (length 0, NaN features, label out of range, mismatched batch sizes) is a `ValueError`
naming the argument, never a silent NaN. Padding (frames at `t >= lengths[b]`) is not checked and
is zeroed, so whatever a caller leaves there cannot reach the jitted code.

Shapes: B batch, T (padded) time, D features.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from lfd_common import as_array


def check_lengths(lengths: Any, n_seq: int, max_len: int, name: str = "lengths") -> np.ndarray:
    """Return `lengths` as an int32 (B,) array with 1 <= lengths[b] <= T, or raise `ValueError`."""
    if lengths is None:
        return np.full((n_seq,), max_len, np.int32)
    arr = as_array(lengths, name, shape=(n_seq,), dtype=np.int64, nonempty=True)
    if np.any(arr < 1):
        raise ValueError(f"{name}: every sequence needs length >= 1, got a length {int(arr.min())}")
    if np.any(arr > max_len):
        raise ValueError(f"{name}: lengths must be <= the padded length T={max_len}, got {int(arr.max())}")
    return arr.astype(np.int32)


def frame_mask(lengths: np.ndarray, max_len: int) -> np.ndarray:
    """(B, T) bool: True on real frames, False on padding."""
    return np.arange(max_len)[None, :] < np.asarray(lengths)[:, None]


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
    Returns (X float32 with padding zeroed, lengths int32).
    """
    raw = as_array(X, name, ndim=3, dtype=None, finite=False, nonempty=False)
    B, T, D = raw.shape
    if B == 0:
        raise ValueError(f"{name}: the batch is empty (B = 0)")
    if T == 0:
        raise ValueError(f"{name}: sequences of length 0 (T = 0) cannot be labelled")
    if D == 0:
        raise ValueError(f"{name}: feature dimension D is 0")
    arr = as_array(raw, name, ndim=3, dtype=np.float64, finite=False)
    lens = check_lengths(lengths, B, T, lengths_name)
    mask = frame_mask(lens, T)
    real = arr[mask]
    if not np.all(np.isfinite(real)):
        bad = int(np.size(real) - np.count_nonzero(np.isfinite(real)))
        raise ValueError(f"{name}: contains {bad} NaN or infinite value(s) in real (unpadded) frames")
    if n_features is not None and D != n_features:
        raise ValueError(f"{name}: expected {n_features} features per frame (the model's D), got {D}")
    out = np.where(mask[..., None], arr, 0.0).astype(np.float32)
    return out, lens


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


def pad_sequences(sequences: Any, name: str = "sequences", dtype: Any = np.float32,
                  pad_value: float = 0) -> tuple[np.ndarray, np.ndarray]:
    """Stack a list of (T_b, ...) arrays into a padded (B, T_max, ...) array and their lengths (B,)."""
    if isinstance(sequences, np.ndarray) or not hasattr(sequences, "__len__"):
        raise ValueError(f"{name}: expected a list of per-sequence arrays")
    if len(sequences) == 0:
        raise ValueError(f"{name}: the list is empty")
    arrays = [np.asarray(s) for s in sequences]
    tail = arrays[0].shape[1:]
    for i, a in enumerate(arrays):
        if a.ndim < 1 or a.shape[0] == 0:
            raise ValueError(f"{name}[{i}]: sequences of length 0 cannot be labelled")
        if a.shape[1:] != tail:
            raise ValueError(f"{name}[{i}]: expected per-frame shape {tail}, got {a.shape[1:]}")
    lengths = np.array([a.shape[0] for a in arrays], np.int32)
    out = np.full((len(arrays), int(lengths.max()), *tail), pad_value, dtype=dtype)
    for i, a in enumerate(arrays):
        out[i, : a.shape[0]] = a
    return out, lengths
