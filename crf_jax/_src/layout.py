"""The parameter layout the crf_jax models share (private).

Node weights of the chain-structured models are (W, D, *M): one (D, *M) slice per window offset
c - C, W = 2C + 1 (connectivity C), so that the label at frame t sees x_{t-C..t+C} (zeros outside the
sequence). `window_project` evaluates sum_c <x_{t+c-C}, weights[c]> for a padded batch.

The models are NamedTuples of arrays; their sizes (D, K, H, C) are read off the array shapes by the
`axis_size` / `window_sizes` properties, and their frozen structure dataclasses validate
their fields with `check_fields`, so each model states only which axis holds which size.
"""
from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from lfd_common import check_int


def axis_size(field: str, axis: int, doc: str) -> property:
    """A read-only property: the size of `axis` of the model's array `field`."""
    return property(lambda self: getattr(self, field).shape[axis], doc=doc)


def window_sizes(labels_doc: str = "K: labels.") -> tuple[property, property, property]:
    """(connectivity, n_features, n_labels) properties of a model whose `weights` are (W, D, K, ...)."""
    connectivity = property(lambda self: (self.weights.shape[0] - 1) // 2,
                            doc="C: each label sees x_{t-C..t+C} (weights has W = 2C + 1 offsets).")
    return connectivity, axis_size("weights", 1, "D: features per frame."), axis_size("weights", 2, labels_doc)


def check_fields(structure, **min_values: int) -> None:
    """Validate (and normalise to int) the integer fields of a frozen structure dataclass.

    min_values: field name -> smallest allowed value; a bad value is a `ValueError` naming the field.
    """
    for name, low in min_values.items():
        object.__setattr__(structure, name, check_int(getattr(structure, name), name, min_value=low))


def window_project(X: Float[Array, "B T D"], weights: Float[Array, "W D *M"],
                   lengths: Int[Array, " B"]) -> Float[Array, "B T *M"]:
    """sum_c x_{t+c-C} @ weights[c] for a padded batch: X (B, T, D), weights (W, D, ...) -> (B, T, ...).

    One matmul over all offsets, then shifted sums; frames outside [0, length) contribute zero.
    Padded frames of X must be finite (the public API zeroes them).
    """
    B, T, D = X.shape
    W = weights.shape[0]
    C = (W - 1) // 2
    out_shape = weights.shape[2:]
    valid = jnp.arange(T)[None, :] < lengths[:, None]
    flat = weights.reshape(W, D, -1).transpose(1, 0, 2).reshape(D, -1)  # (D, W * M)
    proj = (X.reshape(B * T, D) @ flat).reshape(B, T, W, -1)
    # Mask the (W * M)-wide projection rather than X (D-wide): same values, far less memory
    # traffic. Finite padding then has no effect on values or gradients; the public API zeroes
    # padded frames of X at the boundary so NaN padding cannot reach here either.
    proj = jnp.where(valid[:, :, None, None], proj, 0.0)
    if C == 0:
        out = proj[:, :, 0]
    else:
        padded = jnp.pad(proj, ((0, 0), (C, C), (0, 0), (0, 0)))
        out = sum(padded[:, c : c + T, c] for c in range(W))
    return out.reshape(B, T, *out_shape)


