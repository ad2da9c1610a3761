"""A small convolutional network on the hand crops (beyond GRASP): the grasp class from the pixels
instead of from the HOG kNN vote (§V, eq. 3), with augmentation for what skin segmentation (§III-A)
does to a query crop (shifts, brightness, holes in the mask). Orientation stays eq. 4 (`recognise`),
from database views of the predicted class. Two inputs:

* the hand only (`context=None`): the grey crop times its mask, and the mask; trained on the database
  (grid and domain-randomised views, whose background and object are black);
* the hand in its context: the unmasked box around the hand (`hog_jax.Segmentation.context`: the held
  object, the background), and the mask; trained on rendered scenes segmented like the queries. Holes
  are then cut from the mask channel only: skin segmentation misses hand pixels, the camera still
  sees them.

Layers: 3x3 convolutions, ReLU, stride 2 four times (S -> S / 16) with one stride-1 layer after the
first, `width`, 2, 4, 8 x `width` channels, dropout 0.3 on the flattened map, a 256-unit dense layer,
M logits.

Shapes: N crops, S x S pixels (S a multiple of 16), M classes.
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from lfd_common import Cache, as_array, check_int

_HIDDEN = 256
_DROPOUT_KEEP = 0.7
_SHIFT = 0.1  # of the crop's side
_VERSION = 1


class ConvClassifier(NamedTuple):
    """A trained convnet on hand crops (`fit_convnet`).

    Attributes:
        params: flat name -> array dict of the network's weights.
        context: whether its first channel is the unmasked box around the hand (else the hand's
            pixels only).
    """

    params: dict
    context: bool = False


def _conv_init(key, cin: int, cout: int) -> tuple[jax.Array, jax.Array]:
    return jax.random.normal(key, (3, 3, cin, cout)) * np.sqrt(2.0 / (9 * cin)), jnp.zeros(cout)


def _init(key, size: int, n_classes: int, width: int) -> dict:
    ks = jax.random.split(key, 7)
    chans = (2, width, 2 * width, 4 * width, 8 * width)
    p = {}
    for i, name in enumerate(("c0", "c1", "c2", "c3")):
        p[f"{name}_w"], p[f"{name}_b"] = _conv_init(ks[i], chans[i], chans[i + 1])
    p["c0b_w"], p["c0b_b"] = _conv_init(ks[4], width, width)
    n_flat = (size // 16) ** 2 * 8 * width
    p["d1_w"], p["d1_b"] = jax.random.normal(ks[5], (n_flat, _HIDDEN)) * np.sqrt(2.0 / n_flat), jnp.zeros(_HIDDEN)
    p["d2_w"], p["d2_b"] = jax.random.normal(ks[6], (_HIDDEN, n_classes)) * np.sqrt(1.0 / _HIDDEN), jnp.zeros(n_classes)
    return p


def _conv(x, p: dict, name: str, stride: int):
    y = jax.lax.conv_general_dilated(x, p[f"{name}_w"], (stride, stride), "SAME",
                                     dimension_numbers=("NHWC", "HWIO", "NHWC"))
    return jax.nn.relu(y + p[f"{name}_b"])


def logits(params: dict, x: jax.Array, dropout_key=None) -> jax.Array:
    """(N, M) class logits of inputs x (N, S, S, 2); dropout on the flattened map when a key is given."""
    h = _conv(x, params, "c0", 2)
    h = _conv(h, params, "c0b", 1)
    for name in ("c1", "c2", "c3"):
        h = _conv(h, params, name, 2)
    h = h.reshape(h.shape[0], -1)
    if dropout_key is not None:
        h = h * jax.random.bernoulli(dropout_key, _DROPOUT_KEEP, h.shape) / _DROPOUT_KEEP
    return jax.nn.relu(h @ params["d1_w"] + params["d1_b"]) @ params["d2_w"] + params["d2_b"]


def augment(key, x: jax.Array, context: bool = False) -> jax.Array:
    """Network inputs as a query crop might look after skin segmentation (GRASP §III-A).

    Each input is shifted by up to S / 10 pixels, its grey channel scaled by U(0.6, 1.3), and up to
    three rectangular holes with sides of S / 16 to S / 4 (each with probability 0.5) are cut from the
    mask, as skin segmentation leaves holes in a hand, and from the grey channel too unless it is the
    unmasked context.

    Args:
        key: a JAX random key.
        x: (N, S, S, 2) network inputs (`network_input`).
        context: whether the first channel is the unmasked box around the hand.

    Returns:
        (N, S, S, 2) the augmented inputs.
    """
    n, size = x.shape[0], x.shape[1]
    shift = int(round(_SHIFT * size))
    k_shift, k_gain, k_centre, k_side, k_use = jax.random.split(key, 5)
    padded = jnp.pad(x, ((0, 0), (shift, shift), (shift, shift), (0, 0)))
    offsets = jax.random.randint(k_shift, (n, 2), 0, 2 * shift + 1)
    x = jax.vmap(lambda im, o: jax.lax.dynamic_slice(im, (o[0], o[1], 0), (size, size, 2)))(padded, offsets)
    gain = jax.random.uniform(k_gain, (n, 1, 1, 1), minval=0.6, maxval=1.3)
    rows, cols = jnp.mgrid[:size, :size]
    centre = jax.random.randint(k_centre, (n, 3, 2), 0, size)[..., None, None]
    half = jax.random.randint(k_side, (n, 3, 2), size // 16, size // 4 + 1)[..., None, None] // 2
    used = jax.random.bernoulli(k_use, 0.5, (n, 3))[..., None, None]
    hole = ((jnp.abs(rows - centre[:, :, 0]) < half[:, :, 0]) & (jnp.abs(cols - centre[:, :, 1]) < half[:, :, 1])
            & used).any(1)
    grey = x[..., :1] * gain
    keep = (~hole)[..., None]
    return jnp.concatenate([grey if context else grey * keep, x[..., 1:] * keep], -1)


def network_input(images, masks, context=None) -> np.ndarray:
    """The network's two-channel input: the masked crops (or the unmasked boxes) and the masks.

    Args:
        images: (N, S, S) grey crops times their masks, N >= 1, S a positive multiple of 16.
        masks: (N, S, S) bool hand masks.
        context: optional (N, S, S) unmasked boxes around the hand, used instead of `images`.

    Returns:
        (N, S, S, 2) float32: the crops times their masks (or `context`), and the masks.

    Raises:
        ValueError: a wrong shape, empty or non-finite pixels, or S not a multiple of 16 (the message
            names the argument).
    """
    images = as_array(images, "images", ndim=3, dtype=np.float32)
    if images.shape[1] != images.shape[2] or images.shape[1] % 16 or images.shape[1] == 0:
        raise ValueError(f"images: expected square crops (N, S, S) with S a multiple of 16, got {images.shape}")
    masks = np.asarray(masks)
    if masks.shape != images.shape:
        raise ValueError(f"masks: expected the images' shape {images.shape}, got {masks.shape}")
    m = masks.astype(np.float32)
    if context is None:
        return np.stack([images * m, m], -1)
    return np.stack([as_array(context, "context", shape=images.shape, dtype=np.float32), m], -1)


@partial(jax.jit, static_argnames=("optimizer", "context"), donate_argnums=(1, 2))
def _step(optimizer, params, opt_state, key, data, labels, idx, context: bool):
    """One AdamW step on the augmented minibatch `idx` (batch,) of the device-resident data. One call
    per step, not a `lax.scan` over the epoch: XLA:CPU ran these convolutions 23x slower inside the
    scan's loop."""
    k_aug, k_drop = jax.random.split(key)
    xb = augment(k_aug, data[idx], context)
    loss, g = jax.value_and_grad(lambda p: optax.softmax_cross_entropy_with_integer_labels(
        logits(p, xb, k_drop), labels[idx]).mean())(params)
    updates, opt_state = optimizer.update(g, opt_state, params)
    return optax.apply_updates(params, updates), opt_state, loss


