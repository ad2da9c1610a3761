"""A learned grasp classifier beside eq. 3's kNN vote (issue 20): a two-layer perceptron on the HOG
features, or a small convolutional network on the masked crops, trained with optax on the database
only. Orientation stays eq. 4 (`recogniser.recognise`), from database views of the predicted class.

Shapes: N examples, D HOG features, S crop side, M = 6 classes.
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

_DN = ("NHWC", "HWIO", "NHWC")


class NetClassifier(NamedTuple):
    """kind: "mlp" (on standardised HOG) or "cnn" (on `crop_inputs`); params: the weights pytree;
    mean, std: the HOG standardisation (mlp; ones / zeros for cnn)."""

    kind: str
    params: dict
    mean: np.ndarray
    std: np.ndarray


def crop_inputs(images: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """(N, S, S, 2) network inputs of crops (N, S, S) and masks: the grey levels inside the mask
    standardised per image (so skin tone and lighting do not matter), and the mask itself."""
    m = masks.astype(np.float32)
    area = np.maximum(m.sum((1, 2)), 1.0)[:, None, None]
    mean = (images * m).sum((1, 2))[:, None, None] / area
    std = np.sqrt((((images - mean) * m) ** 2).sum((1, 2))[:, None, None] / area) + 1e-3
    return np.stack([m * (images - mean) / std, m], -1).astype(np.float32)


def _init(kind: str, key, n_in: int, n_classes: int, hidden: int) -> dict:
    he = lambda k, shape, fan_in: jax.random.normal(k, shape) * np.sqrt(2.0 / fan_in)
    k = jax.random.split(key, 5)
    if kind == "mlp":
        return {"w1": he(k[0], (n_in, hidden), n_in), "b1": jnp.zeros(hidden),
                "w2": he(k[1], (hidden, n_classes), hidden) / np.sqrt(2.0), "b2": jnp.zeros(n_classes)}
    return {"c1": he(k[0], (5, 5, 2, 16), 50), "c2": he(k[1], (3, 3, 16, 32), 144), "c3": he(k[2], (3, 3, 32, 64), 288),
            "w1": he(k[3], (n_in, hidden), n_in), "b1": jnp.zeros(hidden),
            "w2": he(k[4], (hidden, n_classes), hidden) / np.sqrt(2.0), "b2": jnp.zeros(n_classes)}


def _logits(kind: str, params: dict, x):
    if kind == "cnn":
        for c in ("c1", "c2", "c3"):  # three stride-2 convolutions: S -> S / 8
            x = jax.nn.relu(jax.lax.conv_general_dilated(x, params[c], (2, 2), "SAME", dimension_numbers=_DN))
        x = x.reshape(x.shape[0], -1)
    return jax.nn.relu(x @ params["w1"] + params["b1"]) @ params["w2"] + params["b2"]


@partial(jax.jit, static_argnames=("kind", "optimizer"))
def _epoch(kind, optimizer, params, opt_state, batches_x, batches_y):
    """One pass over (n_batches, batch, ...) minibatches by `lax.scan`."""
    def step(carry, xy):
        p, s = carry
        loss, g = jax.value_and_grad(
            lambda p: optax.softmax_cross_entropy_with_integer_labels(_logits(kind, p, xy[0]), xy[1]).mean())(p)
        updates, s = optimizer.update(g, s, p)
        return (optax.apply_updates(p, updates), s), loss

    (params, opt_state), losses = jax.lax.scan(step, (params, opt_state), (batches_x, batches_y))
    return params, opt_state, losses.mean()


def fit_classifier(kind: str, x: np.ndarray, labels: np.ndarray, n_classes: int, seed: int = 0, hidden: int = 512,
                   epochs: int = 30, batch: int = 256, learning_rate: float = 1e-3, weight_decay: float = 1e-4,
                   progress=None) -> NetClassifier:
    """Train a `kind` ("mlp": x = HOG (N, D); "cnn": x = `crop_inputs` (N, S, S, 2)) classifier by AdamW
    on the cross-entropy, shuffled minibatches, `epochs` passes. `progress(iterable, total)` wraps the
    epochs."""
    if kind not in ("mlp", "cnn"):
        raise ValueError(f"kind: expected 'mlp' or 'cnn', got {kind!r}")
    x = np.asarray(x, np.float32)
    if kind == "mlp":
        mean, std = x.mean(0), x.std(0) + 1e-6
        x = (x - mean) / std
        n_in = x.shape[1]
    else:
        mean, std = np.zeros(1, np.float32), np.ones(1, np.float32)
        n_in = (-(-x.shape[1] // 8)) ** 2 * 64
    key = jax.random.key(seed)
    params = _init(kind, key, n_in, n_classes, hidden)
    optimizer = optax.adamw(learning_rate, weight_decay=weight_decay)
    opt_state = optimizer.init(params)
    rng = np.random.default_rng(seed)
    n_batches = len(x) // batch
    loop = range(epochs) if progress is None else progress(range(epochs), epochs)
    for _ in loop:  # epochs: each one compiled scan over its minibatches
        order = rng.permutation(len(x))[: n_batches * batch].reshape(n_batches, batch)
        params, opt_state, _ = _epoch(kind, optimizer, params, opt_state, jnp.asarray(x[order]),
                                      jnp.asarray(np.asarray(labels)[order]))
    return NetClassifier(kind, params, mean, std)


@partial(jax.jit, static_argnames=("kind",))
def _predict(kind, params, x):
    return jnp.argmax(_logits(kind, params, x), axis=1).astype(jnp.int32)


def classify(clf: NetClassifier, x: np.ndarray, chunk: int = 1024) -> np.ndarray:
    """(N,) class indices of inputs x (HOG for "mlp", `crop_inputs` for "cnn"), `chunk` at a time."""
    x = np.asarray(x, np.float32)
    if clf.kind == "mlp":
        x = (x - clf.mean) / clf.std
    return np.concatenate([np.asarray(_predict(clf.kind, clf.params, jnp.asarray(x[i:i + chunk])))
                           for i in range(0, len(x), chunk)] or [np.zeros(0, np.int32)])
