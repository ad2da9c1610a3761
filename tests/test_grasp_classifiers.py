"""The learned grasp classifiers beside eq. 3's kNN: the convnet on crops, the perceptron on HOG."""
import numpy as np
import pytest

from lfd_jax import grasp
from lfd_jax.grasp import classify, fit_classifier


def _bars(n: int, seed: int, size: int = 32):
    """Crops of one of three shapes at a random place: a horizontal bar, a vertical bar, a square."""
    rng = np.random.default_rng(seed)
    labels = np.arange(n) % 3
    masks = np.zeros((n, size, size), bool)
    for i, c in enumerate(labels):  # building the toy set, not a hot path
        r, q = rng.integers(4, size - 20, 2)
        h, w = [(4, 16), (16, 4), (10, 10)][c]
        masks[i, r:r + h, q:q + w] = True
    images = masks * rng.uniform(0.5, 1.0, (n, 1, 1)).astype(np.float32)
    return images.astype(np.float32), masks, labels


def test_convnet_learns_shapes_it_was_not_shown():
    images, masks, labels = _bars(96, 0)
    clf = grasp.fit_convnet(images, masks, labels, 3, width=4, epochs=25, batch=32)
    new_images, new_masks, new_labels = _bars(60, 1)
    assert np.mean(grasp.classify_crops(clf, new_images, new_masks) == new_labels) >= 0.9


def _hand_beside_a_bar(n: int, seed: int, size: int = 32):
    """The same square 'hand' mask in every crop; the class is only in the unmasked context: a
    horizontal bar, a vertical bar or nothing beside the hand."""
    rng = np.random.default_rng(seed)
    labels = np.arange(n) % 3
    masks = np.zeros((n, size, size), bool)
    masks[:, 12:20, 12:20] = True
    context = np.zeros(masks.shape, np.float32)
    for i, c in enumerate(labels):  # building the toy set, not a hot path
        if c == 0:
            context[i, rng.integers(2, 8), 4:28] = 0.8
        elif c == 1:
            context[i, 4:28, rng.integers(2, 8)] = 0.8
    context = np.where(masks, 0.6, context)
    return context * masks, masks, labels, context


def test_context_convnet_reads_what_is_around_the_hand():
    images, masks, labels, context = _hand_beside_a_bar(96, 5)
    clf = grasp.fit_convnet(images, masks, labels, 3, width=4, epochs=25, batch=32, context=context)
    assert clf.context
    new_images, new_masks, new_labels, new_context = _hand_beside_a_bar(60, 6)
    assert np.mean(grasp.classify_crops(clf, new_images, new_masks, context=new_context) == new_labels) >= 0.9
    with pytest.raises(ValueError, match="context"):
        grasp.classify_crops(clf, new_images, new_masks)  # trained on context: it needs it
    with pytest.raises(ValueError, match="context"):
        grasp.network_input(new_images, new_masks, new_context[:, :16])


def test_augment_keeps_the_context_where_it_cuts_holes_in_the_mask():
    import jax
    _, masks, _ = _bars(8, 2)
    x = grasp.network_input(masks.astype(np.float32), masks, context=np.ones(masks.shape, np.float32))
    out = np.asarray(grasp.augment(jax.random.key(0), x, context=True))
    assert np.all(np.isin(out[..., 1], (0.0, 1.0))) and out[..., 1].sum() < x[..., 1].sum()
    zero = out[..., 0] == 0.0  # only the strips the shift brought in from outside the crop
    assert np.all(~zero | zero.all(2, keepdims=True) | zero.all(1, keepdims=True))


def test_augment_shifts_and_cuts_holes_but_adds_nothing():
    import jax
    _, masks, _ = _bars(8, 2)
    x = grasp.network_input(masks.astype(np.float32), masks)
    out = np.asarray(grasp.augment(jax.random.key(0), x))
    assert out.shape == x.shape
    assert np.all(np.isin(out[..., 1], (0.0, 1.0)))  # the mask stays a mask
    assert np.all(out[..., 1].sum((1, 2)) <= x[..., 1].sum((1, 2)))  # holes and shifts only remove
    assert np.all(out[..., 0] <= 1.3 * out[..., 1] + 1e-6)  # grey only where the mask is, gain at most 1.3


def test_convnet_rejects_bad_input():
    images, masks, labels = _bars(6, 3)
    with pytest.raises(ValueError, match="images"):
        grasp.network_input(images[:, :30, :30], masks[:, :30, :30])
    with pytest.raises(ValueError, match="masks"):
        grasp.network_input(images, masks[:, :8])
    with pytest.raises(ValueError, match="images"):
        grasp.network_input(np.where(masks, np.nan, images), masks)
    with pytest.raises(ValueError, match="labels"):
        grasp.fit_convnet(images, masks, labels + 3, 3)
    with pytest.raises(ValueError, match="images"):
        grasp.network_input(images[:0], masks[:0])


def test_cached_convnet_trains_once_per_settings(tmp_path, monkeypatch):
    monkeypatch.setenv("LFD_JAX_CACHE", str(tmp_path))
    calls = []

    def train():
        calls.append(1)
        return grasp.ConvClassifier({"w": np.arange(3.0)})

    first = grasp.cached_convnet({"a": 1}, train)
    again = grasp.cached_convnet({"a": 1}, train)
    grasp.cached_convnet({"a": 2}, train)
    assert len(calls) == 2 and np.array_equal(again.params["w"], first.params["w"])


def test_perceptron_separates_two_clouds():
    rng = np.random.default_rng(4)
    labels = np.arange(200) % 2
    x = rng.normal(0, 1, (200, 5)) + 3.0 * labels[:, None]
    clf = fit_classifier(x, labels, 2, epochs=20, batch=50, hidden=16, learning_rate=1e-2)
    assert np.mean(classify(clf, x) == labels) >= 0.95
