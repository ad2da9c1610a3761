"""Distance-weighted kNN classification and orientation regression (GRASP eqs. 3-5), exact search.

Shapes: N database points, M classes, Q queries, D feature dimension, k neighbours.

* Class vote (eq. 3): y_hat = argmax_i sum_{neighbours j of class i} exp(-d_j^2 / (2 sigma^2)).
* sigma (eq. 5): the text defines sigma as "the mean intra-class, inter-point distance" in feature
  space; `intra_class_sigma` returns exactly that, the mean of ||x_a - x_b|| over all ordered pairs
  a != b of the same class, pooled over classes (sum of distances / sum_i N_i (N_i - 1)). The printed
  formula's factor 1 / sqrt(2 M N) in front of the double sum cannot be a mean (it grows with N); we
  follow the text. Classes with more than `max_exact` points use a uniform sample of pairs (an
  unbiased estimate of that class's mean distance).
* Orientation (eq. 4): the distance-weighted mean of the orientations of the neighbours of class
  y_hat only. Angles are cyclic, so instead of averaging Euler angles the rotations are averaged:
  the weighted quaternion mean of Markley et al. (2007), the eigenvector of sum_j w_j q_j q_j^T with
  the largest eigenvalue (sign-invariant, so q and -q are the same rotation). It is returned as a
  unit quaternion (w, x, y, z) and as Euler angles.
* Euler angles o = (phi, theta, psi) in radians, intrinsic Z-Y'-X'' (yaw, pitch, roll):
  R = Rz(phi) Ry(theta) Rx(psi) (scipy's `Rotation.from_euler("ZYX", ...)`); the conversions are
  `lfd_common.rotations`'.
* Neighbours come from `hog_jax.query` (an index) or exact search (none).

Edge cases: when eq. 5 gives sigma = 0 (every class's points coincide, e.g. identical or all-zero
features) or a sigma below the float32 resolution of the data, `fit` floors it at
eps_32 * max(1, max|x|) with a `UserWarning`; eq. 3 is then in effect the nearest-neighbour vote (its
limit sigma -> 0). An explicit sigma must lie in [2^-60, 2^62] (sigma^2 finite and normal in
float32). Features must satisfy |x| <= 2^60 / sqrt(D) (see `exact`). "Not found": a query for which an
LSH index returns no neighbour at all gets `Prediction.found` False, label -1, scores 0, quat and
euler NaN (indices -1, distances inf); exact search always finds k neighbours (found True).
"""
from __future__ import annotations

import warnings
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from hog_jax._src.checks import check_feature_range
from hog_jax._src.exact import check_queries, exact_search_checked
from hog_jax._src.lsh import LSHIndex
from hog_jax._src.search import query
from lfd_common import as_array, check_int, check_real, euler_zyx_to_quat, quat_to_euler_zyx

__all__ = [
    "KNNModel", "Prediction", "euler_to_quat", "fit", "intra_class_sigma", "mean_rotation", "predict",
    "quat_to_euler", "vote",
]


# ------------------------------------------------------------------------------------------ sigma
def _pair_distance_sum(x: np.ndarray, block: int = 512) -> float:
    """Sum of ||x_a - x_b|| over ordered pairs a != b, float64, blocked over rows (memory O(block n))."""
    sq = np.einsum("ij,ij->i", x, x)
    total = 0.0
    for start in range(0, x.shape[0], block):  # row blocks, not points
        xb = x[start:start + block]
        d2 = sq[start:start + block, None] - 2.0 * xb @ x.T + sq[None]
        d2[np.arange(xb.shape[0]), start + np.arange(xb.shape[0])] = 0.0  # exact zero on the diagonal
        total += float(np.sqrt(np.maximum(d2, 0.0)).sum())
    return total