def fit_convnet(images, masks, labels, n_classes: int, seed: int = 0, width: int = 16, epochs: int = 10,
                batch: int = 128, learning_rate: float = 2e-3, weight_decay: float = 5e-4,
                progress=None, context=None) -> ConvClassifier:
    """Train the network on hand crops.

    AdamW with a cosine-decayed rate on the cross-entropy of augmented (`augment`) shuffled minibatches,
    `epochs` passes. With `context`, the network sees the unmasked boxes instead of the masked crops
    (the module docstring).

    Args:
        images: (N, S, S) grey crops times their masks, S a multiple of 16.
        masks: (N, S, S) bool hand masks.
        labels: (N,) classes in [0, n_classes).
        n_classes: M >= 2.
        seed: the initialisation's, shuffling's and augmentation's seed.
        width: channels of the first layer.
        epochs: passes over the data.
        batch: minibatch size (at most N).
        learning_rate: the initial rate of the cosine schedule.
        weight_decay: AdamW's decoupled weight decay.
        progress: optional `progress(iterable, total)` that wraps the epochs (a progress bar).
        context: optional (N, S, S) unmasked boxes around the hand.

    Returns:
        The trained `ConvClassifier` (its `context` says which input it was trained on).

    Raises:
        ValueError: inputs of the wrong shape or non-finite, labels outside [0, n_classes), or a
            setting out of range (the message names the argument).
    """
    x = network_input(images, masks, context)
    labels = as_array(labels, "labels", shape=(len(x),), dtype=np.int32)
    n_classes = check_int(n_classes, "n_classes", min_value=2)
    if labels.min(initial=0) < 0 or labels.max(initial=0) >= n_classes:
        raise ValueError(f"labels: expected values in [0, {n_classes}), got [{labels.min()}, {labels.max()}]")
    width, epochs = check_int(width, "width", min_value=1), check_int(epochs, "epochs", min_value=1)
    batch = min(check_int(batch, "batch", min_value=1), len(x))
    n_batches = len(x) // batch
    optimizer = optax.adamw(optax.cosine_decay_schedule(learning_rate, epochs * n_batches), weight_decay=weight_decay)
    params = _init(jax.random.key(seed), x.shape[1], n_classes, width)
    opt_state = optimizer.init(params)
    data, y = jnp.asarray(x), jnp.asarray(labels)
    rng, key = np.random.default_rng(seed), jax.random.key(seed + 1)
    loop = range(epochs) if progress is None else progress(range(epochs), epochs)
    for epoch in loop:
        order = jnp.asarray(rng.permutation(len(x))[: n_batches * batch].reshape(n_batches, batch))
        for b in range(n_batches):  # optimisation steps (see `_step`)
            params, opt_state, loss = _step(optimizer, params, opt_state, jax.random.fold_in(key, epoch * n_batches + b),
                                            data, y, order[b], context is not None)
        loss.block_until_ready()  # the progress bar shows epochs done, not epochs dispatched
    return ConvClassifier(jax.device_get(params), context is not None)


