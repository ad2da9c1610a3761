"""Persistence of crf_jax models: `save(path, model)` / `load(path, model_type)`.

One `.npz` per model through `lfd_common.save_arrays` (kind "crf_jax.<Type>", schema version, the
shapes as JSON config). `load` checks the kind, that every array is present, finite and that the
shapes fit together, so a truncated, corrupt, wrong-kind or tampered file is a `ValueError`.
"""
from __future__ import annotations

from pathlib import Path

import jax.numpy as jnp
import numpy as np

from crf_jax.chain import ChainCRF
from crf_jax.fcrf import FCRF
from crf_jax.hcrf import HCRF
from crf_jax.linear import LinearModel
from lfd_common import load_arrays, save_arrays

SCHEMA_VERSION = 1
MODEL_TYPES = {cls.__name__: cls for cls in (ChainCRF, HCRF, FCRF, LinearModel)}


def _flatten(model, prefix: str = "") -> dict[str, np.ndarray]:
    out = {}
    for name, value in model._asdict().items():
        if hasattr(value, "_asdict"):
            out.update(_flatten(value, f"{prefix}{name}/"))
        else:
            out[prefix + name] = np.asarray(value)
    return out


def _shapes_ok(model) -> bool:
    if isinstance(model, ChainCRF):
        W, D, K = model.weights.shape if model.weights.ndim == 3 else (0, 0, 0)
        return (model.weights.ndim == 3 and W % 2 == 1 and model.bias.shape == (K,)
                and model.trans.shape == (K, K))
    if isinstance(model, HCRF):
        if model.weights.ndim != 4:
            return False
        W, D, K, H = model.weights.shape
        return W % 2 == 1 and model.bias.shape == (K, H) and model.trans.shape == (K, H, H)
    if isinstance(model, FCRF):
        return (_shapes_ok(model.action) and _shapes_ok(model.object)
                and model.action.weights.shape[:2] == model.object.weights.shape[:2]
                and model.coupling.shape == (model.action.n_labels, model.object.n_labels))
    if isinstance(model, LinearModel):
        return model.weights.ndim == 2 and model.bias.shape == (model.weights.shape[1],)
    return False


def save(path: str | Path, model) -> Path:
    """Write `model` (ChainCRF, HCRF, FCRF or LinearModel) to `path` (.npz appended if absent)."""
    name = type(model).__name__
    if name not in MODEL_TYPES:
        raise ValueError(f"model: expected one of {sorted(MODEL_TYPES)}, got {name}")
    arrays = _flatten(model)
    config = {"model": name, "shapes": {k: list(v.shape) for k, v in arrays.items()}}
    return save_arrays(path, f"crf_jax.{name}", arrays, config, schema_version=SCHEMA_VERSION)


def _build(cls, arrays: dict, prefix: str, path):
    fields = {}
    for name in cls._fields:
        sub = {"action": ChainCRF, "object": ChainCRF}.get(name) if cls is FCRF else None
        if sub is not None:
            fields[name] = _build(sub, arrays, f"{prefix}{name}/", path)
            continue
        key = prefix + name
        if key not in arrays:
            raise ValueError(f"path: {path} lacks the array {key!r} of a {cls.__name__}")
        arr = arrays[key]
        if not np.issubdtype(arr.dtype, np.floating) or not np.all(np.isfinite(arr)):
            raise ValueError(f"path: {path} array {key!r} is not finite floating point")
        fields[name] = jnp.asarray(arr, jnp.float32)
    return cls(**fields)


def load(path: str | Path, model_type: type | str):
    """Read a model written by `save`; `model_type` is the expected class (or its name)."""
    name = model_type if isinstance(model_type, str) else getattr(model_type, "__name__", repr(model_type))
    if name not in MODEL_TYPES:
        raise ValueError(f"model_type: expected one of {sorted(MODEL_TYPES)}, got {name!r}")
    arrays, config, _ = load_arrays(path, f"crf_jax.{name}", max_schema_version=SCHEMA_VERSION)
    model = _build(MODEL_TYPES[name], arrays, "", path)
    if not _shapes_ok(model):
        raise ValueError(f"path: {path} holds arrays whose shapes do not form a {name}")
    return model
