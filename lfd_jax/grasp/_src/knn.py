"""GRASP's features and kNN on hand crops: the HOG pyramid of each found crop (§IV, eq. 1) and the
distance-weighted kNN's class (§V, eq. 3) and orientation (eq. 4), by LSH or exact search.

Shapes: N crops of S x S pixels, D HOG features, k neighbours.
"""
from __future__ import annotations

import numpy as np

import hog_jax
from lfd_common import as_array, check_int


def hog_features(images, masks, found, config: hog_jax.HOGConfig) -> np.ndarray:
    """The HOG pyramid of each found crop (GRASP §IV, eq. 1).

    Args:
        images: (N, S, S) grey crops times their hand masks, N >= 1.
        masks: (N, S, S) bool hand masks.
        found: (N,) bool; False where segmentation found no hand.
        config: the HOG settings (B bins, L levels, binning, normalisation).

    Returns:
        (N, D) float32 features; rows of failed segmentations (or all-zero crops) stay zero and are
        never used.

    Raises:
        ValueError: `images` is not a non-empty finite (N, S, S) array, or `masks` / `found` do not
            match it (the message names the argument).
    """
    images = as_array(images, "images", ndim=3, dtype=None)
    masks = as_array(masks, "masks", shape=images.shape, dtype=None)
    found = as_array(found, "found", shape=(len(images),), dtype=bool)
    x = np.zeros((images.shape[0], hog_jax.hog_dim(config)), np.float32)
    ok = found & (images.reshape(len(images), -1).max(1) > 0)
    if ok.any():
        x[ok] = np.asarray(hog_jax.hog(images[ok], config, mask=masks[ok]))
    return x


def knn_predict(model, x, ok, k, **lsh):
    """Class (GRASP §V, eq. 3) and orientation (eq. 4) of the features where segmentation succeeded.

    Args:
        model: the `hog_jax.KNNModel` of the database.
        x: (N, D) query features (`hog_features`); N may be 0.
        ok: (N,) bool; rows where it is False are not queried.
        k: neighbours per query, 1 <= k <= the database's size.
        **lsh: `hog_jax.predict`'s index arguments (`index`, `n_per_table`, `n_tables`, ...); none:
            exact search.

    Returns:
        (labels (N,) int32 with -1 where not queried or no neighbour, Euler angles (N, 3), quaternions
        (N, 4) (NaN where not queried), neighbour indices (N, k) (-1 where none), distances (N, k)
        (inf where none)).

    Raises:
        ValueError: `x` is not a finite (N, D) array, `ok` does not match it or `k` is not a positive
            int (the message names the argument).
    """
    x = as_array(x, "x", ndim=2, dtype=None, nonempty=False)
    ok = as_array(ok, "ok", shape=(len(x),), dtype=bool, nonempty=False)
    k = check_int(k, "k", min_value=1)
    labels = np.full(len(x), -1, np.int32)
    euler = np.full((len(x), 3), np.nan, np.float32)
    quat = np.full((len(x), 4), np.nan, np.float32)
    idx = np.full((len(x), k), -1, np.int32)
    dist = np.full((len(x), k), np.inf, np.float32)
    if ok.any():
        p = hog_jax.predict(model, x[ok], k=k, **lsh)
        labels[ok], euler[ok], quat[ok] = np.asarray(p.label), np.asarray(p.euler), np.asarray(p.quat)
        idx[ok], dist[ok] = np.asarray(p.indices), np.asarray(p.distances)
    return labels, euler, quat, idx, dist
