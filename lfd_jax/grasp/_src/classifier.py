"""A learned grasp classifier beside GRASP's kNN vote (eq. 3, beyond the paper): a two-layer perceptron
on the HOG features (§IV), trained with optax on the database only. Orientation stays eq. 4
(`recognise`), from database views of the predicted class.

Shapes: N examples, D HOG features, M classes.
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from lfd_common import as_array, check_int, check_real


class NetClassifier(NamedTuple):
    """A trained perceptron on HOG features (`fit_classifier`).

    Attributes:
        params: the perceptron's weights pytree ("w1", "b1", "w2", "b2").
        mean: (D,) the HOG standardisation's mean.
        std: (D,) the HOG standardisation's standard deviation (plus 1e-6).
    """

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
    """Train the perceptron on standardised HOG features by AdamW on the cross-entropy.

    Shuffled minibatches, `epochs` passes, each pass one compiled `lax.scan` over its minibatches.

    Args:
        x: (N, D) HOG features (`hog_features`), finite, N >= 1.
        labels: (N,) classes in [0, n_classes).
        n_classes: M >= 2.
        seed: the initialisation's and the shuffling's seed.
        hidden: units of the hidden layer.
        epochs: passes over the data.
        batch: minibatch size (the last partial minibatch of each pass is dropped).
        learning_rate: AdamW's rate.
        weight_decay: AdamW's decoupled weight decay.
        progress: optional `progress(iterable, total)` that wraps the epochs (a progress bar).

    Returns:
        The trained `NetClassifier`.

    Raises:
        ValueError: `x` is not a non-empty finite (N, D) array, `labels` does not match it or lies
            outside [0, n_classes), or a setting is out of range (the message names the argument).
    """
    x = as_array(x, "x", ndim=2, dtype=np.float32)
    checked = as_array(labels, "labels", shape=(len(x),), dtype=np.int64)
    n_classes = check_int(n_classes, "n_classes", min_value=2)
    if checked.min() < 0 or checked.max() >= n_classes:
        raise ValueError(f"labels: expected values in [0, {n_classes}), got [{checked.min()}, {checked.max()}]")
    for name, value in (("hidden", hidden), ("epochs", epochs), ("batch", batch)):
        check_int(value, name, min_value=1)
    check_real(learning_rate, "learning_rate", min_value=0.0, exclusive_min=True)
    check_real(weight_decay, "weight_decay", min_value=0.0)
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
    """The perceptron's classes of HOG features, `chunk` rows at a time (bounded memory).

    Args:
        clf: a trained `NetClassifier` (`fit_classifier`).
        x: (N, D) HOG features with the training features' D; N may be 0.
        chunk: rows per call.

    Returns:
        (N,) int32 class indices.

    Raises:
        ValueError: `x` is not a finite (N, D) array with the classifier's D, or `chunk` is not a
            positive int (the message names the argument).
    """
    x = as_array(x, "x", shape=(None, len(clf.mean)), dtype=np.float32, nonempty=False)
    chunk = check_int(chunk, "chunk", min_value=1)
    x = (x - clf.mean) / clf.std
    return np.concatenate([np.asarray(_predict(clf.params, jnp.asarray(x[i:i + chunk])))
                           for i in range(0, len(x), chunk)] or [np.zeros(0, np.int32)])
