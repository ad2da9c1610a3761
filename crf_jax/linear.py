"""Per-vector baselines: multinomial logistic regression and a linear SVM (Crammer-Singer multiclass hinge).

Both are `LinearModel(weights (D, K), bias (K,))`, scores s = x @ weights + bias; fit with optax
through `crf_jax.fit_linear`. Objectives (sums over the N examples, plus l2 ||weights||^2):
logistic: -log softmax(s)_y;  svm: max_k (s_k + [k != y]) - s_y.
Shapes: N examples, D features, K classes.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from lfd_common import as_array

Array = jax.Array


class LinearModel(NamedTuple):
    """weights (D, K), bias (K,)."""

    weights: Array
    bias: Array

    @property
    def n_features(self) -> int:
        return self.weights.shape[0]

    @property
    def n_labels(self) -> int:
        return self.weights.shape[1]


def init_linear(n_features: int, n_labels: int, dtype=jnp.float32) -> LinearModel:
    return LinearModel(jnp.zeros((n_features, n_labels), dtype), jnp.zeros((n_labels,), dtype))


def scores(model: LinearModel, X: Array) -> Array:
    """(N, K) decision scores."""
    return X @ model.weights + model.bias


def logistic_loss(model: LinearModel, X: Array, y: Array) -> Array:
    """(N,) -log P(y | x)."""
    s = scores(model, X)
    return jax.nn.logsumexp(s, axis=-1) - jnp.take_along_axis(s, y[:, None], axis=1)[:, 0]


def hinge_loss(model: LinearModel, X: Array, y: Array) -> Array:
    """(N,) Crammer-Singer multiclass hinge max_k (s_k + [k != y]) - s_y."""
    s = scores(model, X)
    margin = 1.0 - jax.nn.one_hot(y, s.shape[-1], dtype=s.dtype)
    return jnp.max(s + margin, axis=-1) - jnp.take_along_axis(s, y[:, None], axis=1)[:, 0]


def _check_X(model: LinearModel, X) -> Array:
    Xc = as_array(X, "X", ndim=2)
    if Xc.shape[1] != model.n_features:
        raise ValueError(f"X: expected {model.n_features} features (the model's D), got {Xc.shape[1]}")
    return jnp.asarray(Xc, jnp.float32)


@jax.jit
def _log_proba(model, X):
    return jax.nn.log_softmax(scores(model, X), axis=-1)


def predict(model: LinearModel, X) -> np.ndarray:
    """Validated: argmax class (N,) for X (N, D)."""
    return np.asarray(jnp.argmax(scores(model, _check_X(model, X)), axis=-1))


def predict_log_proba(model: LinearModel, X) -> Array:
    """Validated: log softmax of the scores (N, K) (calibrated for logistic regression only)."""
    return _log_proba(model, _check_X(model, X))
