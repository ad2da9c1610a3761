"""A learned grasp classifier beside eq. 3's kNN vote (issue 20): a two-layer perceptron on the HOG
features, trained with optax on the database only. Orientation stays eq. 4 (`recogniser.recognise`),
from database views of the predicted class.

Shapes: N examples, D HOG features, M = 6 classes.
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

class NetClassifier(NamedTuple):
    """params: the perceptron's weights pytree; mean, std: the HOG standardisation (D,)."""

    params: dict
    mean: np.ndarray
    std: np.ndarray


def _init(key, n_in: int, n_classes: int, hidden: int) -> dict:
    k1, k2 = jax.random.split(key)
    return {"w1": jax.random.normal(k1, (n_in, hidden)) * np.sqrt(2.0 / n_in), "b1": jnp.zeros(hidden),
            "w2": jax.random.normal(k2, (hidden, n_classes)) * np.sqrt(1.0 / hidden), "b2": jnp.zeros(n_classes)}


def _logits(params: dict, x):
    return jax.nn.relu(x @ params["w1"] + params["b1"]) @ params["w2"] + params["b2"]


@partial(jax.jit, static_argnames=("optimizer",))
def _epoch(optimizer, params, opt_state, batches_x, batches_y):
    """One pass over (n_batches, batch, ...) minibatches by `lax.scan`."""
    def step(carry, xy):
        p, s = carry
        loss, g = jax.value_and_grad(
            lambda p: optax.softmax_cross_entropy_with_integer_labels(_logits(p, xy[0]), xy[1]).mean())(p)
        updates, s = optimizer.update(g, s, p)
        return (optax.apply_updates(p, updates), s), loss

    (params, opt_state), losses = jax.lax.scan(step, (params, opt_state), (batches_x, batches_y))
    return params, opt_state, losses.mean()


def fit_classifier(x: np.ndarray, labels: np.ndarray, n_classes: int, seed: int = 0, hidden: int = 512,
                   epochs: int = 30, batch: int = 256, learning_rate: float = 1e-3, weight_decay: float = 1e-4,
                   progress=None) -> NetClassifier:
    """Train the perceptron on HOG features x (N, D) (standardised) by AdamW on the cross-entropy,
    shuffled minibatches, `epochs` passes. `progress(iterable, total)` wraps the epochs."""
    x = np.asarray(x, np.float32)
    mean, std = x.mean(0), x.std(0) + 1e-6
    x = (x - mean) / std
    params = _init(jax.random.key(seed), x.shape[1], n_classes, hidden)
    optimizer = optax.adamw(learning_rate, weight_decay=weight_decay)
    opt_state = optimizer.init(params)
    rng = np.random.default_rng(seed)
    n_batches = len(x) // batch
    loop = range(epochs) if progress is None else progress(range(epochs), epochs)
    for _ in loop:  # epochs: each one compiled scan over its minibatches
        order = rng.permutation(len(x))[: n_batches * batch].reshape(n_batches, batch)
        params, opt_state, _ = _epoch(optimizer, params, opt_state, jnp.asarray(x[order]),
                                      jnp.asarray(np.asarray(labels)[order]))
    return NetClassifier(params, mean, std)


@jax.jit
def _predict(params, x):
    return jnp.argmax(_logits(params, x), axis=1).astype(jnp.int32)


def classify(clf: NetClassifier, x: np.ndarray, chunk: int = 1024) -> np.ndarray:
    """(N,) class indices of HOG features x (N, D), `chunk` rows at a time (bounded memory)."""
    x = (np.asarray(x, np.float32) - clf.mean) / clf.std
    return np.concatenate([np.asarray(_predict(clf.params, jnp.asarray(x[i:i + chunk])))
                           for i in range(0, len(x), chunk)] or [np.zeros(0, np.int32)])
