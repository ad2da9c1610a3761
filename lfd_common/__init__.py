"""What every lfd-jax library shares, once: input validation, padded batches, log-space numerics,
rotations (quaternions (w, x, y, z), intrinsic Z-Y'-X'' Euler angles), model persistence, JAX set-up and
batches sharded over a device mesh (`lfd_common.sharding`, the `mesh=` option of every batch entry point).

The libraries (`phmm_jax`, `hog_jax`, `crf_jax`, `sim`) never import `experiments` or each other for
plumbing, so the little they share lives here.
"""
from lfd_common.batch import frame_mask, pad_sequences
from lfd_common.jaxsetup import cache_dir, enable_compilation_cache
from lfd_common.numerics import NEG_INF, float_dtype, safe_log, safe_logaddexp, safe_logsumexp, solve_spd
from lfd_common.persist import (
    SCHEMA_VERSION,
    ArraySpec,
    ModelCodec,
    load_arrays,
    load_model,
    model_path,
    read_file,
    save_arrays,
    save_model,
    structure_from_json,
    structure_to_json,
    write_npz,
)
from lfd_common.rotations import (axis_angle_to_matrix, euler_zyx_to_quat, matrix_to_quat, quat_to_euler_zyx,
                                 quat_to_matrix)
from lfd_common.sharding import (ShardedBatch, batch_mesh, batch_spec, check_mesh, map_batch, pad_rows, replicate,
                                 shard, sharded_call, unshard)
from lfd_common.validate import as_array, check_choice, check_int, check_real

__all__ = [
    "axis_angle_to_matrix", "euler_zyx_to_quat", "matrix_to_quat", "quat_to_euler_zyx", "quat_to_matrix",
    "NEG_INF", "SCHEMA_VERSION", "ArraySpec", "ModelCodec", "as_array", "cache_dir", "check_choice",
    "check_int", "check_real", "enable_compilation_cache", "float_dtype", "frame_mask", "load_arrays",
    "load_model", "model_path", "pad_sequences", "read_file", "safe_log", "safe_logaddexp",
    "safe_logsumexp", "save_arrays", "save_model", "solve_spd", "structure_from_json", "structure_to_json",
    "write_npz", "ShardedBatch", "batch_mesh", "batch_spec", "check_mesh", "map_batch", "pad_rows", "replicate",
    "shard", "sharded_call", "unshard",
]
