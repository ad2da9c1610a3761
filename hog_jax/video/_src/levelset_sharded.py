"""`hog_jax.video.segment_video(..., mesh=)`: the videos split over a device mesh (`lfd_common.sharding`).

`sharded_kernel(mesh)` is a drop-in for `levelset_evolution.evolve_kernel` (same arguments:
structure, model, data (B, T, ...), phi0 (B, R, H, W), cold0, options, batched, frames): the B videos
are padded to the mesh with copies of video 0, each device runs `evolve_kernel` on its own videos,
the padding is cut off, so the result equals the one-device result. With several processes each
passes its own videos and gets its own back.
"""
from __future__ import annotations

import jax

from hog_jax.video._src.levelset_evolution import evolve_kernel
from lfd_common import check_mesh, map_batch

__all__ = ["sharded_kernel"]


def _shard(cold0, o, data, phi0, *, kernel, structure, model, frames: bool):
    """`kernel` on one shard's videos (B/S, T, ...), with a batch axis."""
    return kernel(structure, model, data, phi0, cold0, o, True, frames)


def sharded_kernel(mesh):
    """`evolve_kernel` with the videos split over `mesh`; ValueError naming `mesh` when it is not a
    `jax.sharding.Mesh`."""
    mesh = check_mesh(mesh)

    def run(structure, model, data, phi0, cold0, o, batched: bool, frames: bool):
        static = (("kernel", evolve_kernel), ("structure", structure), ("model", model), ("frames", frames))
        res = map_batch(_shard, mesh, (cold0, o), (data, phi0), static=static)
        return res if batched else jax.tree_util.tree_map(lambda a: a[0], res)

    return run