@jax.jit
def _predict(params, x):
    return jnp.argmax(logits(params, x), axis=1).astype(jnp.int32)


def classify_crops(clf: ConvClassifier, images, masks, chunk: int = 256, context=None) -> np.ndarray:
    """The network's classes of hand crops, `chunk` crops at a time (bounded memory).

    Args:
        clf: a trained `ConvClassifier` (`fit_convnet`).
        images: (N, S, S) grey crops times their masks, N >= 1.
        masks: (N, S, S) bool hand masks.
        chunk: crops per call.
        context: (N, S, S) unmasked boxes around the hand; required by a network trained on them.

    Returns:
        (N,) int32 class indices.

    Raises:
        ValueError: `context` missing for a network trained on it, or inputs as `network_input`
            rejects them (the message names the argument).
    """
    if clf.context and context is None:
        raise ValueError("context: this network was trained on the unmasked boxes around the hand; pass them")
    x = network_input(images, masks, context if clf.context else None)
    return np.concatenate([np.asarray(_predict(clf.params, jnp.asarray(x[i:i + chunk])))
                           for i in range(0, len(x), chunk)])


# What a network trained by `fit_convnet` depends on besides its settings: this package, the validation in
# `lfd_common`, and `sim`'s grasp classes (their number is the network's output size).
_PACKAGES = ("lfd_jax.grasp", "sim", "lfd_common")
_NETS = Cache("grasp_cnn", packages=_PACKAGES, version=_VERSION)


def cached_convnet(settings: dict, train, context: bool = False,
                   packages: tuple[str, ...] = ()) -> ConvClassifier:
    """The network `train()` returns, stored on disk and reused while what it depends on is unchanged.

    Stored under `cache_dir("grasp_cnn")`, keyed by `settings`, `context` and the source of this
    package, `sim` and `lfd_common`, plus `packages`.

    Args:
        settings: what determines the training data and the training (str-keyed; values a
            `lfd_common.Cache` key can hold, arrays by content).
        train: a function of no arguments that returns the trained `ConvClassifier`.
        context: whether the network is trained on the unmasked boxes (part of the key).
        packages: dotted names of further packages whose code `train` runs (the renderer and data
            generators of its training data, say); their source is part of the key.

    Returns:
        The stored network, or `train()`'s, stored.

    Raises:
        ValueError: a setting a cache key cannot hold, or an unknown package (the message names it).
    """
    if packages:
        cache = Cache("grasp_cnn", packages=_PACKAGES + tuple(packages), version=_VERSION)
        return cache.get(train, settings=settings, context=context)
    return _NETS.get(train, settings=settings, context=context)
