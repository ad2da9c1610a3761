"""What every lfd-jax library shares, once: input validation, padded batches, log-space numerics,
rotations (quaternions (w, x, y, z), intrinsic Z-Y'-X'' Euler angles), model persistence, JAX set-up and
batches sharded over a device mesh (`lfd_common.sharding`, the `mesh=` option of every batch entry point).

The libraries (`phmm_jax`, `hog_jax`, `crf_jax`, `sim`) never import `experiments` or each other for
plumbing, so the little they share lives here.
"""
from lfd_common._src.batch import frame_mask, pad_sequences
from lfd_common._src.cache import (Cache, CacheWarning, cache_disabled, cached, clear_source_digests,
                                   source_digest)
from lfd_common._src.jaxsetup import cache_dir, enable_compilation_cache
from lfd_common._src.numerics import NEG_INF, float_dtype, safe_log, safe_logaddexp, safe_logsumexp, solve_spd
from lfd_common._src.persist import (ArraySpec, ModelCodec, SCHEMA_VERSION, load_arrays, load_model,
                                     model_path, read_file, save_arrays, save_model, structure_from_json,
                                     structure_to_json, write_npz)
from lfd_common._src.rotations import (axis_angle_to_matrix, euler_zyx_to_quat, matrix_to_quat,
                                       quat_to_euler_zyx, quat_to_matrix)
from lfd_common._src.sharding import (ShardedBatch, batch_mesh, batch_spec, check_mesh, map_batch, pad_rows,
                                      replicate, shard, sharded_call, unshard)
from lfd_common._src.validate import as_array, check_choice, check_int, check_real

__all__ = [
    "Cache", "CacheWarning", "cache_disabled", "cached", "clear_source_digests", "source_digest",
    "ArraySpec", "ModelCodec", "NEG_INF", "SCHEMA_VERSION", "ShardedBatch", "as_array", "axis_angle_to_matrix", "batch_mesh",
    "batch_spec", "cache_dir", "check_choice", "check_int", "check_mesh", "check_real", "enable_compilation_cache", "euler_zyx_to_quat",
    "float_dtype", "frame_mask", "load_arrays", "load_model", "map_batch", "matrix_to_quat", "model_path", "pad_rows",
    "pad_sequences", "quat_to_euler_zyx", "quat_to_matrix", "read_file", "replicate", "safe_log", "safe_logaddexp", "safe_logsumexp",
    "save_arrays", "save_model", "shard", "sharded_call", "solve_spd", "structure_from_json", "structure_to_json", "unshard",
    "write_npz",
]
