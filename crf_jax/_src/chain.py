"""Linear-chain CRF (OAC eqs. 3-4, LfD eqs. 7-8): the model on padded batches.

Model (connectivity C, window W = 2C + 1): the label y_t sees x_{t-C..t+C} (zeros outside the
sequence), log psi_t(k) = sum_c <x_{t+c-C}, weights[c, :, k]> + bias[k] and
log P(y | x) = sum_t log psi_t(y_t) + sum_{t>=1} trans[y_{t-1}, y_t] - log Z(x).
This is eq. 3 with feature functions that factor into node and edge terms, as in CRFsuite.

Two layers: `unary_potentials`, `nll` and the `*_jit` functions take jax arrays X (B, T, D),
lengths (B,) and do no validation; `predict`, `predict_marginals`, `segment_log_probs` and
`log_likelihood` (re-exported by `crf_jax`) validate user input (`ValueError` naming the argument)
and return jax arrays. Inference on the potentials is in `inference`.
"""
from __future__ import annotations

import dataclasses
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from crf_jax._src.checks import check_batch, check_labels
from crf_jax._src.layout import check_fields, window_project, window_sizes
from crf_jax._src.inference import constant_path_log_prob, log_partition, marginals, sequence_score, viterbi


@dataclasses.dataclass(frozen=True)
class ChainStructure:
    """What defines a linear-chain CRF (OAC eqs. 3-4): what a saved model's file stores as JSON.

    Attributes:
        n_labels: K, labels, >= 1.
        n_features: D, features per frame, >= 1.
        connectivity: C >= 0: each label sees x_{t-C..t+C} (W = 2C + 1 window offsets).

    Raises:
        ValueError: Naming the field, for a non-integer or a value below its minimum.
    """

    n_labels: int
    n_features: int
    connectivity: int = 0

    def __post_init__(self):
        check_fields(self, n_labels=1, n_features=1, connectivity=0)


class ChainCRF(NamedTuple):
    """Linear-chain CRF parameters (a pytree; OAC eqs. 3-4, LfD eqs. 7-8).

    log P(y | x) = sum_t log psi_t(y_t) + sum_{t>=1} trans[y_{t-1}, y_t] - log Z(x), with
    log psi_t(k) = sum_c <x_{t+c-C}, weights[c, :, k]> + bias[k]. Its sizes (connectivity,
    n_features, n_labels) are read off the arrays.

    Attributes:
        weights: (W, D, K) node weights for window offset c - C, W = 2C + 1 (C = connectivity).
        bias: (K,) per-label bias.
        trans: (K, K) transition log potentials, trans[i, j] for y_{t-1} = i -> y_t = j.
    """

    weights: Float[Array, "W D K"]
    bias: Float[Array, " K"]
    trans: Float[Array, "K K"]

    connectivity, n_features, n_labels = window_sizes("K: labels.")

    @property
    def structure(self) -> ChainStructure:
        """The `ChainStructure` that defines this model."""
        return ChainStructure(self.n_labels, self.n_features, self.connectivity)


def init_chain(n_features: int, n_labels: int, connectivity: int = 0, key: Array | None = None,
               scale: float = 0.0, dtype: jnp.dtype = jnp.float32) -> ChainCRF:
    """Starting parameters of a linear-chain CRF (no input checks).

    All zero by default: the convex CRF objective needs no random start.

    Args:
        n_features: D, features per frame.
        n_labels: K, labels.
        connectivity: C: each label sees x_{t-C..t+C}.
        key: A `jax.random` key for random node weights, or None for zeros.
        scale: Standard deviation of the random node weights (0: zeros).
        dtype: The arrays' dtype.

    Returns:
        `ChainCRF`: weights (2C + 1, D, K) zero or N(0, scale^2), bias (K,) and trans (K, K) zero.
    """
    W = 2 * connectivity + 1
    shape = (W, n_features, n_labels)
    if key is None or scale == 0.0:
        weights = jnp.zeros(shape, dtype)
    else:
        weights = scale * jax.random.normal(key, shape, dtype)
    return ChainCRF(weights, jnp.zeros((n_labels,), dtype), jnp.zeros((n_labels, n_labels), dtype))


