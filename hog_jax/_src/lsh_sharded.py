"""Neighbour search over a database split by rows across a device mesh (one host or several):
exact search and the hyperplane LSH index of `lsh`, each shard holding N'/S rows.

Shapes: N database rows (N' padded to the mesh, S shards of n = N'/S rows), Q queries, D dims,
T tables, K bits, k neighbours.

The queries are broadcast to every shard; each shard finds its own k best (exact: the blocked scan
of `exact`; LSH: `lsh`'s query on its own tables), the shards' (Q, k) lists are gathered
(`jax.lax.all_gather`) and merged by one top-k, so every device ends with the global answer.
Row ids in results are rows of the whole (unpadded) database, processes in order.

The sharded LSH index hashes with the same hyperplanes as `hog_jax.build_index` with the same key,
through the mean of all rows (one jitted reduction over the split array), and padding rows go to bucket -1,
which no query reads. Each shard reads up to C slots of every bucket the query reads (its own and
`n_probes` neighbours) in each of its tables, so the candidates are the union of the shards'
buckets: the same set as one device's whenever no bucket holds more than C points (then the results
are equal), and a superset otherwise (the shards together read up to S C slots per bucket).
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh

from hog_jax._src.exact import N_BLOCK, Q_CHUNK, LSHResult, exact_blocks, check_queries
from hog_jax._src.lsh import LSHIndex, bucket_ids, check_slots, hash_codes, query_chunks
from lfd_common import check_int
from lfd_common import replicate, shard, sharded_call

__all__ = ["ShardedLSHIndex", "build_sharded_index", "exact_search_sharded", "query_sharded"]


class ShardedLSHIndex(NamedTuple):
    """An LSH index whose rows are split over `mesh`. `index` holds global arrays: planes (T, K, D),
    center (D,) and table_bits replicated; data (N', D) split by rows; keys and order (S T, n) (shard
    s's tables are rows s T .. s T + T - 1, their point ids local to the shard). `mask` (N',) is True
    on real rows (split like data), `row_ids` (N',) the row of the unpadded database of each padded
    row (-1 on padding, replicated), `n_rows` N."""

    index: LSHIndex
    mask: jax.Array
    row_ids: jax.Array
    n_rows: int
    mesh: Mesh


def _merge(idx, dist, k: int, axes):
    """Every shard's (Q, k_s) ids and distances -> the global k best, on every shard."""
    idx = jax.lax.all_gather(idx, axes, axis=1, tiled=True)
    dist = jax.lax.all_gather(dist, axes, axis=1, tiled=True)
    neg, sel = jax.lax.top_k(-dist, k)
    return jnp.take_along_axis(idx, sel, axis=1), -neg


def _merge_local(idx, dist, mask, k: int, axes):
    """Shard-local ids (Q, k_s) (-1: none) and distances -> the global k best as padded global ids;
    padding rows never count."""
    ok = (idx >= 0) & mask[jnp.maximum(idx, 0)]
    idx = jnp.where(ok, idx + jax.lax.axis_index(axes) * mask.shape[0], -1)
    return _merge(idx, jnp.where(ok, dist, jnp.inf), k, axes)


def _unpadded(row_ids, idx):
    """Padded global ids (Q, k) -> rows of the unpadded database (-1 stays -1)."""
    return jnp.where(idx >= 0, row_ids[jnp.maximum(idx, 0)], -1).astype(jnp.int32)


def _exact_shard(queries, data, mask, *, k: int, axes):
    n = data.shape[0]
    sq = jnp.where(mask, jnp.sum(data * data, axis=1), jnp.inf)
    idx, d = exact_blocks(data, sq, queries, min(k, n), min(queries.shape[0], Q_CHUNK), min(n, N_BLOCK))
    return _merge_local(idx, d, mask, k, axes)


def exact_search_sharded(data: np.ndarray, queries: np.ndarray, k: int, mesh: Mesh) -> LSHResult:
    """`hog_jax.exact_search` on checked (N, D) float32 `data` (this process's rows) and (Q, D) `queries`
    (the same on every process), the rows split over `mesh`: equal to the one-device result."""
    batch = shard(mesh, data)
    idx, d = sharded_call(_exact_shard, mesh, (queries,), (*batch.arrays, batch.mask),
                          static=(("k", k), ("axes", tuple(mesh.axis_names))), out_batched=False)
    n_rows = int(np.sum(batch.row_ids >= 0))
    return LSHResult(_unpadded(replicate(mesh, batch.row_ids), idx), d,
                     jnp.full((queries.shape[0],), n_rows, jnp.int32))


@jax.jit
def _masked_mean(data, mask):
    """The mean (D,) of the rows of data (N', D) where mask (N',) is True."""
    w = mask.astype(data.dtype)
    return w @ data / jnp.sum(w)


def _build_shard(planes, center, table_bits, key_data, data, mask, *, chunk: int, axes):
    """This shard's tables: keys and order (T, n), its padding rows in bucket -1."""
    n, D = data.shape
    n_chunks = -(-n // chunk)
    padded = jnp.concatenate([data, jnp.zeros((n_chunks * chunk - n, D), data.dtype)])
    codes = jax.lax.map(lambda x: hash_codes(x, planes, center), padded.reshape(n_chunks, chunk, D))
    codes = jnp.moveaxis(codes, 0, 1).reshape(planes.shape[0], n_chunks * chunk)[:, :n]
    buckets = jnp.where(mask, bucket_ids(codes, planes.shape[1], table_bits), -1)
    key = jax.random.fold_in(jax.random.wrap_key_data(key_data), jax.lax.axis_index(axes))
    perm = jax.random.permutation(key, n).astype(jnp.int32)  # random order inside a bucket
    pos = jnp.argsort(buckets[:, perm], axis=1, stable=True)
    return jnp.take_along_axis(buckets[:, perm], pos, axis=1), perm[pos]


def build_sharded_index(key, data: np.ndarray, n_bits: int, n_tables: int, table_bits: int,
                        mesh: Mesh) -> ShardedLSHIndex:
    """`hog_jax.build_index` (the same hyperplanes for the same key) on checked (N, D) float32 `data`
    (this process's rows), the rows split over `mesh`; see the module docstring."""
    batch = shard(mesh, data)
    (x,), mask = batch.arrays, batch.mask
    k_planes, k_perm = jax.random.split(key)
    planes = replicate(mesh, jax.random.normal(k_planes, (n_tables, n_bits, data.shape[1]), jnp.float32))
    center = _masked_mean(x, mask)
    bits = replicate(mesh, jnp.int32(table_bits))
    n = x.shape[0] // mesh.size
    static = (("chunk", max(1, min(n, (1 << 22) // (n_tables * n_bits)))), ("axes", tuple(mesh.axis_names)))
    keys, order = sharded_call(_build_shard, mesh, (planes, center, bits, jax.random.key_data(k_perm)), (x, mask),
                               static=static)
    return ShardedLSHIndex(LSHIndex(planes, center, x, keys, order, bits), mask, replicate(mesh, batch.row_ids),
                           int(np.sum(batch.row_ids >= 0)), mesh)


def _query_shard(planes, center, table_bits, queries, n_tables_used, data, keys, order, mask, *, k: int,
                 n_per_table: int, n_rerank: int, chunk: int, n_probes: int, axes):
    res = query_chunks(LSHIndex(planes, center, data, keys, order, table_bits), queries, min(k, data.shape[0]),
                 n_per_table, n_tables_used, n_rerank, chunk, n_probes)
    idx, dist = _merge_local(res.indices, res.distances, mask, k, axes)
    return idx, dist, jax.lax.psum(res.n_scanned, axes)


def query_sharded(index: ShardedLSHIndex, queries, k: int = 10, n_per_table: int = 64, n_tables: int | None = None,
                  max_rerank: int | None = None, n_probes: int = 0) -> LSHResult:
    """`hog_jax.query` on a `ShardedLSHIndex` (the same arguments, checks and result; `hog_jax.query`
    hands a sharded index here). `max_rerank` bounds each shard's re-ranked candidates; n_scanned sums
    the shards' (equal to one device's when no bucket holds more than C points)."""
    ix, mesh = index.index, index.mesh
    q, single = check_queries(queries, ix.data.shape[1])
    check_int(k, "k", min_value=1, max_value=index.n_rows)
    check_int(n_per_table, "n_per_table", min_value=1)
    T = ix.planes.shape[0]
    n_tables = T if n_tables is None else check_int(n_tables, "n_tables", min_value=1, max_value=T)
    n_probes = check_int(n_probes, "n_probes", min_value=0, max_value=ix.planes.shape[1])
    check_slots(k, n_tables, n_per_table)
    slots = n_tables * n_per_table * (1 + n_probes)
    R = slots if max_rerank is None else min(slots, check_int(max_rerank, "max_rerank", min_value=k))
    shared = (ix.planes, ix.center, ix.table_bits, q, jnp.int32(n_tables))
    static = (("k", k), ("n_per_table", n_per_table), ("n_rerank", R), ("chunk", max(1, min(q.shape[0], 16))),
              ("n_probes", n_probes), ("axes", tuple(mesh.axis_names)))
    idx, dist, n = sharded_call(_query_shard, mesh, shared, (ix.data, ix.keys, ix.order, index.mask),
                                static=static, out_batched=False)
    res = LSHResult(_unpadded(index.row_ids, idx), dist, n)
    return LSHResult(*(a[0] for a in res)) if single else res
