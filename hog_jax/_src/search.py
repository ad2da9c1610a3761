"""Neighbour search as users call it: exact search and the LSH index, on one device or over a mesh.

Shapes: N database points, Q queries, D feature dimension, T tables, K hyperplanes per table,
C candidate slots per table and query, k neighbours.

Each entry point validates its input and runs the one-device kernels (`exact`, `lsh`) or, given a
`jax.sharding.Mesh` (`mesh=`) or a sharded index, their sharded versions (`lsh_sharded`), which
are built on the one-device kernels.
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh
from jaxtyping import Array, ArrayLike, Float, Key

from hog_jax._src.checks import check_feature_range, check_key
from hog_jax._src.exact import LSHResult, check_queries, exact_search_checked
from hog_jax._src.lsh import LSHIndex, build_index_one_device, query_one_device
from hog_jax._src.lsh_sharded import ShardedLSHIndex, build_sharded_index, exact_search_sharded, query_sharded
from lfd_common import as_array, check_int, check_mesh

__all__ = ["build_index", "exact_search", "query"]


def exact_search(data: Float[ArrayLike, "N D"], queries: Float[ArrayLike, "Q D"] | Float[ArrayLike, " D"],
                 k: int = 10, *, mesh: Mesh | None = None) -> LSHResult:
    """Exact Euclidean k nearest neighbours of each query (GRASP §V's search, without hashing).

    The drop-in for `query` (the same `LSHResult`), and the reference the LSH autotuner measures
    recall against. The database is scanned in blocks, a running top k merged per block of points,
    so memory stays O(query chunk x block) for millions of points. Every query finds k neighbours.

    Args:
        data: (N, D) the database.
        queries: (Q, D) queries, or one (D,) query.
        k: neighbours per query, 1 <= k <= N.
        mesh: a `jax.sharding.Mesh`, or None for one device. The database rows are split over its
            devices, the queries broadcast and each device's k best merged; the result equals the
            one-device result. With several processes each passes its own rows of the database (the
            same queries everywhere) and gets the whole result, ids counting the processes' rows in
            order.

    Returns:
        An `LSHResult` with indices and distances (Q, k) (or (k,) for one query), ascending, and
        n_scanned = N.

    Raises:
        ValueError: naming the argument for empty or non-finite input, a query of another dimension,
            k outside [1, N], |values| > 2^60 / sqrt(D) (squared distances would overflow float32),
            or a `mesh` that is not a `jax.sharding.Mesh`.
    """
    mesh = check_mesh(mesh)
    data = check_feature_range(as_array(data, "data", ndim=2, dtype=np.float32), "data")
    q, single = check_queries(queries, data.shape[1])
    check_int(k, "k", min_value=1, max_value=data.shape[0])
    res = exact_search_checked(jnp.asarray(data), q, k) if mesh is None else exact_search_sharded(data, q, k, mesh)
    return LSHResult(*(a[0] for a in res)) if single else res


def build_index(key: Key[Array, ""], data: Float[ArrayLike, "N D"], n_bits: int, n_tables: int,
                table_bits: int = 20, *, mesh: Mesh | None = None) -> LSHIndex | ShardedLSHIndex:
    """Build a hyperplane LSH index (GRASP §V, steps 1-4).

    Table t holds K random hyperplanes through the data mean; a point's bucket in it is its K-bit
    sign code (hashed into 2^table_bits buckets when K > table_bits).

    Args:
        key: a `jax.random` key (the hyperplanes and the order inside a bucket).
        data: (N, D) the database.
        n_bits: hyperplanes per table (K), 1..32.
        n_tables: number of tables (T), >= 1.
        table_bits: log2 of the hash-table size H, 1..31.
        mesh: a `jax.sharding.Mesh`, or None for one device. The rows are split over its devices,
            each with its own tables (the same hyperplanes as one device's for the same key), and a
            `ShardedLSHIndex` is returned, which `query` accepts (queries broadcast, the shards' top
            k merged). With several processes each passes its own rows (ids count the processes'
            rows in order).

    Returns:
        An `LSHIndex`, or a `ShardedLSHIndex` with `mesh`.

    Raises:
        ValueError: naming the argument for a key that is not a `jax.random` key, empty or
            non-finite data, |data| > 2^60 / sqrt(D) (squared distances would overflow float32),
            parameters out of range, or a `mesh` that is not a `jax.sharding.Mesh`.
    """
    mesh = check_mesh(mesh)
    check_key(key, "key")
    data = check_feature_range(as_array(data, "data", ndim=2, dtype=np.float32), "data")
    check_int(n_bits, "n_bits", min_value=1, max_value=32)
    check_int(n_tables, "n_tables", min_value=1)
    check_int(table_bits, "table_bits", min_value=1, max_value=31)
    if mesh is not None:
        return build_sharded_index(key, data, n_bits, n_tables, table_bits, mesh)
    return build_index_one_device(key, data, n_bits, n_tables, table_bits)


def query(index: LSHIndex | ShardedLSHIndex, queries: Float[ArrayLike, "Q D"] | Float[ArrayLike, " D"],
          k: int = 10, n_per_table: int = 64, n_tables: int | None = None, max_rerank: int | None = None,
          n_probes: int = 0) -> LSHResult:
    """The k approximate nearest neighbours of each query (GRASP §V, the query).

    Per table the query's bucket is read into C slots (a larger bucket contributes a random C of its
    points); the candidates of all tables are de-duplicated and re-ranked by their exact distance.

    Args:
        index: an `LSHIndex`, or a `ShardedLSHIndex` from `build_index(..., mesh=...)` (then
            `max_rerank` bounds each shard's candidates, and n_scanned sums the shards'; equal to
            one device's when no bucket holds more than C points).
        queries: (Q, D) queries, or one (D,) query.
        k: neighbours per query, 1 <= k <= N.
        n_per_table: candidate slots per bucket read and query (C).
        n_tables: use only the first tables (default all).
        max_rerank: re-rank at most this many distinct candidates (R, >= k; default T (1 + P) C,
            i.e. all). When more are found, n_scanned reports R, and which R are kept depends on the
            database size: up to 64 T (1 + P) C rows the first R in table order, beyond that the R
            smallest ids of at most 4 R bucket slots collected in table order.
        n_probes: per table, also read the P buckets whose codes differ from the query's in one bit,
            the bits of the hyperplanes nearest the query first (multi-probe LSH, Lv et al. 2007;
            0 <= P <= K; 0: the query's bucket only).

    Returns:
        An `LSHResult`: indices and distances (Q, k) (or (k,) for one query), ascending; a query
        whose buckets hold fewer than k points gets -1 / inf in the missing places (a query with
        none at all: every index -1); n_scanned (Q,) the distinct candidates re-ranked.

    Raises:
        ValueError: naming the argument for invalid queries, k, n_tables, n_probes or max_rerank,
            or n_tables * n_per_table < k (the candidate slots cannot hold k neighbours:
            `n_per_table`).
    """
    if not isinstance(index, LSHIndex):
        return query_sharded(index, queries, k, n_per_table, n_tables, max_rerank, n_probes)
    return query_one_device(index, queries, k, n_per_table, n_tables, max_rerank, n_probes)