def unary_potentials(model: ChainCRF, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Float[Array, "B T K"]:
    """Node log potentials (B, T, K) for a padded batch X (B, T, D)."""
    return window_project(X, model.weights, lengths) + model.bias


@partial(jax.jit, static_argnames=("method",))
def nll(model: ChainCRF, X: Float[Array, "B T D"], y: Int[Array, "B T"], lengths: Int[Array, " B"],
        method: str = "scan") -> Float[Array, " B"]:
    """Per-sequence negative log-likelihood (B,): log Z(x_b) - score(y_b)."""
    unary = unary_potentials(model, X, lengths)
    log_z = log_partition(unary, model.trans, lengths, method=method)
    score = jax.vmap(sequence_score, (0, None, 0, 0))(unary, model.trans, y, lengths)
    return log_z - score


@jax.jit
def predict_jit(model: ChainCRF, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Int[Array, "B T"]:
    """Viterbi labels (B, T), -1 on padding."""
    unary = unary_potentials(model, X, lengths)
    return jax.vmap(viterbi, (0, None, 0))(unary, model.trans, lengths).labels


@jax.jit
def marginals_jit(model: ChainCRF, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Float[Array, "B T K"]:
    """Node marginals (B, T, K), 0 on padding."""
    unary = unary_potentials(model, X, lengths)
    return marginals(unary, model.trans, lengths).node


@jax.jit
def segment_log_probs_jit(model: ChainCRF, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Float[Array, "B K"]:
    """log P(y_t = k for all t | x) (B, K)."""
    unary = unary_potentials(model, X, lengths)
    return constant_path_log_prob(unary, model.trans, lengths)


# ----------------------------------------------------------------------------------------------
# public, validated (numpy in, jax arrays out; ValueError naming the argument)
# ----------------------------------------------------------------------------------------------
def _prepare(model: ChainCRF, X, lengths):
    Xc, lens = check_batch(X, lengths, n_features=model.n_features)
    return jnp.asarray(Xc), jnp.asarray(lens)


def predict(model: ChainCRF, X: Float[ArrayLike, "B T D"], lengths: Int[ArrayLike, " B"] | None = None
            ) -> Int[Array, "B T"]:
    """The most probable label sequence of every sequence (Viterbi; OAC eq. 3).

    Args:
        model: The fitted `ChainCRF`.
        X: (B, T, D) padded features.
        lengths: (B,) frames per sequence in [1, T], or None (all T).

    Returns:
        (B, T) int32 labels, -1 on padding.

    Raises:
        ValueError: Naming the argument: `X` not (B, T, D) with the model's D, NaN/inf on real
            frames, an empty batch; `lengths` outside [1, T].
    """
    Xj, lj = _prepare(model, X, lengths)
    return predict_jit(model, Xj, lj)


def predict_marginals(model: ChainCRF, X: Float[ArrayLike, "B T D"], lengths: Int[ArrayLike, " B"] | None = None
                      ) -> Float[Array, "B T K"]:
    """Posterior node marginals P(y_t = k | x) by forward-backward (OAC eq. 3).

    Args:
        model: The fitted `ChainCRF`.
        X: (B, T, D) padded features.
        lengths: (B,) frames per sequence in [1, T], or None (all T).

    Returns:
        (B, T, K) marginals, each real row summing to 1, 0 on padding.

    Raises:
        ValueError: Naming the argument: `X` not (B, T, D) with the model's D, NaN/inf on real
            frames, an empty batch; `lengths` outside [1, T].
    """
    Xj, lj = _prepare(model, X, lengths)
    return marginals_jit(model, Xj, lj)


def segment_log_probs(model: ChainCRF, X: Float[ArrayLike, "B T D"], lengths: Int[ArrayLike, " B"] | None = None
                      ) -> Float[Array, "B K"]:
    """Pre-segmented classification (OAC §4): the log-probability that every frame has label k.

    Args:
        model: The fitted `ChainCRF`.
        X: (B, T, D) padded features.
        lengths: (B,) frames per sequence in [1, T], or None (all T).

    Returns:
        (B, K) log P(y_t = k for all t | x).

    Raises:
        ValueError: Naming the argument: `X` not (B, T, D) with the model's D, NaN/inf on real
            frames, an empty batch; `lengths` outside [1, T].
    """
    Xj, lj = _prepare(model, X, lengths)
    return segment_log_probs_jit(model, Xj, lj)


def log_likelihood(model: ChainCRF, X: Float[ArrayLike, "B T D"], y: Int[ArrayLike, "B T"],
                   lengths: Int[ArrayLike, " B"] | None = None) -> Float[Array, " B"]:
    """Conditional log-likelihood log P(y | x) of a labelling (OAC eq. 3).

    Args:
        model: The fitted `ChainCRF`.
        X: (B, T, D) padded features.
        y: (B, T) labels in [0, K) on the real frames.
        lengths: (B,) frames per sequence in [1, T], or None (all T).

    Returns:
        (B,) log P(y_b | x_b), at most 0 (float32 rounding of the two large terms score - log Z,
        for large potentials, is clipped).

    Raises:
        ValueError: Naming the argument: `X` and `lengths` as in `predict`; `y` of the wrong
            shape, non-integral, or outside [0, K).
    """
    Xj, lj = _prepare(model, X, lengths)
    yc = check_labels(y, np.asarray(lj), model.n_labels)
    return jnp.minimum(-nll(model, Xj, jnp.asarray(yc[:, : Xj.shape[1]]), lj), 0.0)