def intra_class_sigma(data: Float[ArrayLike, "N D"], labels: Int[ArrayLike, " N"], max_exact: int = 10_000,
                      n_pairs: int = 1_000_000, seed: int = 0) -> float:
    """sigma of GRASP eq. 5: the mean distance between two distinct points of the same class.

    The text defines sigma as "the mean intra-class, inter-point distance" in feature space: the mean
    of ||x_a - x_b|| over all ordered pairs a != b of the same class, pooled over classes (sum of
    distances / sum_i N_i (N_i - 1)). The printed formula's factor 1 / sqrt(2 M N) cannot be a mean
    (it grows with N); the text is followed. Classes with a single point have no pair and do not
    count.

    Args:
        data: (N, D) features.
        labels: (N,) integer class labels.
        max_exact: classes with at most this many points use all pairs (float64 accumulation per
            block), >= 2.
        n_pairs: larger classes use this many uniform random pairs a != b (an unbiased estimate), >= 1.
        seed: the seed of the pair sample.

    Returns:
        sigma, as a float.

    Raises:
        ValueError: naming the argument for empty or non-finite data, labels of another length,
            max_exact < 2, n_pairs < 1, or no class with two points (`labels`).
    """
    x = as_array(data, "data", ndim=2, dtype=np.float64)
    y = as_array(labels, "labels", shape=(x.shape[0],), dtype=np.int64)
    check_int(max_exact, "max_exact", min_value=2)
    check_int(n_pairs, "n_pairs", min_value=1)
    rng = np.random.default_rng(seed)
    total, count = 0.0, 0.0
    for c in np.unique(y):  # a loop over classes (M is small), not over points
        xc = x[y == c]
        n = xc.shape[0]
        if n < 2:
            continue
        pairs = n * (n - 1)
        if n <= max_exact:
            s = _pair_distance_sum(xc)
            mean = s / pairs
        else:
            a = rng.integers(0, n, n_pairs)
            b = (a + rng.integers(1, n, n_pairs)) % n  # uniform over b != a
            mean = float(np.linalg.norm(xc[a] - xc[b], axis=1).mean())
        total += mean * pairs
        count += pairs
    if count == 0:
        raise ValueError("labels: every class has a single point; eq. 5 needs two points of one class")
    return total / count


