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
  R = Rz(phi) Ry(theta) Rx(psi) (scipy's `Rotation.from_euler("ZYX", ...)`).
* `exact_search` is the exact kNN drop-in for `lsh.query` (same result type).
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from lfd_common import as_array, check_int, check_real
from hog_jax.lsh import LSHIndex, LSHResult

__all__ = [
    "KNNModel", "Prediction", "euler_to_quat", "exact_search", "fit", "intra_class_sigma", "mean_rotation",
    "predict", "quat_to_euler", "vote",
]


# ----------------------------------------------------------------------------------------- search
@partial(jax.jit, static_argnames=("k", "q_chunk", "n_block"))
def _exact(data, sq, queries, k: int, q_chunk: int, n_block: int):
    N, D = data.shape
    n_blocks = -(-N // n_block)
    pad = n_blocks * n_block - N
    blocks = jnp.concatenate([data, jnp.zeros((pad, D), data.dtype)]).reshape(n_blocks, n_block, D)
    sq_b = jnp.concatenate([sq, jnp.full((pad,), jnp.inf, sq.dtype)]).reshape(n_blocks, n_block)
    kb = min(k, n_block)

    def one_chunk(qc):  # (c, D) -> top k over all blocks, merged block by block
        qq = jnp.sum(qc * qc, axis=1, keepdims=True)

        def step(carry, blk):
            best_d, best_i = carry
            x, s, b = blk
            d2 = qq - 2.0 * qc @ x.T + s[None]
            neg, pos = jax.lax.top_k(-d2, kb)
            cand_d = jnp.concatenate([best_d, -neg], axis=1)
            cand_i = jnp.concatenate([best_i, (pos + b * n_block).astype(jnp.int32)], axis=1)
            neg2, sel = jax.lax.top_k(-cand_d, k)
            return (-neg2, jnp.take_along_axis(cand_i, sel, axis=1)), None

        init = (jnp.full((qc.shape[0], k), jnp.inf, data.dtype), jnp.full((qc.shape[0], k), -1, jnp.int32))
        (d2, idx), _ = jax.lax.scan(step, init, (blocks, sq_b, jnp.arange(n_blocks)))
        # exact distances of the k found (the expanded form above loses precision for near points)
        diff = data[jnp.maximum(idx, 0)] - qc[:, None, :]
        d = jnp.sqrt(jnp.sum(diff * diff, axis=-1))
        order = jnp.argsort(d, axis=1)
        return jnp.take_along_axis(idx, order, 1), jnp.take_along_axis(d, order, 1)

    Q = queries.shape[0]
    n_chunks = -(-Q // q_chunk)
    qp = jnp.concatenate([queries, jnp.broadcast_to(queries[:1], (n_chunks * q_chunk - Q, D))])
    idx, d = jax.lax.map(one_chunk, qp.reshape(n_chunks, q_chunk, D))
    return idx.reshape(-1, k)[:Q], d.reshape(-1, k)[:Q]


def exact_search(data, queries, k: int = 10) -> LSHResult:
    """Exact Euclidean kNN of each query (Q, D) in `data` (N, D): an `LSHResult` with n_scanned = N.

    Blocked over the database (a running top-k merged per block of 16,384 points), so memory stays
    O(Q_chunk x block) even for millions of points.
    """
    data = as_array(data, "data", ndim=2, dtype=np.float32)
    q = as_array(queries, "queries", ndim=(1, 2), dtype=np.float32)
    single = q.ndim == 1
    q = q[None] if single else q
    if q.shape[1] != data.shape[1]:
        raise ValueError(f"queries: expected dimension D = {data.shape[1]} (the database's), got {q.shape[1]}")
    N = data.shape[0]
    check_int(k, "k", min_value=1, max_value=N)
    x = jnp.asarray(data)
    idx, d = _exact(x, jnp.sum(x * x, axis=1), jnp.asarray(q), k, min(q.shape[0], 64), min(N, 16384))
    res = LSHResult(idx, d, jnp.full((q.shape[0],), N, jnp.int32))
    return LSHResult(*(a[0] for a in res)) if single else res


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


def intra_class_sigma(data, labels, max_exact: int = 10_000, n_pairs: int = 1_000_000,
                      seed: int = 0) -> float:
    """sigma of GRASP eq. 5: the mean distance between two distinct points of the same class.

    data: (N, D); labels: (N,) ints. Classes with <= max_exact points are exact (all pairs, float64
    accumulation per block); larger classes use `n_pairs` uniform random pairs a != b (unbiased).
    Classes with a single point have no pair and do not count. Needs at least one class with 2 points.
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
def euler_to_quat(euler: jax.Array) -> jax.Array:
    """(..., 3) Euler angles (phi, theta, psi), R = Rz(phi) Ry(theta) Rx(psi) -> (..., 4) (w, x, y, z)."""
    half = 0.5 * jnp.asarray(euler)
    cz, sz = jnp.cos(half[..., 0]), jnp.sin(half[..., 0])
    cy, sy = jnp.cos(half[..., 1]), jnp.sin(half[..., 1])
    cx, sx = jnp.cos(half[..., 2]), jnp.sin(half[..., 2])
    w = cz * cy * cx + sz * sy * sx
    x = cz * cy * sx - sz * sy * cx
    y = cz * sy * cx + sz * cy * sx
    z = sz * cy * cx - cz * sy * sx
    return jnp.stack([w, x, y, z], axis=-1)


def quat_to_euler(q: jax.Array) -> jax.Array:
    """(..., 4) unit quaternions (w, x, y, z) -> (..., 3) Z-Y'-X'' Euler angles, theta in [-pi/2, pi/2]."""
    q = jnp.asarray(q)
    q = q / jnp.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    phi = jnp.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    theta = jnp.arcsin(jnp.clip(2 * (w * y - z * x), -1.0, 1.0))
    psi = jnp.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    return jnp.stack([phi, theta, psi], axis=-1)


def mean_rotation(quats: jax.Array, weights: jax.Array) -> jax.Array:
    """Weighted mean rotation (..., n, 4), (..., n) -> (..., 4): top eigenvector of sum w q q^T,
    sign chosen with w >= 0. Weights must not all be zero."""
    m = jnp.einsum("...n,...ni,...nj->...ij", weights, quats, quats)
    _, vecs = jnp.linalg.eigh(m)
    q = vecs[..., :, -1]
    return q * jnp.where(q[..., :1] < 0, -1.0, 1.0)


# ----------------------------------------------------------------------------------- classifier
class KNNModel(NamedTuple):
    """A kNN classifier/regressor: data (N, D) float32, labels (N,) int32 in [0, M), quats (N, 4)
    orientations as unit quaternions (zeros when none were given), sigma () eq. 5, n_classes M."""

    data: jax.Array
    labels: jax.Array
    quats: jax.Array
    sigma: jax.Array
    n_classes: int


class Prediction(NamedTuple):
    """label (Q,) int32; scores (Q, M) eq. 3 class scores; quat (Q, 4) and euler (Q, 3) the eq. 4
    orientation (NaN where the model has none); indices / distances (Q, k) the neighbours used."""

    label: jax.Array
    scores: jax.Array
    quat: jax.Array
    euler: jax.Array
    indices: jax.Array
    distances: jax.Array


def fit(data, labels, orientations=None, sigma: float | None = None, n_classes: int | None = None,
        max_exact: int = 10_000, seed: int = 0) -> KNNModel:
    """A kNN model. data (N, D); labels (N,) ints in [0, M); orientations (N, 3) Euler angles (radians,
    Z-Y'-X'') or None; sigma: eq. 5 from the data when None."""
    x = as_array(data, "data", ndim=2, dtype=np.float32)
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
        quats = np.asarray(euler_to_quat(jnp.asarray(o, jnp.float32)))
    s = intra_class_sigma(x, y, max_exact=max_exact, seed=seed) if sigma is None else \
        check_real(sigma, "sigma", min_value=0.0, exclusive_min=True)
    return KNNModel(jnp.asarray(x), jnp.asarray(y, jnp.int32), jnp.asarray(quats), jnp.float32(s), M)


@partial(jax.jit, static_argnames=("n_classes",))
def vote(labels, distances, quats, sigma, n_classes: int):
    """Eqs. 3-4 for neighbour labels (Q, k) (-1 = none), distances (Q, k), quaternions (Q, k, 4).

    Returns (label (Q,), scores (Q, M), quat (Q, 4)). Weights are exp(-d^2 / (2 sigma^2)); the
    orientation uses only neighbours of the winning class. A query whose neighbours all underflow
    to weight 0 falls back to the nearest neighbour (weights computed relative to the nearest)."""
    valid = labels >= 0
    d2 = jnp.where(valid, distances, jnp.inf) ** 2
    logw = -d2 / (2.0 * sigma**2)
    w = jnp.where(valid, jnp.exp(logw), 0.0)
    rel = jnp.where(valid, jnp.exp(logw - jnp.max(logw, axis=1, keepdims=True)), 0.0)
    onehot = jax.nn.one_hot(jnp.where(valid, labels, 0), n_classes) * valid[..., None]
    scores = jnp.einsum("qk,qkm->qm", w, onehot)
    rel_scores = jnp.einsum("qk,qkm->qm", rel, onehot)  # same argmax, no underflow
    label = jnp.argmax(rel_scores, axis=1).astype(jnp.int32)
    same = valid & (labels == label[:, None])
    quat = mean_rotation(quats, jnp.where(same, rel, 0.0))
    return label, scores, quat


def predict(model: KNNModel, queries, k: int = 10, index: LSHIndex | None = None,
            n_per_table: int = 64, n_tables: int | None = None, max_rerank: int | None = None) -> Prediction:
    """Class and orientation of each query (Q, D): neighbours from `index` (LSH, built on
    model.data) or exact search when None, then eqs. 3-4."""
    from hog_jax.lsh import query as lsh_query

    if index is not None:
        if index.data.shape != model.data.shape:
            raise ValueError(f"index: built on {index.data.shape} points, the model holds {model.data.shape}")
        res = lsh_query(index, queries, k, n_per_table, n_tables, max_rerank)
    else:
        res = exact_search(model.data, queries, k)
    idx, dist = res.indices, res.distances
    if idx.ndim == 1:
        idx, dist = idx[None], dist[None]
    safe = jnp.maximum(idx, 0)
    labels = jnp.where(idx >= 0, model.labels[safe], -1)
    label, scores, quat = vote(labels, dist, model.quats[safe], model.sigma, model.n_classes)
    has_orientation = jnp.any(model.quats != 0)
    quat = jnp.where(has_orientation, quat, jnp.nan)
    return Prediction(label, scores, quat, quat_to_euler(quat), idx, dist)
