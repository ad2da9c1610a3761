"""Batches sharded over a device mesh, on one host or several, with JAX's own runtime only
(`jax.sharding.Mesh`, `NamedSharding`, `jax.shard_map`, `jax.make_array_from_process_local_data`).

Every library's `mesh=` option goes through here: the batch axis (axis 0) is split over all axes of
the mesh. A batch that does not divide the mesh is padded outside `jit` with copies of its first row
(valid input, so the padded rows compute finite values) and a (B',) mask marks the real rows; per-row
results come back unpadded, reductions mask the padding inside (`shard_map` bodies get the mask).

Several processes (`jax.distributed.initialize`): each process passes its own part of the batch
(B_p rows); `shard` pads every part to the same size (the largest part, rounded up to the process's
number of mesh devices) and assembles the global array with `jax.make_array_from_process_local_data`;
per-row results come back as this process's rows, replicated results (a psum, a merged top-k) whole
on every process. The mesh's devices must be grouped by process, in process order (`batch_mesh`'s are).
Shapes: B rows of this process, B' padded global rows, S = mesh size.
"""
from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import jax
import numpy as np
from jax.experimental import multihost_utils
from jax.sharding import Mesh, NamedSharding, PartitionSpec

__all__ = ["ShardedBatch", "batch_mesh", "batch_spec", "check_mesh", "map_batch", "pad_rows", "replicate", "shard",
           "sharded_call", "unshard"]


def check_mesh(mesh: Any, name: str = "mesh") -> Mesh | None:
    """Check the `mesh=` option of a batch entry point.

    Args:
        mesh: A `jax.sharding.Mesh`, or None (no sharding).
        name: The argument name that errors start with.

    Returns:
        `mesh`.

    Raises:
        ValueError: Naming `name`, when it is not a Mesh or None, or its devices are not grouped by
            process in process order (the layout that `shard` assumes when several processes each
            load their own part).
    """
    if mesh is None:
        return None
    if not isinstance(mesh, Mesh):
        raise ValueError(f"{name}: expected a jax.sharding.Mesh or None, got {type(mesh).__name__}")
    owners = np.array([d.process_index for d in mesh.devices.flat])
    if np.any(np.diff(owners) < 0):
        raise ValueError(f"{name}: its devices must be grouped by process in process order "
                         "(build it with lfd_common.batch_mesh)")
    return mesh


def batch_mesh(n_devices: int | None = None, axis_name: str = "batch") -> Mesh:
    """A 1-D mesh over the first devices of `jax.devices()` (all processes' devices), for `mesh=`.

    Args:
        n_devices: How many devices; None: all.
        axis_name: The mesh's one axis name.

    Returns:
        The `jax.sharding.Mesh`, its devices grouped by process in process order.

    Raises:
        ValueError: Naming `n_devices`, outside [1, number of devices].
    """
    devices = jax.devices()
    n = len(devices) if n_devices is None else n_devices
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or not 1 <= n <= len(devices):
        raise ValueError(f"n_devices: expected an int in [1, {len(devices)}], got {n_devices!r}")
    return Mesh(np.array(devices[:n]), (axis_name,))


def batch_spec(mesh: Mesh) -> PartitionSpec:
    """The partition of a batch over a mesh.

    Args:
        mesh: The mesh.

    Returns:
        The `PartitionSpec` splitting axis 0 over every axis of `mesh` (the other axes are not
        split).
    """
    return PartitionSpec(tuple(mesh.axis_names))


def _local_devices(mesh: Mesh) -> int:
    return sum(d.process_index == jax.process_index() for d in mesh.devices.flat)


class ShardedBatch(NamedTuple):
    """A batch laid out on a mesh (from `shard`).

    Attributes:
        arrays: Each a (B', ...) global jax array split along axis 0.
        mask: (B',) bool, True on real rows.
        n_local: B, this process's real rows.
        row_ids: (B',) int64 numpy: each padded row's index in the unpadded global batch
            (processes in order), -1 on padding.
    """

    arrays: tuple
    mask: jax.Array
    n_local: int
    row_ids: np.ndarray


def _global(mesh: Mesh, spec: PartitionSpec, local: np.ndarray) -> jax.Array:
    """This process's part (or, for the replicated spec, the whole value) -> a global array on `mesh`."""
    sharding = NamedSharding(mesh, spec)
    if jax.process_count() == 1:
        return jax.device_put(local, sharding)
    split = spec != PartitionSpec()
    rows = local.shape[0] * mesh.size // _local_devices(mesh) if split else None
    global_shape = (rows,) + local.shape[1:] if split else local.shape
    return jax.make_array_from_process_local_data(sharding, local, global_shape)


def pad_rows(arrays: Sequence[Any], size: int) -> tuple[np.ndarray, ...]:
    """Pad arrays to a number of rows with copies of their row 0 (valid input, finite results).

    Args:
        arrays: Each (B, ...), the same B.
        size: The rows wanted, >= B.

    Returns:
        Each array as numpy with `size` rows (not copied when B = size).
    """
    arrays = [np.asarray(a) for a in arrays]
    return tuple(a if a.shape[0] == size else np.concatenate([a, np.broadcast_to(a[:1], (size - a.shape[0],) + a.shape[1:])])
                 for a in arrays)


