"""Hidden CRF (OAC eqs. 5-6): one label y per pre-segmented sequence, a chain of hidden states h_t.

    P(y | x) = (1 / Z(x)) sum_h prod_t Phi(y, h_t, x) prod_{t>=1} Phi(y, h_{t-1}, h_t, x)

with H hidden states per class (disjoint per class), node log potentials
log Phi(y, h_t, x) = sum_c <x_{t+c-C}, weights[c, :, y, h]> + bias[y, h] and class-specific
transitions trans[y] (H, H). Exact inference: for each class the sum over h is a linear-chain
log-partition (`inference.log_partition`), so log P(y | x) = s_y(x) - logsumexp_y' s_y'(x).
The objective is non-convex (hidden states), so parameters start from small random values.

Shapes: B batch, T time, D features, K classes, H hidden states per class, W = 2C + 1.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Int

from crf_jax._src.checks import check_batch
from crf_jax._src.layout import axis_size, check_fields, window_project, window_sizes
from crf_jax._src.inference import log_partition
from lfd_common import safe_logsumexp


@dataclasses.dataclass(frozen=True)
class HCRFStructure:
    """What defines a hidden CRF (OAC eqs. 5-6): what a saved model's file stores as JSON.

    Attributes:
        n_labels: K, classes, >= 1.
        n_hidden: H, hidden states per class, >= 1.
        n_features: D, features per frame, >= 1.
        connectivity: C >= 0: each hidden state sees x_{t-C..t+C}.

    Raises:
        ValueError: Naming the field, for a non-integer or a value below its minimum.
    """

    n_labels: int
    n_hidden: int
    n_features: int
    connectivity: int = 0

    def __post_init__(self):
        check_fields(self, n_labels=1, n_hidden=1, n_features=1, connectivity=0)


class HCRF(NamedTuple):
    """Hidden CRF parameters (a pytree; OAC eqs. 5-6): one label per sequence, a chain of hidden states.

    log Phi(y, h_t, x) = sum_c <x_{t+c-C}, weights[c, :, y, h]> + bias[y, h], with class-specific
    transitions trans[y]. Its sizes are read off the arrays.

    Attributes:
        weights: (W, D, K, H) node weights per window offset, class and hidden state.
        bias: (K, H) per class and hidden state.
        trans: (K, H, H) hidden-state transition log potentials per class.
    """

    weights: Float[Array, "W D K H"]
    bias: Float[Array, "K H"]
    trans: Float[Array, "K H H"]

    connectivity, n_features, n_labels = window_sizes("K: classes.")
    n_hidden = axis_size("weights", 3, "H: hidden states per class.")

    @property
    def structure(self) -> HCRFStructure:
        """The `HCRFStructure` that defines this model."""
        return HCRFStructure(self.n_labels, self.n_hidden, self.n_features, self.connectivity)


def init_hcrf(key: Array, n_features: int, n_labels: int, n_hidden: int, connectivity: int = 0,
              scale: float = 0.1, dtype: jnp.dtype = jnp.float32) -> HCRF:
    """Random starting parameters of a hidden CRF (no input checks).

    The objective is non-convex; N(0, scale^2) values break the symmetry between hidden states.

    Args:
        key: A `jax.random` key.
        n_features: D, features per frame.
        n_labels: K, classes.
        n_hidden: H, hidden states per class.
        connectivity: C: each hidden state sees x_{t-C..t+C}.
        scale: Standard deviation of every parameter.
        dtype: The arrays' dtype.

    Returns:
        `HCRF` with weights (2C + 1, D, K, H), bias (K, H), trans (K, H, H).
    """
    k1, k2, k3 = jax.random.split(key, 3)
    W = 2 * connectivity + 1
    return HCRF(
        scale * jax.random.normal(k1, (W, n_features, n_labels, n_hidden), dtype),
        scale * jax.random.normal(k2, (n_labels, n_hidden), dtype),
        scale * jax.random.normal(k3, (n_labels, n_hidden, n_hidden), dtype),
    )


def class_scores(model: HCRF, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Float[Array, "B K"]:
    """s_y(x) = log sum_h exp(score(y, h, x)) for every class: (B, K)."""
    unary = window_project(X, model.weights, lengths) + model.bias  # (B, T, K, H)
    per_class = jnp.moveaxis(unary, 2, 0)  # (K, B, T, H)
    return jax.vmap(log_partition, (0, 0, None))(per_class, model.trans, lengths).T


@jax.jit
def log_probs_jit(model: HCRF, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Float[Array, "B K"]:
    """log P(y | x) (B, K)."""
    s = class_scores(model, X, lengths)
    # shift by the max first: s - logsumexp(s) would round at the magnitude of s (large potentials)
    s = s - jax.lax.stop_gradient(jnp.max(s, axis=-1, keepdims=True))
    return s - safe_logsumexp(s, axis=-1)[:, None]


@jax.jit
def nll(model: HCRF, X: Float[Array, "B T D"], y: Int[Array, " B"], lengths: Int[Array, " B"]) -> Float[Array, " B"]:
    """-log P(y_b | x_b) per sequence (B,) for class labels y (B,)."""
    lp = log_probs_jit(model, X, lengths)
    return -jnp.take_along_axis(lp, y[:, None], axis=1)[:, 0]


def log_probs(model: HCRF, X: Float[ArrayLike, "B T D"], lengths: Int[ArrayLike, " B"] | None = None
              ) -> Float[Array, "B K"]:
    """Class log-probabilities log P(y | x) of every pre-segmented sequence (OAC eq. 5).

    Exact: for each class the sum over hidden paths is a linear-chain log-partition.

    Args:
        model: The fitted `HCRF`.
        X: (B, T, D) padded features, one pre-segmented sequence per row.
        lengths: (B,) frames per sequence in [1, T], or None (all T).

    Returns:
        (B, K) log P(y | x).

    Raises:
        ValueError: Naming the argument: `X` not (B, T, D) with the model's D, NaN/inf on real
            frames, an empty batch; `lengths` outside [1, T].
    """
    Xc, lens = check_batch(X, lengths, n_features=model.n_features)
    return log_probs_jit(model, jnp.asarray(Xc), jnp.asarray(lens))


def predict(model: HCRF, X: Float[ArrayLike, "B T D"], lengths: Int[ArrayLike, " B"] | None = None
            ) -> Int[Array, " B"]:
    """The most probable class of every pre-segmented sequence (OAC eq. 5).

    Args:
        model: The fitted `HCRF`.
        X: (B, T, D) padded features, one pre-segmented sequence per row.
        lengths: (B,) frames per sequence in [1, T], or None (all T).

    Returns:
        (B,) class indices.

    Raises:
        ValueError: Naming the argument: `X` not (B, T, D) with the model's D, NaN/inf on real
            frames, an empty batch; `lengths` outside [1, T].
    """
    return jnp.argmax(log_probs(model, X, lengths), axis=-1)
