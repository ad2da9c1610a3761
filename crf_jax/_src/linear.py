"""Per-vector baselines: multinomial logistic regression and a linear SVM (Crammer-Singer multiclass hinge).

Both are `LinearModel(weights (D, K), bias (K,))`, scores s = x @ weights + bias; fit with optax
through `crf_jax.fit_linear`. Objectives (sums over the N examples, plus l2 ||weights||^2):
logistic: -log softmax(s)_y;  svm: max_k (s_k + [k != y]) - s_y.
Shapes: N examples, D features, K classes.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Int

from crf_jax._src.checks import check_vectors
from crf_jax._src.layout import axis_size, check_fields


@dataclasses.dataclass(frozen=True)
class LinearStructure:
    """What defines a per-vector linear classifier: what a saved model's file stores as JSON.

    Attributes:
        n_labels: K, classes, >= 1.
        n_features: D, features, >= 1.

    Raises:
        ValueError: Naming the field, for a non-integer or a value below 1.
    """

    n_labels: int
    n_features: int

    def __post_init__(self):
        check_fields(self, n_labels=1, n_features=1)


class LinearModel(NamedTuple):
    """Per-vector baseline parameters (a pytree): scores s = x @ weights + bias.

    Multinomial logistic regression or a linear SVM (Crammer-Singer multiclass hinge): the
    per-vector baselines (OAC §5 categorises objects by an SVM on HOG feature vectors). Fit with
    `fit_linear`.

    Attributes:
        weights: (D, K) weights.
        bias: (K,) per-class bias.
    """

    weights: Float[Array, "D K"]
    bias: Float[Array, " K"]

    n_features = axis_size("weights", 0, "D: features.")
    n_labels = axis_size("weights", 1, "K: classes.")

    @property
    def structure(self) -> LinearStructure:
        """The `LinearStructure` that defines this model."""
        return LinearStructure(self.n_labels, self.n_features)


def init_linear(n_features: int, n_labels: int, dtype: jnp.dtype = jnp.float32) -> LinearModel:
    """All-zero starting parameters of a linear classifier (both objectives are convex).

    Args:
        n_features: D, features.
        n_labels: K, classes.
        dtype: The arrays' dtype.

    Returns:
        `LinearModel` with zero weights (D, K) and bias (K,).
    """
    return LinearModel(jnp.zeros((n_features, n_labels), dtype), jnp.zeros((n_labels,), dtype))


def scores(model: LinearModel, X: Float[Array, "N D"]) -> Float[Array, "N K"]:
    """(N, K) decision scores."""
    return X @ model.weights + model.bias


def logistic_loss(model: LinearModel, X: Float[Array, "N D"], y: Int[Array, " N"]) -> Float[Array, " N"]:
    """(N,) -log P(y | x)."""
    s = scores(model, X)
    return jax.nn.logsumexp(s, axis=-1) - jnp.take_along_axis(s, y[:, None], axis=1)[:, 0]


def hinge_loss(model: LinearModel, X: Float[Array, "N D"], y: Int[Array, " N"]) -> Float[Array, " N"]:
    """(N,) Crammer-Singer multiclass hinge max_k (s_k + [k != y]) - s_y."""
    s = scores(model, X)
    margin = 1.0 - jax.nn.one_hot(y, s.shape[-1], dtype=s.dtype)
    return jnp.max(s + margin, axis=-1) - jnp.take_along_axis(s, y[:, None], axis=1)[:, 0]


def _check_X(model: LinearModel, X) -> Array:
    return jnp.asarray(check_vectors(X, n_features=model.n_features))


@jax.jit
def _log_proba(model, X):
    return jax.nn.log_softmax(scores(model, X), axis=-1)


@jax.jit
def _predict(model, X):
    return jnp.argmax(scores(model, X), axis=-1)


def predict(model: LinearModel, X: Float[ArrayLike, "N D"]) -> Int[Array, " N"]:
    """The highest-scoring class of every feature vector.

    Args:
        model: The fitted `LinearModel`.
        X: (N, D) feature vectors.

    Returns:
        (N,) class indices.

    Raises:
        ValueError: Naming `X`: not (N, D) with the model's D, NaN/inf, empty.
    """
    return _predict(model, _check_X(model, X))


def predict_log_proba(model: LinearModel, X: Float[ArrayLike, "N D"]) -> Float[Array, "N K"]:
    """Class log-probabilities: the log softmax of the scores.

    Calibrated for logistic regression only; for an SVM they are monotone in the scores.

    Args:
        model: The fitted `LinearModel`.
        X: (N, D) feature vectors.

    Returns:
        (N, K) log-probabilities.

    Raises:
        ValueError: Naming `X`: not (N, D) with the model's D, NaN/inf, empty.
    """
    return _log_proba(model, _check_X(model, X))