# ------------------------------------------------------------------------------------ rotations
def euler_to_quat(euler: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 4"]:
    """Euler angles to unit quaternions (the orientation of GRASP eq. 4).

    Args:
        euler: (..., 3) angles (phi, theta, psi) in radians, intrinsic Z-Y'-X'' (yaw, pitch, roll):
            R = Rz(phi) Ry(theta) Rx(psi) (scipy's `Rotation.from_euler("ZYX", ...)`).

    Returns:
        (..., 4) quaternions (w, x, y, z), a jax array (`lfd_common.euler_zyx_to_quat`).
    """
    return euler_zyx_to_quat(jnp.asarray(euler))


def quat_to_euler(q: Float[ArrayLike, "*batch 4"]) -> Float[Array, "*batch 3"]:
    """Quaternions to Z-Y'-X'' Euler angles (the inverse of `euler_to_quat`).

    Args:
        q: (..., 4) quaternions (w, x, y, z).

    Returns:
        (..., 3) angles (phi, theta, psi), theta in [-pi/2, pi/2], a jax array
        (`lfd_common.quat_to_euler_zyx`).
    """
    return quat_to_euler_zyx(jnp.asarray(q))


def mean_rotation(quats: Float[ArrayLike, "*batch n 4"], weights: Float[ArrayLike, "*batch n"]
                  ) -> Float[Array, "*batch 4"]:
    """The weighted mean rotation of quaternions (GRASP eq. 4 on rotations, Markley et al. 2007).

    Angles are cyclic, so instead of averaging Euler angles the rotations are averaged: the
    eigenvector of sum_j w_j q_j q_j^T with the largest eigenvalue (sign-invariant: q and -q are the
    same rotation), its sign chosen with w >= 0.

    Args:
        quats: (..., n, 4) unit quaternions (w, x, y, z).
        weights: (..., n) non-negative weights, not all zero.

    Returns:
        (..., 4) the mean unit quaternion.
    """
    m = jnp.einsum("...n,...ni,...nj->...ij", weights, quats, quats)
    _, vecs = jnp.linalg.eigh(m)
    q = vecs[..., :, -1]
    return q * jnp.where(q[..., :1] < 0, -1.0, 1.0)


# ----------------------------------------------------------------------------------- classifier
class KNNModel(NamedTuple):
    """A kNN classifier and orientation regressor (GRASP eqs. 3-5).

    Attributes:
        data: (N, D) float32 database features.
        labels: (N,) int32 classes in [0, M).
        quats: (N, 4) orientations as unit quaternions (zeros when none were given).
        sigma: () the eq. 5 scale.
        n_classes: M.
    """

    data: Float[Array, "N D"]
    labels: Int[Array, " N"]
    quats: Float[Array, "N 4"]
    sigma: Float[Array, ""]
    n_classes: int


class Prediction(NamedTuple):
    """Class and orientation of each query (GRASP eqs. 3-4).

    Attributes:
        label: (Q,) int32 class, -1 where no neighbour was found.
        scores: (Q, M) eq. 3 class scores, 0 where none was found.
        quat: (Q, 4) the eq. 4 orientation as a quaternion, NaN where the model has none or no
            neighbour was found.
        euler: (Q, 3) the same as Z-Y'-X'' Euler angles.
        indices: (Q, k) the neighbours used, -1 where missing.
        distances: (Q, k) their distances, inf where missing.
        found: (Q,) bool, at least one neighbour was found (always True for exact search).
    """

    label: Int[Array, " Q"]
    scores: Float[Array, "Q M"]
    quat: Float[Array, "Q 4"]
    euler: Float[Array, "Q 3"]
    indices: Int[Array, "Q k"]
    distances: Float[Array, "Q k"]
    found: Bool[Array, " Q"]


_SIGMA_MIN, _SIGMA_MAX = 2.0**-60, 2.0**62


def fit(data: Float[ArrayLike, "N D"], labels: Int[ArrayLike, " N"],
        orientations: Float[ArrayLike, "N 3"] | None = None, sigma: float | None = None,
        n_classes: int | None = None, max_exact: int = 10_000, seed: int = 0) -> KNNModel:
    """A kNN model of labelled features (GRASP eqs. 3-5).

    Args:
        data: (N, D) features, |x| <= 2^60 / sqrt(D).
        labels: (N,) integer classes in [0, M).
        orientations: (N, 3) Euler angles (radians, Z-Y'-X''), or None.
        sigma: the eq. 5 scale, in [2^-60, 2^62]; None: eq. 5 from the data (`intra_class_sigma`),
            floored with a `UserWarning` at eps_32 * max(1, max|x|) when eq. 5 gives less (0 when every
            class's points coincide; eq. 3 is then in effect the nearest-neighbour vote).
        n_classes: M, at least max(labels) + 1 (default max(labels) + 1).
        max_exact: passed to `intra_class_sigma`.
        seed: passed to `intra_class_sigma`.

    Returns:
        A `KNNModel`.

    Raises:
        ValueError: naming the argument for empty or non-finite data, |data| > 2^60 / sqrt(D),
            negative labels or labels of another length, too few classes (`n_classes`), orientations
            of another shape, or sigma out of range.
    """
    x = check_feature_range(as_array(data, "data", ndim=2, dtype=np.float32), "data")
    N = x.shape[0]
    y = as_array(labels, "labels", ndim=1, dtype=np.int64, min_value=0)
    if y.shape[0] != N:
        raise ValueError(f"labels: expected {N} labels (one per data row), got {y.shape[0]}")
    M = int(y.max()) + 1 if n_classes is None else check_int(n_classes, "n_classes", min_value=int(y.max()) + 1)
    if orientations is None:
        quats = np.zeros((N, 4), np.float32)
    else:
        o = as_array(orientations, "orientations", ndim=2, dtype=np.float64)
        if o.shape != (N, 3):
            raise ValueError(f"orientations: expected shape ({N}, 3) (Euler angles per data row), got {o.shape}")
        quats = np.asarray(euler_to_quat(o.astype(np.float32)))
    if sigma is None:
        s = intra_class_sigma(x, y, max_exact=max_exact, seed=seed)
        floor = float(np.finfo(np.float32).eps) * max(1.0, float(max(np.max(x), -np.min(x))))
        if s < floor:
            warnings.warn(f"sigma: eq. 5 gives {s:.3g} (same-class points coincide); floored at {floor:.3g}, "
                          "so eq. 3 votes by the nearest neighbours", UserWarning, stacklevel=2)
            s = floor
    else:
        s = check_real(sigma, "sigma", min_value=_SIGMA_MIN, max_value=_SIGMA_MAX)
    return KNNModel(jnp.asarray(x), jnp.asarray(y, jnp.int32), jnp.asarray(quats), jnp.float32(s), M)


@partial(jax.jit, static_argnames=("n_classes",))
def vote(labels: Int[ArrayLike, "Q k"], distances: Float[ArrayLike, "Q k"], quats: Float[ArrayLike, "Q k 4"],
         sigma: Float[ArrayLike, ""], n_classes: int
         ) -> tuple[Int[Array, " Q"], Float[Array, "Q M"], Float[Array, "Q 4"]]:
    """The distance-weighted class vote and orientation of GRASP eqs. 3-4 (jitted).

    Weights are exp(-d^2 / (2 sigma^2)) (eq. 3: y_hat = argmax_i sum_{neighbours j of class i} w_j);
    the orientation (eq. 4) is the weighted mean rotation (`mean_rotation`) of the neighbours of the
    winning class only. A query whose neighbours all underflow to weight 0 falls back to the nearest
    neighbour (weights relative to the nearest; when even those exponents overflow, the nearest
    neighbours, ties included, vote with weight 1).

    Args:
        labels: (Q, k) neighbour classes, -1 for none.
        distances: (Q, k) neighbour distances.
        quats: (Q, k, 4) neighbour orientations.
        sigma: () the eq. 5 scale.
        n_classes: M (static).

    Returns:
        label (Q,), scores (Q, M), quat (Q, 4). A query without any neighbour gets scores 0 and
        label 0 (`predict` marks it not found).
    """
    valid = labels >= 0
    d2 = jnp.where(valid, distances, jnp.inf) ** 2
    logw = -d2 / (2.0 * sigma**2)
    w = jnp.where(valid, jnp.exp(logw), 0.0)
    nearest = valid & (distances == jnp.min(jnp.where(valid, distances, jnp.inf), axis=1, keepdims=True))
    # every exponent overflowed (d / sigma beyond float32): the limit of eq. 3 is the nearest-neighbour vote
    logw_rel = jnp.where(jnp.isfinite(jnp.max(logw, axis=1, keepdims=True)), logw, jnp.where(nearest, 0.0, -jnp.inf))
    rel = jnp.where(valid, jnp.exp(logw_rel - jnp.max(logw_rel, axis=1, keepdims=True)), 0.0)
    onehot = jax.nn.one_hot(jnp.where(valid, labels, 0), n_classes) * valid[..., None]
    scores = jnp.einsum("qk,qkm->qm", w, onehot)
    rel_scores = jnp.einsum("qk,qkm->qm", rel, onehot)  # same argmax, no underflow
    label = jnp.argmax(rel_scores, axis=1).astype(jnp.int32)
    same = valid & (labels == label[:, None])
    quat = mean_rotation(quats, jnp.where(same, rel, 0.0))
    return label, scores, quat


def predict(model: KNNModel, queries: Float[ArrayLike, "Q D"] | Float[ArrayLike, " D"], k: int = 10,
            index: LSHIndex | None = None, n_per_table: int = 64, n_tables: int | None = None,
            max_rerank: int | None = None, n_probes: int = 0) -> Prediction:
    """Class and orientation of each query by the kNN vote (GRASP eqs. 3-4).

    Neighbours come from `index` (LSH, built on the model's data) or exact search when None. A query
    for which the index finds no neighbour at all is marked, not guessed: found False, label -1,
    scores 0, quat / euler NaN (no fallback to exact search; rerun those rows with index=None, or tune
    the index, if an answer is needed).

    Args:
        model: the `KNNModel`.
        queries: (Q, D) features, or one (D,) query.
        k: neighbours per query, 1 <= k <= N.
        index: an `LSHIndex` built on `model.data`, or None for exact search.
        n_per_table: passed to `query`.
        n_tables: passed to `query`.
        max_rerank: passed to `query`.
        n_probes: passed to `query`.

    Returns:
        A `Prediction`.

    Raises:
        ValueError: naming the argument for invalid queries or k, an index built on other data, or
            n_tables * n_per_table < k (`n_per_table`).
    """
    q, _ = check_queries(queries, model.data.shape[1])
    check_int(k, "k", min_value=1, max_value=model.data.shape[0])
    if index is not None:
        if index.data.shape != model.data.shape:
            raise ValueError(f"index: built on {index.data.shape} points, the model holds {model.data.shape}")
        res = query(index, q, k, n_per_table, n_tables, max_rerank, n_probes)
    else:
        res = exact_search_checked(model.data, q, k)
    return Prediction(*_vote_neighbours(model.labels, model.quats, model.sigma, model.n_classes, res.indices,
                                        res.distances))


@partial(jax.jit, static_argnames=("n_classes",))
def _vote_neighbours(db_labels, db_quats, sigma, n_classes: int, idx, dist):
    """Eqs. 3-4 from the neighbours' ids (Q, k) (-1: none) and distances (Q, k), in one compiled call
    (as separate operations their dispatch cost more than an LSH query of one image)."""
    safe = jnp.maximum(idx, 0)
    labels = jnp.where(idx >= 0, db_labels[safe], -1)
    label, scores, quat = vote(labels, dist, db_quats[safe], sigma, n_classes)
    found = idx[:, 0] >= 0  # neighbours come nearest first, the missing ones last
    label = jnp.where(found, label, -1)
    has_orientation = jnp.any(db_quats != 0)
    quat = jnp.where(has_orientation & found[:, None], quat, jnp.nan)
    return label, scores, quat, quat_to_euler(quat), idx, dist, found