def shard(mesh: Mesh, *arrays: Any) -> ShardedBatch:
    """Pad this process's rows and split them over `mesh`.

    Padding copies row 0 (outside jit, `pad_rows`); `mask` marks the real rows. With several
    processes every part is padded to the same size so that the global batch divides the mesh.

    Args:
        mesh: The mesh.
        *arrays: Each (B, ...), the same B: this process's rows.

    Returns:
        The `ShardedBatch`.
    """
    n = np.shape(arrays[0])[0]
    per_process = _local_devices(mesh)
    counts = np.array([n])
    if jax.process_count() > 1:
        counts = np.asarray(multihost_utils.process_allgather(np.int64(n))).reshape(-1)
    size = -(-int(counts.max()) // per_process) * per_process
    spec = batch_spec(mesh)
    padded = tuple(_global(mesh, spec, a) for a in pad_rows(arrays, size))
    mask = _global(mesh, spec, np.arange(size) < n)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    blocks = np.arange(size)[None, :] + starts[:, None]
    row_ids = np.where(np.arange(size)[None, :] < counts[:, None], blocks, -1).reshape(-1)
    return ShardedBatch(padded, mask, n, row_ids)


def replicate(mesh: Mesh, tree: Any) -> Any:
    """Replicate every leaf of a pytree over a mesh.

    Args:
        mesh: The mesh.
        tree: A pytree, the same on every process.

    Returns:
        The pytree with every leaf a jax array replicated over `mesh`.
    """
    sharding = NamedSharding(mesh, PartitionSpec())

    def put(leaf):
        if isinstance(leaf, jax.Array) and leaf.sharding == sharding:
            return leaf
        return _global(mesh, PartitionSpec(), np.asarray(leaf))

    return jax.tree.map(put, tree)


def unshard(mesh: Mesh, tree: Any, n_local: int) -> Any:
    """Per-row results of a sharded batch back to this process's real rows.

    Args:
        mesh: The mesh.
        tree: A pytree whose leaves are (B', ...), split like `shard`'s arrays.
        n_local: B, this process's real rows (`ShardedBatch.n_local`).

    Returns:
        The pytree with leaves (B, ...).
    """
    if jax.process_count() == 1:
        return jax.tree.map(lambda a: a[:n_local], tree)
    local = multihost_utils.global_array_to_host_local_array(tree, mesh, batch_spec(mesh))
    return jax.tree.map(lambda a: a[:n_local], local)


@functools.lru_cache(maxsize=None)
def _compiled(fn: Callable, mesh: Mesh, n_shared: int, n_batched: int, static: tuple, out_batched: bool):
    """The jitted `shard_map` of `fn` (see `sharded_call`), built once per arguments."""
    spec = batch_spec(mesh)
    body = functools.partial(fn, **dict(static)) if static else fn
    return jax.jit(jax.shard_map(body, mesh=mesh, in_specs=(PartitionSpec(),) * n_shared + (spec,) * n_batched,
                                 out_specs=spec if out_batched else PartitionSpec(), check_vma=False))


def sharded_call(fn: Callable, mesh: Mesh, shared: tuple, batched: tuple, *, static: tuple = (),
                 out_batched: bool = True) -> Any:
    """Run `fn(*shared, *batched, **static)` by `jax.shard_map` on every shard of `mesh`.

    Jitted once per fn, mesh and static options. `fn` sees its shard's rows (B'/S, ...) and may
    reduce over the mesh with `jax.lax.psum(x, tuple(mesh.axis_names))`. The map runs with
    `check_vma=False` (kernels written for one device, scans included, run as they are), so `fn`
    must not be differentiated through a collective: take gradients inside the shard, or let XLA
    partition a jitted function of the split arrays (as `crf_jax.fit_chain` does).

    Args:
        fn: The per-shard function (hashable).
        mesh: The mesh.
        shared: Arguments whose leaves are replicated.
        batched: Global arrays split along axis 0 (`ShardedBatch.arrays`, its mask).
        static: A tuple of (name, hashable value) keyword options.
        out_batched: Whether the results are per-row (returned as global padded arrays) or the
            same on every shard (returned replicated).

    Returns:
        `fn`'s results, global.
    """
    call = _compiled(fn, mesh, len(shared), len(batched), tuple(static), out_batched)
    return call(*replicate(mesh, tuple(shared)), *batched)


def map_batch(fn: Callable, mesh: Mesh, shared: tuple, batched: tuple, *, static: tuple = ()) -> Any:
    """Run a per-row function with the batch split over a mesh; equal to `fn` on one device.

    The batch is padded (`shard`), run by `sharded_call` and unpadded (`unshard`).

    Args:
        fn: The per-row function (hashable), `fn(*shared, *batched, **static)`.
        mesh: The mesh.
        shared: Arguments whose leaves are replicated.
        batched: This process's arrays, each (B, ...), the same B.
        static: A tuple of (name, hashable value) keyword options.

    Returns:
        `fn`'s per-row results for this process's B rows.
    """
    batch = shard(mesh, *batched)
    return unshard(mesh, sharded_call(fn, mesh, shared, batch.arrays, static=static), batch.n_local)
