"""Hyperplane locality-sensitive hashing with exact re-ranking on one device (GRASP §V, steps 1-4
and the query), and its autotuner.

Shapes: N database points, Q queries, D feature dimension, T tables, K hyperplanes (bits) per table,
C candidates kept per table and query, k neighbours returned.

Build (`hog_jax.build_index`; on one device `build_index_one_device`): table t holds K random
hyperplanes through the data mean (normal directions drawn i.i.d. N(0, I)); point x gets the K-bit
code f_t(x) = sum_j [a_tj . (x - mean) > 0] 2^j and the bucket h(f) in a table of size
H = 2^table_bits: h(f) = f when K <= table_bits, else the multiplicative (Fibonacci) hash
(f * 2654435761 mod 2^32) >> (32 - table_bits). Each table is stored as its bucket ids sorted, with
the point ids in that order (ties in random order), so a bucket is a contiguous run found with
`searchsorted`; no Python dict.

Query (`hog_jax.query`; on one device `query_one_device`): per table the query's bucket run is read
into a fixed buffer of C slots (a bucket with more than C points contributes a random C of them);
the union over the T tables is de-duplicated (a scatter into an N-row table; for very large
databases by sorting), every candidate is re-ranked by its exact Euclidean distance and the k
nearest are returned with their distances (-1 / inf where fewer than k were found), and the number
of distinct candidates scanned. Queries are processed in batches by one jitted function.

Parameters (`tune`): the paper learns K and T from the data for its epsilon; here the autotuner
measures recall@k against exact search on held-out queries for a grid of K and T (the first t tables
of one index per K) and returns the (K, T) that reaches the target recall with the fewest candidates
scanned.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int, Key

from hog_jax._src.checks import check_feature_range, check_key
from hog_jax._src.exact import LSHResult, check_queries, exact_search_checked
from lfd_common import as_array, check_int, check_real

__all__ = ["LSHIndex", "TuneOptions", "TuneResult", "bucket_ids", "build_index_one_device", "check_slots", "hash_codes",
           "query_chunks", "query_one_device", "recall_at_k", "tune"]

_GOLDEN = np.uint32(2654435761)


class LSHIndex(NamedTuple):
    """An immutable hyperplane LSH index on one device (a pytree of arrays; GRASP §V).

    Attributes:
        planes: (T, K, D) hyperplane normals.
        center: (D,) the point the hyperplanes pass through (the data mean).
        data: (N, D) the database, float32.
        keys: (T, N) per table, the bucket ids sorted.
        order: (T, N) per table, the point ids in bucket order.
        table_bits: () log2 of the table size H.
    """

    planes: Float[Array, "T K D"]  # hyperplane normals
    center: Float[Array, " D"]     # the point the hyperplanes pass through (the data mean)
    data: Float[Array, "N D"]      # the database, float32
    keys: Int[Array, "T N"]        # per table, the bucket ids sorted
    order: Int[Array, "T N"]       # per table, the point ids in bucket order
    table_bits: Int[Array, ""]     # log2 of the table size H


def bucket_ids(codes, n_bits: int, table_bits):
    """K-bit codes (..., uint32) -> bucket ids in [0, 2^table_bits) (int32)."""
    hashed = (codes * _GOLDEN) >> (jnp.uint32(32) - table_bits.astype(jnp.uint32))
    return jnp.where(n_bits <= table_bits, codes, hashed).astype(jnp.int32)


def _projections(x, planes, center):
    """(n, D) points -> (n, T, K) signed distances to the hyperplanes (up to the normals' lengths)."""
    T, K, D = planes.shape
    return ((x - center) @ planes.reshape(T * K, D).T).reshape(x.shape[0], T, K)


def _pack(bits):
    """(..., K) 0/1 uint32 -> (...,) uint32 codes sum_j bit_j 2^j."""
    return (bits << jnp.arange(bits.shape[-1], dtype=jnp.uint32)).sum(-1, dtype=jnp.uint32)


def hash_codes(x, planes, center):
    """(n, D) points -> (T, n) uint32 codes."""
    return _pack((_projections(x, planes, center) > 0).astype(jnp.uint32)).T


def _probe_codes(q, planes, center, n_probes: int):
    """(D,) query -> (T, 1 + n_probes) codes: its own bucket's, then the buckets that differ in one bit,
    the bits whose hyperplanes pass closest to the query first (query-directed probing, Lv et al. 2007,
    restricted to single-bit perturbations)."""
    proj = _projections(q[None], planes, center)[0]  # (T, K)
    code = _pack((proj > 0).astype(jnp.uint32))      # (T,)
    if n_probes == 0:
        return code[:, None]
    closest = jnp.argsort(jnp.abs(proj), axis=-1)[:, :n_probes].astype(jnp.uint32)  # (T, P)
    flipped = code[:, None] ^ (jnp.uint32(1) << closest)
    return jnp.concatenate([code[:, None], flipped], axis=1)


@partial(jax.jit, static_argnames=("chunk",))
def _build(key, data, planes, table_bits, chunk: int):
    N, D = data.shape
    T, K, _ = planes.shape
    center = data.mean(axis=0)
    n_chunks = -(-N // chunk)
    padded = jnp.concatenate([data, jnp.zeros((n_chunks * chunk - N, D), data.dtype)])
    codes = jax.lax.map(lambda x: hash_codes(x, planes, center), padded.reshape(n_chunks, chunk, D))
    codes = jnp.moveaxis(codes, 0, 1).reshape(T, n_chunks * chunk)[:, :N]
    buckets = bucket_ids(codes, K, table_bits)  # (T, N)
    perm = jax.random.permutation(key, N).astype(jnp.int32)  # random order inside a bucket

    def sort_table(b):
        pos = jnp.argsort(b[perm], stable=True)
        return b[perm][pos], perm[pos]

    keys, order = jax.vmap(sort_table)(buckets)
    return LSHIndex(planes, center, data, keys, order.astype(jnp.int32), table_bits)


def build_index_one_device(key, data: np.ndarray, n_bits: int, n_tables: int, table_bits: int) -> LSHIndex:
    """`hog_jax.build_index` on one device, for checked (N, D) float32 `data` and checked parameters."""
    N, D = data.shape
    k_planes, k_perm = jax.random.split(key)
    planes = jax.random.normal(k_planes, (n_tables, n_bits, D), jnp.float32)
    chunk = max(1, min(N, (1 << 22) // (n_tables * n_bits)))
    return _build(k_perm, jnp.asarray(data), planes, jnp.int32(table_bits), chunk)


_TABLE_DEDUP_ROWS_PER_SLOT = 64  # de-duplicate with an N-row table up to N <= 64 x the candidate slots


def _candidates(index: LSHIndex, q, n_per_table: int, n_tables_used, n_rerank: int, n_probes: int):
    """(D,) query -> (R,) distinct candidate ids, N-padded; and how many were distinct.

    Per table the query's bucket and `n_probes` neighbouring buckets (`_probe_codes`) are read, C slots
    each, T (1 + P) C = S slots in all. De-duplication depends on the database size (static):
    * N <= 64 S: each id's first slot is found by a scatter-min into an N-row table (O(N + S); XLA's
      comparison sort of the slots cost more than this up to several hundred thousand rows); the
      first R distinct ids in table order are kept.
    * larger N: the filled slots are compacted (cumsum + scatter, in table order) into a buffer of
      G = min(S, 4 R) slots, which is sorted and de-duplicated (O(G log G), not O(S log S); when more
      than G slots are filled, the last tables' candidates are dropped); the R smallest ids are kept.
    """
    T, K, _ = index.planes.shape
    N = index.data.shape[0]
    qb = bucket_ids(_probe_codes(q, index.planes, index.center, n_probes), K, index.table_bits)  # (T, 1 + P)
    lo = jax.vmap(lambda keys, b: jnp.searchsorted(keys, b, side="left"))(index.keys, qb)
    hi = jax.vmap(lambda keys, b: jnp.searchsorted(keys, b, side="right"))(index.keys, qb)
    pos = lo[..., None] + jnp.arange(n_per_table)  # (T, 1 + P, C)
    ok = ((pos < hi[..., None]) & (jnp.arange(T)[:, None, None] < n_tables_used)).reshape(-1)
    ids = jax.vmap(lambda order, p: order[p])(index.order, jnp.minimum(pos, N - 1)).reshape(-1)
    slots = ids.shape[0]
    if N <= _TABLE_DEDUP_ROWS_PER_SLOT * slots:
        ids = jnp.where(ok, ids, N)
        slot = jnp.arange(slots, dtype=jnp.int32)
        first_slot = jnp.full((N + 1,), slots, jnp.int32).at[ids].min(slot)
        keep = ok & (first_slot[ids] == slot)
        return _compact(ids, keep, n_rerank, N), jnp.sum(keep).astype(jnp.int32)
    G = min(slots, 4 * n_rerank)
    ids = _compact(ids, ok, G, N)
    ids = jnp.sort(ids)
    dup = jnp.concatenate([jnp.zeros((1,), bool), ids[1:] == ids[:-1]])
    ids = jnp.where(dup, N, ids)
    n_distinct = jnp.sum(ids < N).astype(jnp.int32)
    if n_rerank < G:
        ids = _compact(ids, ids < N, n_rerank, N)
    return ids, n_distinct


def _compact(ids, keep, size: int, fill: int):
    """The kept ids (S,) in their order, in a buffer of `size`, padded with `fill` (the rest dropped)."""
    at = jnp.where(keep, jnp.cumsum(keep) - 1, size)
    return jnp.full((size,), fill, ids.dtype).at[at].set(ids, mode="drop")


def _query_one(index: LSHIndex, q, k: int, n_per_table: int, n_tables_used, n_rerank: int, n_probes: int):
    N = index.data.shape[0]
    ids, _ = _candidates(index, q, n_per_table, n_tables_used, n_rerank, n_probes)
    valid = ids < N
    diff = index.data[jnp.minimum(ids, N - 1)] - q
    d2 = jnp.where(valid, jnp.sum(diff * diff, axis=-1), jnp.inf)
    neg, pos = jax.lax.top_k(-d2, k)
    found = jnp.isfinite(neg)
    return (jnp.where(found, ids[pos], -1).astype(jnp.int32), jnp.where(found, jnp.sqrt(-neg), jnp.inf),
            valid.sum().astype(jnp.int32))


@partial(jax.jit, static_argnames=("k", "n_per_table", "n_rerank", "chunk", "n_probes"))
def query_chunks(index: LSHIndex, queries, k: int, n_per_table: int, n_tables_used, n_rerank: int, chunk: int,
           n_probes: int = 0):
    Q, D = queries.shape
    n_chunks = -(-Q // chunk)
    padded = jnp.concatenate([queries, jnp.broadcast_to(queries[:1], (n_chunks * chunk - Q, D))])
    one = partial(_query_one, index, k=k, n_per_table=n_per_table, n_tables_used=n_tables_used,
                  n_rerank=n_rerank, n_probes=n_probes)
    idx, dist, n = jax.lax.map(jax.vmap(one), padded.reshape(n_chunks, chunk, D))
    return LSHResult(idx.reshape(-1, k)[:Q], dist.reshape(-1, k)[:Q], n.reshape(-1)[:Q])


def query_one_device(index: LSHIndex, queries, k: int = 10, n_per_table: int = 64, n_tables: int | None = None,
                     max_rerank: int | None = None, n_probes: int = 0) -> LSHResult:
    """`hog_jax.query` on a one-device `LSHIndex`: the same arguments, checks and result."""
    q, single = check_queries(queries, index.data.shape[1])
    check_int(k, "k", min_value=1, max_value=index.data.shape[0])
    check_int(n_per_table, "n_per_table", min_value=1)
    T = index.planes.shape[0]
    n_tables = T if n_tables is None else check_int(n_tables, "n_tables", min_value=1, max_value=T)
    if n_tables < T:
        index = index._replace(planes=index.planes[:n_tables], keys=index.keys[:n_tables],
                               order=index.order[:n_tables])
    n_probes = check_int(n_probes, "n_probes", min_value=0, max_value=index.planes.shape[1])
    slots = n_tables * n_per_table * (1 + n_probes)
    check_slots(k, n_tables, n_per_table)
    R = slots if max_rerank is None else min(slots, check_int(max_rerank, "max_rerank", min_value=k))
    chunk = max(1, min(q.shape[0], 16))
    res = query_chunks(index, jnp.asarray(q), k, n_per_table, jnp.int32(n_tables), R, chunk, n_probes)
    return LSHResult(*(a[0] for a in res)) if single else res


def check_slots(k: int, n_tables: int, n_per_table: int) -> None:
    if n_tables * n_per_table < k:
        raise ValueError(f"n_per_table: n_tables * n_per_table = {n_tables} * {n_per_table} = {n_tables * n_per_table} "
                         f"candidate slots cannot hold k = {k} neighbours; use n_per_table >= {-(-k // n_tables)}")


def _check_grid(grid, name: str, max_value: int | None) -> tuple[int, ...]:
    if isinstance(grid, (str, bytes)) or not hasattr(grid, "__iter__"):
        raise ValueError(f"{name}: expected a non-empty sequence of integers, got {grid!r}")
    values = tuple(grid)
    if not values:
        raise ValueError(f"{name}: must not be empty (the grid to search)")
    for i, v in enumerate(values):
        check_int(v, f"{name}[{i}]", min_value=1, max_value=max_value)
    return tuple(int(v) for v in values)


def recall_at_k(found: Int[ArrayLike, "Q k"], truth: Int[ArrayLike, "Q k"]) -> float:
    """Recall@k of found neighbours against the true ones.

    Args:
        found: (Q, k) neighbour ids found by a search, -1 where nothing was found.
        truth: (Q, k) the true neighbour ids (from `exact_search`).

    Returns:
        The mean over queries of |found_q ∩ truth_q| / k.

    Raises:
        ValueError: `found` has another shape than `truth`.
    """
    found, truth = np.asarray(found), np.asarray(truth)
    if found.shape != truth.shape:
        raise ValueError(f"found: expected shape {truth.shape} (the truth's), got {found.shape}")
    hits = (found[:, :, None] == truth[:, None, :]) & (found[:, :, None] >= 0)
    return float(hits.any(axis=2).sum(axis=1).mean() / truth.shape[1])


@dataclasses.dataclass(frozen=True)
class TuneOptions:
    """The search space and the goal of `tune` (GRASP §V: K and T learnt from the data).

    Validated on construction; the grids are stored as tuples of ints.

    Attributes:
        target_recall: the recall@k to reach on the held-out queries, in [0, 1].
        n_bits_grid: the hyperplanes per table (K) to try, each in 1..32.
        n_tables_grid: the numbers of tables (T) to try, each >= 1.
        n_per_table: candidate slots per bucket read and query (C, >= 1).
        table_bits: log2 of the hash-table size H, 1..31.
        n_probes: the multi-probe setting the index will be queried with (see `query`), at most
            min(n_bits_grid).

    Raises:
        ValueError: naming the field for an empty grid, a grid entry out of range or another value
            out of range.
    """

    target_recall: float = 0.9
    n_bits_grid: Sequence[int] = (8, 10, 12, 14, 16, 18, 20)
    n_tables_grid: Sequence[int] = (1, 2, 4, 8, 12, 16, 24, 32)
    n_per_table: int = 64
    table_bits: int = 20
    n_probes: int = 0

    def __post_init__(self):
        check_real(self.target_recall, "target_recall", min_value=0.0, max_value=1.0)
        check_int(self.n_per_table, "n_per_table", min_value=1)
        check_int(self.table_bits, "table_bits", min_value=1, max_value=31)
        object.__setattr__(self, "n_bits_grid", _check_grid(self.n_bits_grid, "n_bits_grid", 32))
        object.__setattr__(self, "n_tables_grid", _check_grid(self.n_tables_grid, "n_tables_grid", None))
        check_int(self.n_probes, "n_probes", min_value=0, max_value=min(self.n_bits_grid))


class TuneResult(NamedTuple):
    """The LSH settings `tune` chose, and what it measured.

    Attributes:
        n_bits: hyperplanes per table (K).
        n_tables: number of tables (T).
        n_per_table: candidate slots per bucket (C).
        max_rerank: the re-rank buffer (R).
        recall: recall@k on the held-out queries with these settings.
        mean_scanned: distinct candidates re-ranked per query.
        reached: whether the target was met; if not, the highest-recall setting is returned.
        table: rows (K, T, recall, mean_scanned) of every (K, T) tried, with R = T C.
    """

    n_bits: int
    n_tables: int
    n_per_table: int
    max_rerank: int
    recall: float
    mean_scanned: float
    reached: bool
    table: tuple


def tune(key: Key[Array, ""], data: Float[ArrayLike, "N D"], queries: Float[ArrayLike, "Q D"], k: int = 10,
         options: TuneOptions = TuneOptions(), truth: Int[ArrayLike, "Q k"] | None = None) -> TuneResult:
    """Choose the LSH parameters (K, T, R) that reach a target recall with the fewest candidates.

    The paper learns K and T from the data for its epsilon (GRASP §V); here recall@k is measured
    against exact search on held-out queries for a grid of K and T, and the (K, T) that reaches
    `options.target_recall` with the fewest distinct candidates scanned is chosen. Then the re-rank
    buffer R: the smallest power of two >= the 99th percentile of distinct candidates that keeps the
    target (else R = T C). For each K one index with max(T grid) tables is built and the first t
    tables are used for each t, so the grid costs one build per K.

    Args:
        key: a `jax.random` key.
        data: (N, D) the database.
        queries: (Q, D) held-out queries, not in `data`.
        k: the number of neighbours the index will be asked for.
        options: the grids, the target recall and the query settings (`TuneOptions`).
        truth: (Q, k) the exact neighbour ids of `queries`, if already known.

    Returns:
        A `TuneResult`.

    Raises:
        ValueError: naming the argument for a key that is not a `jax.random` key, empty or
            non-finite data or queries, |values| > 2^60 / sqrt(D), k outside [1, N], options that
            are not a `TuneOptions`, or min(n_tables_grid) * n_per_table < k (`n_per_table`).
    """
    check_key(key, "key")
    data = check_feature_range(as_array(data, "data", ndim=2, dtype=np.float32), "data")
    q = check_feature_range(as_array(queries, "queries", shape=(None, data.shape[1]), dtype=np.float32), "queries")
    check_int(k, "k", min_value=1, max_value=data.shape[0])
    if not isinstance(options, TuneOptions):
        raise ValueError(f"options: expected a TuneOptions, got {type(options).__name__}")
    n_bits_grid, n_tables_grid = options.n_bits_grid, options.n_tables_grid
    n_per_table, table_bits, n_probes = options.n_per_table, options.table_bits, options.n_probes
    check_slots(k, min(n_tables_grid), n_per_table)
    if truth is None:
        truth = np.asarray(exact_search_checked(jnp.asarray(data), q, k).indices)
    else:
        truth = as_array(truth, "truth", shape=(q.shape[0], k), dtype=np.int64, min_value=-1,
                         max_value=data.shape[0] - 1)
    t_max = max(n_tables_grid)
    chunk = max(1, min(q.shape[0], 16))
    qj = jnp.asarray(q)
    rows = []
    for i, n_bits in enumerate(n_bits_grid):  # a grid search: one build per K
        index = build_index_one_device(jax.random.fold_in(key, i), data, n_bits, t_max, table_bits)
        for t in sorted(n_tables_grid):  # the first t tables, masked: one compiled query for all t
            res = query_chunks(index, qj, k, n_per_table, jnp.int32(t), t_max * n_per_table * (1 + n_probes), chunk,
                               n_probes)
            rows.append((int(n_bits), int(t), recall_at_k(res.indices, truth), float(np.mean(res.n_scanned))))
    ok = [r for r in rows if r[2] >= options.target_recall]
    best = min(ok, key=lambda r: r[3]) if ok else max(rows, key=lambda r: (r[2], -r[3]))
    K, T, recall, scanned = best
    R = T * n_per_table * (1 + n_probes)
    if ok:
        index = build_index_one_device(jax.random.fold_in(key, list(n_bits_grid).index(K)), data, K, t_max,
                                       table_bits)
        res = query_one_device(index, q, k, n_per_table, T, n_probes=n_probes)
        r_try = int(2 ** np.ceil(np.log2(max(k, np.percentile(np.asarray(res.n_scanned), 99)))))
        if r_try < R:
            res = query_one_device(index, q, k, n_per_table, T, max_rerank=r_try, n_probes=n_probes)
            rec = recall_at_k(res.indices, truth)
            if rec >= options.target_recall:
                R, recall, scanned = r_try, rec, float(np.mean(res.n_scanned))
    return TuneResult(K, T, n_per_table, R, recall, scanned, bool(ok), tuple(rows))
