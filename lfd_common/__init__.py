"""lfd_common: what every lfd-jax library shares, once.

The libraries (`phmm_jax`, `hog_jax`, `crf_jax`, `sim`) never import `experiments` or each other for
plumbing, so the little they share lives here:

- Input validation at public boundaries (`ValueError` naming the argument): `as_array`,
  `check_int`, `check_real`, `check_choice`; padded batches: `pad_sequences`, `frame_mask`.
- Log-space numerics with finite gradients at log 0: `safe_log`, `safe_logsumexp`,
  `safe_logaddexp`, `NEG_INF`, `solve_spd`; the compute dtype: `float_dtype`.
- Rotations (quaternions (w, x, y, z), intrinsic Z-Y'-X'' Euler angles): `quat_to_matrix`,
  `matrix_to_quat`, `euler_zyx_to_quat`, `quat_to_euler_zyx`, `axis_angle_to_matrix`.
- Model persistence (kind + structure JSON + arrays, checked on load): `save_model`, `load_model`,
  `ModelCodec`, `ArraySpec`; named arrays: `save_arrays`, `load_arrays`, `read_file`.
- Batches sharded over a device mesh (the `mesh=` option of every batch entry point): `batch_mesh`,
  `check_mesh`, `shard`, `unshard`, `map_batch`, `sharded_call`.
- Progress bars and markdown tables for people: `progress`, `markdown_table`.
- One content-keyed cache (`cached`, `Cache`) and JAX set-up (`cache_dir`, `enable_compilation_cache`).

Example:
    ```python
    import numpy as np
    from lfd_common import check_real, pad_sequences

    X, lengths = pad_sequences([np.zeros((5, 3)), np.ones((7, 3))])  # X (2, 7, 3), lengths [5, 7]
    sigma = check_real(0.1, "sigma", min_value=0.0)                   # ValueError naming "sigma" if bad
    ```
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
from lfd_common._src.text import markdown_table, progress
from lfd_common._src.validate import as_array, check_choice, check_int, check_real

__all__ = [
    "Cache", "CacheWarning", "cache_disabled", "cached", "clear_source_digests", "source_digest",
    "ArraySpec", "ModelCodec", "NEG_INF", "SCHEMA_VERSION", "ShardedBatch", "as_array", "axis_angle_to_matrix", "batch_mesh",
    "batch_spec", "cache_dir", "check_choice", "check_int", "check_mesh", "check_real", "enable_compilation_cache", "euler_zyx_to_quat",
    "float_dtype", "frame_mask", "load_arrays", "load_model", "map_batch", "matrix_to_quat", "model_path", "pad_rows",
    "pad_sequences", "quat_to_euler_zyx", "quat_to_matrix", "read_file", "replicate", "safe_log", "safe_logaddexp", "safe_logsumexp",
    "save_arrays", "save_model", "shard", "sharded_call", "solve_spd", "structure_from_json", "structure_to_json", "unshard",
    "write_npz", "markdown_table", "progress",
]
