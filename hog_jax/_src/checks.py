"""Boundary checks shared by the hog_jax modules (numpy, outside jit): random keys and the range of
feature values for which squared Euclidean distances stay finite in float32."""
from __future__ import annotations

import math

import jax
import numpy as np

__all__ = ["check_feature_range", "check_key", "feature_limit"]


def check_key(key, name: str = "key"):
    """A single `jax.random` key: a typed key (`jax.random.key(seed)`, shape ()) or a raw uint32 (2,)
    key (`jax.random.PRNGKey(seed)`); anything else (an int seed, a batch of keys) is a ValueError."""
    if isinstance(key, jax.Array) and jax.dtypes.issubdtype(key.dtype, jax.dtypes.prng_key):
        if key.shape != ():
            raise ValueError(f"{name}: expected a single jax.random key, got a batch of shape {key.shape}")
        return key
    if isinstance(key, (jax.Array, np.ndarray)) and key.dtype == np.uint32 and key.shape == (2,):
        return key
    raise ValueError(f"{name}: expected a jax.random key (jax.random.key(seed)), got {type(key).__name__}"
                     + (f" of dtype {key.dtype} and shape {key.shape}" if hasattr(key, "shape") else f" {key!r}"))


def feature_limit(dim: int) -> float:
    """The largest |x| accepted for D-dimensional features: 2^60 / sqrt(D).

    Then every squared distance (at most 4 D max|x|^2 = 2^122, also in the expanded form
    |q|^2 - 2 q.x + |x|^2) and every GRASP eq. 3 weight exponent stays finite in float32 (max 3.4e38
    ~ 2^128).

    Args:
        dim: the feature dimension D.

    Returns:
        The limit, as a float.
    """
    return 2.0**60 / math.sqrt(max(int(dim), 1))


def check_feature_range(x: np.ndarray, name: str) -> np.ndarray:
    """ValueError naming `name` when a value of the (..., D) array `x` exceeds `feature_limit(D)`."""
    if x.size:
        peak = float(max(np.max(x), -np.min(x)))
        limit = feature_limit(x.shape[-1])
        if peak > limit:
            raise ValueError(f"{name}: values up to {peak:.3g} exceed the supported range |x| <= {limit:.3g} "
                             f"(2^60 / sqrt(D), D = {x.shape[-1]}): squared distances would overflow float32; "
                             "scale the features")
    return x
