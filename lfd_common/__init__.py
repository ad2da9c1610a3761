"""Helpers shared by every lfd-jax library: input validation, model persistence, JAX set-up.

The four libraries (`phmm_jax`, `hog_jax`, `crf_jax`, `sim`) must not import `experiments` or each
other for plumbing, so the little they share lives here.
"""
from lfd_common.jaxsetup import cache_dir, enable_compilation_cache
from lfd_common.persist import SCHEMA_VERSION, load_arrays, save_arrays, write_npz
from lfd_common.validate import as_array, check_choice, check_int, check_real

__all__ = [
    "SCHEMA_VERSION",
    "as_array",
    "cache_dir",
    "check_choice",
    "check_int",
    "check_real",
    "enable_compilation_cache",
    "load_arrays",
    "save_arrays",
    "write_npz",
]
