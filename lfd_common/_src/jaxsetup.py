"""Cache directories and JAX's persistent compilation cache.

Compile time dominates short runs (tests, quick presets), so scripts and the test suite call
`enable_compilation_cache()` once at start-up. Libraries never change global JAX state on import.
"""
from __future__ import annotations

import os
from pathlib import Path

import jax

_CACHE_ENV = "LFD_JAX_CACHE"


def cache_dir(*parts: str) -> Path:
    """Return (and create) a directory under the project cache root.

    The root is `$LFD_JAX_CACHE` when set, else `~/.cache/lfd-jax`. Generated data sets and the
    compilation cache live here; nothing under it is ever committed.

    Args:
        *parts: Path components below the root.

    Returns:
        The directory, created if missing.
    """
    root = Path(os.environ.get(_CACHE_ENV, Path.home() / ".cache" / "lfd-jax"))
    path = root.joinpath(*parts)
    path.mkdir(parents=True, exist_ok=True)
    return path


def enable_compilation_cache(min_compile_time_s: float = 0.2) -> Path:
    """Turn on JAX's persistent compilation cache in `cache_dir("jax")`.

    Programs that take longer than `min_compile_time_s` to compile are written to disk and reused
    by later processes with the same JAX version, backend and program. Scripts and the test suite
    call it once at start-up; libraries never do.

    Args:
        min_compile_time_s: Compile time (seconds) above which a program is cached.

    Returns:
        The cache directory.
    """
    path = cache_dir("jax")
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", float(min_compile_time_s))
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return path
