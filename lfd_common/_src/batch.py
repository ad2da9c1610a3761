"""Variable-length batches: user sequences in, one padded array and lengths out (outside `jit`).

One dtype policy for every library: features come back in the compute dtype (`float_dtype()`:
float32, or float64 when `jax_enable_x64` is on), and values that are finite in the input but do not
fit that dtype are rejected, never turned into inf. Padding is zero and every padded frame is masked
downstream, so its value never matters (it may hold NaN on input: only frames t < length are checked).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from lfd_common._src.numerics import float_dtype
from lfd_common._src.validate import as_array


def frame_mask(lengths: np.ndarray, n_frames: int) -> np.ndarray:
    """The real frames of a padded batch.

    Args:
        lengths: (B,) frames per sequence.
        n_frames: T, the padded length.

    Returns:
        (B, T) bool numpy array, True on the real frames t < lengths[b].
    """
    return np.arange(n_frames)[None, :] < np.asarray(lengths)[:, None]


def _stack(sequences: Sequence, name: str) -> tuple[np.ndarray, np.ndarray]:
    seqs = [as_array(x, f"{name}[{b}]", finite=False, nonempty=False) for b, x in enumerate(sequences)]
    for b, s in enumerate(seqs):
        if s.ndim < 1 or s.shape[0] == 0:
            raise ValueError(f"{name}[{b}]: a sequence of length 0 (or a scalar) has no frames")
    frame_shapes = {s.shape[1:] for s in seqs}
    if len(frame_shapes) != 1:
        raise ValueError(f"{name}: sequences have different per-frame shapes {sorted(frame_shapes)}")
    lengths = np.array([len(s) for s in seqs], np.int32)
    padded = np.zeros((len(seqs), int(lengths.max()), *frame_shapes.pop()))
    for b, s in enumerate(seqs):
        padded[b, : len(s)] = s
    return padded, lengths


def pad_sequences(
    X: Any,
    lengths: Any = None,
    *,
    dim: int | None = None,
    frame_ndim: int = 1,
    name: str = "X",
    lengths_name: str = "lengths",
    dtype: Any = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Check user sequences and return them as one padded batch (outside jit).

    The one dtype policy of every library: values finite in the input but too large for `dtype`
    are rejected, never turned into inf. Padding is zero (it may hold NaN on input: only frames
    t < length are checked).

    Args:
        X: A padded (B, T, *F) array (with `lengths` for unequal lengths, default all T), one
            (T, *F) sequence, or a list of (T_b, *F) arrays (then `lengths` must be None). F has
            `frame_ndim` axes (1: a D-vector per frame).
        lengths: (B,) frames per sequence in [1, T], or None.
        dim: The expected size of the last axis (the model's D), if any.
        frame_ndim: The number of per-frame axes F.
        name: The argument name that errors about `X` start with.
        lengths_name: The argument name that errors about `lengths` start with.
        dtype: The output dtype; default `float_dtype()`.

    Returns:
        (X (B, T, *F) numpy in `dtype` with zero padding, lengths (B,) int32).

    Raises:
        ValueError: Naming the argument, for an empty batch, zero frames or features, a wrong
            last axis, lengths outside [1, T] (or given with a list), NaN/inf within the lengths,
            or values that overflow `dtype`.
    """
    dtype = np.dtype(float_dtype() if dtype is None else dtype)
    if isinstance(X, (list, tuple)) and len(X) and np.ndim(X[0]) == frame_ndim + 1:
        if lengths is not None:
            raise ValueError(f"{lengths_name}: give either a list of sequences or a padded array with lengths, not both")
        X, lengths = _stack(X, name)
    else:
        X = as_array(X, name, ndim=(frame_ndim + 1, frame_ndim + 2), finite=False, nonempty=False)
        if X.ndim == frame_ndim + 1:
            X = X[None]
    if X.shape[0] == 0:
        raise ValueError(f"{name}: the batch is empty")
    if min(X.shape[1:]) == 0:
        raise ValueError(f"{name}: must not be empty, got shape {X.shape}")
    if dim is not None and X.shape[-1] != dim:
        raise ValueError(f"{name}: expected feature dimension D={dim}, got {X.shape[-1]}")
    batch, n_frames = X.shape[:2]
    if lengths is None:
        lengths = np.full(batch, n_frames, np.int32)
    else:
        lengths = as_array(lengths, lengths_name, shape=(batch,), dtype=np.int32, min_value=1, max_value=n_frames)
    valid = frame_mask(lengths, n_frames).reshape(batch, n_frames, *([1] * frame_ndim))
    real = np.broadcast_to(valid, X.shape)
    if not np.all(np.isfinite(X[real])):
        bad = int(np.sum(~np.isfinite(X[real])))
        raise ValueError(f"{name}: contains {bad} NaN or infinite value(s) within the sequence lengths")
    out = np.where(valid, X, 0.0)
    limit = np.finfo(dtype).max if np.issubdtype(dtype, np.floating) else None
    if limit is not None and out.size and np.max(np.abs(out)) > limit:
        raise ValueError(f"{name}: values up to {np.max(np.abs(out)):.3g} overflow {dtype.name} (max {limit:.3g})")
    return out.astype(dtype), lengths
