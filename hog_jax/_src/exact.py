"""Exact k-nearest-neighbour search on one device, and the result type every neighbour search returns.

Shapes: N database points, Q queries, D feature dimension, k neighbours.

`exact_search_checked` is the one-device kernel behind `hog_jax.exact_search` (the exact drop-in for
`hog_jax.query`, same `LSHResult`): the LSH autotuner measures recall against it and `knn.predict`
uses it when no index is given. The database is scanned in blocks (a running top-k merged block by
block), so memory stays O(query chunk x block) for millions of points; `exact_blocks` is the scan,
which the sharded search runs on every shard.

Range: data and queries must satisfy |x| <= 2^60 / sqrt(D) (`checks.feature_limit`), so that the
expanded squared distances |q|^2 - 2 q.x + |x|^2 cannot overflow float32; larger values are a
`ValueError` naming the argument (scale the features), never wrong neighbours.
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from hog_jax._src.checks import check_feature_range
from lfd_common import as_array

__all__ = ["LSHResult", "check_queries", "exact_blocks", "exact_search_checked"]

Q_CHUNK, N_BLOCK = 64, 16384


class LSHResult(NamedTuple):
    """The k neighbours of each query, from `query` or `exact_search`.

    A single (D,) query gives (k,), (k,) and ().

    Attributes:
        indices: (Q, k) int32 neighbour ids, -1 where not found.
        distances: (Q, k) float32 Euclidean distances, ascending, inf where not found.
        n_scanned: (Q,) int32 distinct candidates re-ranked (N for exact search).
    """

    indices: Int[Array, "Q k"]
    distances: Float[Array, "Q k"]
    n_scanned: Int[Array, " Q"]


@partial(jax.jit, static_argnames=("k", "q_chunk", "n_block"))
def exact_blocks(data, sq, queries, k: int, q_chunk: int, n_block: int):
    N, D = data.shape
    n_blocks = -(-N // n_block)
    kb = min(k, n_block)

    def one_chunk(qc):  # (c, D) -> top k over all blocks, merged block by block
        qq = jnp.sum(qc * qc, axis=1, keepdims=True)

        def step(carry, b):
            best_d, best_i = carry
            # the last block is read ending at row N (no padded copy of the database), its rows that the
            # block before already covered masked out
            start = jnp.minimum(b * n_block, N - n_block)
            x = jax.lax.dynamic_slice_in_dim(data, start, n_block)
            s = jnp.where(start + jnp.arange(n_block) >= b * n_block,
                          jax.lax.dynamic_slice_in_dim(sq, start, n_block), jnp.inf)
            d2 = qq - 2.0 * qc @ x.T + s[None]
            neg, pos = jax.lax.top_k(-d2, kb)
            cand_d = jnp.concatenate([best_d, -neg], axis=1)
            cand_i = jnp.concatenate([best_i, (pos + start).astype(jnp.int32)], axis=1)
            neg2, sel = jax.lax.top_k(-cand_d, k)
            return (-neg2, jnp.take_along_axis(cand_i, sel, axis=1)), None

        init = (jnp.full((qc.shape[0], k), jnp.inf, data.dtype), jnp.full((qc.shape[0], k), -1, jnp.int32))
        (d2, idx), _ = jax.lax.scan(step, init, jnp.arange(n_blocks))
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


def check_queries(queries, dim: int) -> tuple[np.ndarray, bool]:
    """Validate queries (Q, D) or one (D,) query of dimension `dim` -> ((Q, D) float32, single)."""
    q = as_array(queries, "queries", ndim=(1, 2), dtype=np.float32)
    single = q.ndim == 1
    q = q[None] if single else q
    if q.shape[1] != dim:
        raise ValueError(f"queries: expected dimension D = {dim} (the database's), got {q.shape[1]}")
    check_feature_range(q, "queries")
    return q, single


def exact_search_checked(data: Float[Array, "N D"], queries: Float[ArrayLike, "Q D"], k: int) -> LSHResult:
    """`exact_search` for a database validated before (a `knn.KNNModel`'s data) and queries (Q, D) that
    passed `check_queries`, 1 <= k <= N: no per-call copy and range check of the whole database, which
    would cost more than the search itself for a single query."""
    N = data.shape[0]
    q = jnp.asarray(queries)
    idx, d = _exact_plain(data, q, k, min(q.shape[0], Q_CHUNK), min(N, N_BLOCK))
    return LSHResult(idx, d, jnp.full((q.shape[0],), N, jnp.int32))


@partial(jax.jit, static_argnames=("k", "q_chunk", "n_block"))
def _exact_plain(data, queries, k: int, q_chunk: int, n_block: int):
    return exact_blocks(data, jnp.sum(data * data, axis=1), queries, k, q_chunk, n_block)
