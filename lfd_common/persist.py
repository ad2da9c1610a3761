"""Model persistence: one `.npz` per model, with a format tag, a kind, a schema version and the config.

Every library stores its models through `save_arrays` / `load_arrays`, so files look alike and every
failure (missing, truncated, corrupt, another kind of model, a newer schema) is a clear `ValueError`
(or `FileNotFoundError`) rather than a pickle error or a KeyError deep inside a loader.
"""
from __future__ import annotations

import json
import os
import tempfile
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

SCHEMA_VERSION = 1
_FORMAT = "lfd-jax"
_META_KEY = "__lfd_meta__"


def save_arrays(
    path: str | Path,
    kind: str,
    arrays: Mapping[str, Any],
    config: Mapping[str, Any] | None = None,
    schema_version: int = SCHEMA_VERSION,
) -> Path:
    """Write `arrays` (name -> array-like) and a JSON `config` to `path` (`.npz` is appended if absent).

    `kind` names the model type (e.g. "phmm_jax.HMM"); `load_arrays` checks it. The config must be
    JSON-serialisable (frozen dataclasses: pass `dataclasses.asdict(cfg)`). Returns the path written.
    """
    if not kind:
        raise ValueError("kind: expected a non-empty model kind string")
    if _META_KEY in arrays:
        raise ValueError(f"arrays: the name {_META_KEY!r} is reserved")
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_name(path.name + ".npz")
    meta = {
        "format": _FORMAT,
        "kind": kind,
        "schema_version": int(schema_version),
        "config": dict(config or {}),
    }
    try:
        meta_json = json.dumps(meta, sort_keys=True)
    except TypeError as err:
        raise ValueError(f"config: not JSON-serialisable ({err})") from err
    payload = {name: np.asarray(value) for name, value in arrays.items()}
    for name, value in payload.items():
        if value.dtype == object:
            raise ValueError(f"arrays[{name!r}]: object arrays cannot be stored (no pickles)")
    write_npz(path, **{_META_KEY: np.asarray(meta_json)}, **payload)
    return path


def write_npz(path, **arrays) -> Path:
    """`np.savez` to `path` atomically: written to a temporary file in the same folder, then renamed.

    Caches are shared by concurrent processes (the test suite runs on two pytest-xdist workers), and
    a reader must never see a half-written file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def load_arrays(
    path: str | Path, kind: str, max_schema_version: int = SCHEMA_VERSION
) -> tuple[dict[str, np.ndarray], dict[str, Any], int]:
    """Read a file written by `save_arrays` and return `(arrays, config, schema_version)`.

    Raises `FileNotFoundError` when the file is missing, and `ValueError` naming the file when it is
    truncated or corrupt, not an lfd-jax model, a model of another kind than `kind`, or written with
    a newer schema than `max_schema_version`.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"path: no such model file: {path}")
    try:
        with np.load(path, allow_pickle=False) as npz:
            contents = {name: npz[name] for name in npz.files}
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, KeyError) as err:
        raise ValueError(f"path: {path} is not a readable .npz model file (truncated or corrupt: {err})") from err
    if _META_KEY not in contents:
        raise ValueError(f"path: {path} is an .npz file but not an lfd-jax model (no metadata)")
    try:
        meta = json.loads(str(contents.pop(_META_KEY)))
    except json.JSONDecodeError as err:
        raise ValueError(f"path: {path} has corrupt metadata ({err})") from err
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT:
        raise ValueError(f"path: {path} is not an lfd-jax model file")
    if meta.get("kind") != kind:
        raise ValueError(f"path: {path} holds a {meta.get('kind')!r}, expected a {kind!r}")
    version = meta.get("schema_version")
    if not isinstance(version, int) or not 1 <= version <= max_schema_version:
        raise ValueError(
            f"path: {path} has schema version {version!r}; this lfd-jax reads versions 1..{max_schema_version}"
        )
    return contents, meta.get("config", {}), version
