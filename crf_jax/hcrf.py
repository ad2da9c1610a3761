"""Hidden CRF (OAC eqs. 5-6): one label y per pre-segmented sequence, a chain of hidden states h_t.

    P(y | x) = (1 / Z(x)) sum_h prod_t Phi(y, h_t, x) prod_{t>=1} Phi(y, h_{t-1}, h_t, x)

with H hidden states per class (disjoint per class), node log potentials
log Phi(y, h_t, x) = sum_c <x_{t+c-C}, weights[c, :, y, h]> + bias[y, h] and class-specific
transitions trans[y] (H, H). Exact inference: for each class the sum over h is a linear-chain
log-partition (`chain.log_partition`), so log P(y | x) = s_y(x) - logsumexp_y' s_y'(x).
The objective is non-convex (hidden states), so parameters start from small random values.

Shapes: B batch, T time, D features, K classes, H hidden states per class, W = 2C + 1.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from crf_jax.chain import log_partition, safe_logsumexp, window_project

Array = jax.Array


class HCRF(NamedTuple):
    """weights (W, D, K, H), bias (K, H), trans (K, H, H)."""

    weights: Array
    bias: Array
    trans: Array

    @property
    def connectivity(self) -> int:
        return (self.weights.shape[0] - 1) // 2

    @property
    def n_features(self) -> int:
        return self.weights.shape[1]

    @property
    def n_labels(self) -> int:
        return self.weights.shape[2]

    @property
    def n_hidden(self) -> int:
        return self.weights.shape[3]


def init_hcrf(key: Array, n_features: int, n_labels: int, n_hidden: int, connectivity: int = 0,
              scale: float = 0.1, dtype=jnp.float32) -> HCRF:
    """N(0, scale^2) parameters (random, to break the symmetry between hidden states)."""
    k1, k2, k3 = jax.random.split(key, 3)
    W = 2 * connectivity + 1
    return HCRF(
        scale * jax.random.normal(k1, (W, n_features, n_labels, n_hidden), dtype),
        scale * jax.random.normal(k2, (n_labels, n_hidden), dtype),
        scale * jax.random.normal(k3, (n_labels, n_hidden, n_hidden), dtype),
    )


def class_scores(model: HCRF, X: Array, lengths: Array) -> Array:
    """s_y(x) = log sum_h exp(score(y, h, x)) for every class: (B, K)."""
    unary = window_project(X, model.weights, lengths) + model.bias  # (B, T, K, H)
    per_class = jnp.moveaxis(unary, 2, 0)  # (K, B, T, H)
    return jax.vmap(log_partition, (0, 0, None))(per_class, model.trans, lengths).T


@jax.jit
def log_probs_jit(model: HCRF, X: Array, lengths: Array) -> Array:
    """log P(y | x) (B, K)."""
    s = class_scores(model, X, lengths)
    return s - safe_logsumexp(s, axis=-1)[:, None]


@jax.jit
def nll(model: HCRF, X: Array, y: Array, lengths: Array) -> Array:
    """-log P(y_b | x_b) per sequence (B,) for class labels y (B,)."""
    lp = log_probs_jit(model, X, lengths)
    return -jnp.take_along_axis(lp, y[:, None], axis=1)[:, 0]


def log_probs(model: HCRF, X, lengths=None) -> Array:
    """Validated: log P(y | x) (B, K) for X (B, T, D), lengths (B,) or None."""
    from crf_jax._checks import check_batch

    Xc, lens = check_batch(X, lengths, n_features=model.n_features)
    return log_probs_jit(model, jnp.asarray(Xc), jnp.asarray(lens))


def predict(model: HCRF, X, lengths=None) -> np.ndarray:
    """Validated: the most probable class per sequence (B,)."""
    return np.asarray(jnp.argmax(log_probs(model, X, lengths), axis=-1))
