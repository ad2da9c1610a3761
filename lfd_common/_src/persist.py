"""Persistence: one `.npz` per model or data set, with a format tag, a kind, a schema version and JSON.

Two layers:
- `save_arrays` / `load_arrays`: named arrays plus a JSON config under a kind (data-set caches use
  this directly);
- `save_model` / `load_model`: a model = a static *structure* (frozen dataclass, stored as JSON) plus
  a parameters pytree (flattened by `jax.tree_util.tree_flatten_with_path`, one array per leaf). Each
  library describes its model types once with a `ModelCodec`; `load_model` finds the codec from the
  kind stored in the file (never by trying and matching error text), rebuilds the structure, checks
  every array against the shapes the structure implies (`ArraySpec`), and runs the codec's own
  semantic check (for example positive-definite covariances).

Every failure (missing, truncated or corrupt file, another kind, a newer schema, arrays that disagree
with the structure) is a `ValueError` (or `FileNotFoundError`) naming the file, never a pickle error or
a `KeyError` deep inside a loader. `save*` and `load*` map a path the same way (`.npz` is appended when
the name lacks it), so the path string given to `save` always loads.
"""
from __future__ import annotations

import dataclasses
import json
import os
import tempfile
import types
import typing
import zipfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import jax
import numpy as np

from lfd_common._src.numerics import float_dtype

SCHEMA_VERSION = 1
"""The schema version `save_arrays` writes; readers accept 1..their `max_schema_version`."""
_FORMAT = "lfd-jax"
_META_KEY = "__lfd_meta__"


def model_path(path: str | Path) -> Path:
    """The file `save_*` writes (and `load_*` reads) for `path`.

    Args:
        path: A file path.

    Returns:
        `path` itself if it ends in `.npz`, else `path + ".npz"`.

    Raises:
        ValueError: Naming `path`, when it is not a str or os.PathLike.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path: expected a file path (str or os.PathLike), got {type(path).__name__}")
    path = Path(path)
    return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")


def save_arrays(
    path: str | Path,
    kind: str,
    arrays: Mapping[str, Any],
    config: Mapping[str, Any] | None = None,
    schema_version: int = SCHEMA_VERSION,
) -> Path:
    """Write named arrays and a JSON config under a kind, atomically (no pickles).

    Args:
        path: The file (".npz" appended when missing, `model_path`).
        kind: Names what is stored (e.g. "phmm_jax.HMM"); `load_arrays` checks it.
        arrays: Name -> array-like.
        config: JSON-serialisable mapping (frozen dataclasses: pass `dataclasses.asdict(cfg)`), or
            None.
        schema_version: The version stored.

    Returns:
        The path written.

    Raises:
        ValueError: Naming the argument: an empty `kind`, `arrays` not a mapping, a reserved
            name, ragged or object arrays (`arrays[name]`), `config` not a JSON-serialisable
            mapping.
    """
    if not isinstance(kind, str) or not kind:
        raise ValueError("kind: expected a non-empty kind string")
    if not isinstance(arrays, Mapping):
        raise ValueError(f"arrays: expected a mapping of names to arrays, got {type(arrays).__name__}")
    if _META_KEY in arrays:
        raise ValueError(f"arrays: the name {_META_KEY!r} is reserved")
    if config is not None and not isinstance(config, Mapping):
        raise ValueError(f"config: expected a mapping, got {type(config).__name__}")
    path = model_path(path)
    meta = {"format": _FORMAT, "kind": kind, "schema_version": int(schema_version), "config": dict(config or {})}
    try:
        meta_json = json.dumps(meta, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as err:
        raise ValueError(f"config: not JSON-serialisable ({err})") from err
    payload = {}
    for name, value in arrays.items():
        try:
            payload[name] = np.asarray(value)
        except ValueError as err:  # ragged nested lists
            raise ValueError(f"arrays[{name!r}]: cannot be converted to an array ({err})") from err
        if payload[name].dtype == object:
            raise ValueError(f"arrays[{name!r}]: object arrays cannot be stored (no pickles)")
    write_npz(path, **{_META_KEY: np.asarray(meta_json)}, **payload)
    return path


def write_npz(path: str | Path, **arrays: Any) -> Path:
    """`np.savez` to `path` atomically: written to a temporary file in the same folder, then renamed.

    Caches are shared by concurrent processes (the test suite runs on two pytest-xdist workers), and
    a reader must never see a half-written file.

    Args:
        path: The file, written as given (its folder is created).
        **arrays: Name -> array.

    Returns:
        The path written.
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


def read_file(path: str | Path, max_schema_version: int = SCHEMA_VERSION
              ) -> tuple[str, dict[str, np.ndarray], dict[str, Any], int]:
    """Read any file written by `save_arrays`, whatever its kind.

    Args:
        path: The file (".npz" appended when missing).
        max_schema_version: The newest schema the caller reads.

    Returns:
        (kind, arrays (name -> numpy array), config (dict), schema_version).

    Raises:
        FileNotFoundError: The file is missing.
        ValueError: Naming the file, when it is truncated or corrupt, not an lfd-jax file, or
            written with a newer schema than `max_schema_version`.
    """
    path = model_path(path)
    if not path.exists():
        raise FileNotFoundError(f"path: no such model file: {path}")
    try:
        with open(path, "rb") as f:
            loaded = np.load(f, allow_pickle=False)
            if not isinstance(loaded, np.lib.npyio.NpzFile):
                raise ValueError(f"path: {path} holds a plain .npy array, not an .npz model file")
            with loaded as npz:
                contents = {name: npz[name] for name in npz.files}
    except (zipfile.BadZipFile, EOFError, OSError, KeyError) as err:
        raise ValueError(f"path: {path} is not a readable .npz model file (truncated or corrupt: {err})") from err
    except ValueError as err:
        if str(err).startswith("path:"):
            raise
        raise ValueError(f"path: {path} is not a readable .npz model file (truncated or corrupt: {err})") from err
    if _META_KEY not in contents:
        raise ValueError(f"path: {path} is an .npz file but not an lfd-jax model (no metadata)")
    try:
        meta = json.loads(str(contents.pop(_META_KEY)))
    except json.JSONDecodeError as err:
        raise ValueError(f"path: {path} has corrupt metadata ({err})") from err
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT:
        raise ValueError(f"path: {path} is not an lfd-jax model file")
    version = meta.get("schema_version")
    if isinstance(version, bool) or not isinstance(version, int) or not 1 <= version <= max_schema_version:
        raise ValueError(
            f"path: {path} has schema version {version!r}; this lfd-jax reads versions 1..{max_schema_version}")
    config = meta.get("config", {})
    if not isinstance(config, dict):
        raise ValueError(f"path: {path} has corrupt metadata (config is a {type(config).__name__}, not a mapping)")
    kind = meta.get("kind")
    if not isinstance(kind, str):
        raise ValueError(f"path: {path} has corrupt metadata (no kind)")
    return kind, contents, config, version


def load_arrays(
    path: str | Path, kind: str, max_schema_version: int = SCHEMA_VERSION
) -> tuple[dict[str, np.ndarray], dict[str, Any], int]:
    """Read a file written by `save_arrays` under `kind`.

    Args:
        path: The file (".npz" appended when missing).
        kind: The kind the caller expects.
        max_schema_version: The newest schema the caller reads.

    Returns:
        (arrays (name -> numpy array), config (dict), schema_version).

    Raises:
        FileNotFoundError: The file is missing.
        ValueError: As `read_file` does, and naming the file when it holds another kind.
    """
    stored, arrays, config, version = read_file(path, max_schema_version)
    if stored != kind:
        raise ValueError(f"path: {model_path(path)} holds a {stored!r}, expected a {kind!r}")
    return arrays, config, version


# ------------------------------------------------------------------------------------------------
# Models: structure (JSON) + parameters pytree (arrays)
# ------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ArraySpec:
    """What one parameter array of a model must look like, given the model's structure.

    A `ModelCodec`'s template puts one at every array leaf.

    Attributes:
        shape: Sizes; an int must match exactly, a str names a size the structure does not fix
            (e.g. "D", the feature dimension) and must be the same wherever the name recurs in one
            model.
        dtype: "float" (loaded in the compute dtype, `float_dtype()`) or "int" (int32).
        finite: Floats must be finite; with False, -inf is allowed (log-probabilities of forbidden
            transitions) but NaN and +inf are not.
    """

    shape: tuple[int | str, ...]
    dtype: str = "float"
    finite: bool = True


@dataclasses.dataclass(frozen=True)
class ModelCodec:
    """How one model type is stored: each library describes its model types once with one.

    Attributes:
        kind: The name stored in the file ("phmm_jax.HMM").
        model_type: The class `save_model` accepts under this kind.
        structure_type: The frozen dataclass of the model's static structure (stored as JSON).
        structure_of: Model -> its structure.
        template: Structure -> the model with an `ArraySpec` at every array leaf (same pytree
            shape).
        check: Optional model -> None, raising `ValueError` for what shapes cannot express
            (positive-definite covariances, normalised distributions, the structure agreeing with
            the arrays).
    """

    kind: str
    model_type: type
    structure_type: type
    structure_of: Callable[[Any], Any]
    template: Callable[[Any], Any]
    check: Callable[[Any], None] | None = None


def _key_name(entry) -> str:
    for attr in ("name", "key", "idx"):
        if hasattr(entry, attr):
            return str(getattr(entry, attr))
    return str(entry)


def _leaf_names(tree, is_leaf=None) -> tuple[list[str], list[Any], Any]:
    leaves_with_path, treedef = jax.tree_util.tree_flatten_with_path(tree, is_leaf=is_leaf)
    names = ["/".join(_key_name(k) for k in path) or "value" for path, _ in leaves_with_path]
    return names, [leaf for _, leaf in leaves_with_path], treedef


def structure_to_json(structure: Any) -> dict:
    """A model's structure (a frozen dataclass, possibly nested) as a JSON-ready dict.

    Args:
        structure: A dataclass instance.

    Returns:
        Its fields as a dict (nested dataclasses as dicts).

    Raises:
        ValueError: Naming `structure`, when it is not a dataclass instance.
    """
    if not dataclasses.is_dataclass(structure) or isinstance(structure, type):
        raise ValueError(f"structure: expected a dataclass instance, got {type(structure).__name__}")
    return dataclasses.asdict(structure)


def _to_tuples(value):
    if isinstance(value, list):
        return tuple(_to_tuples(v) for v in value)
    return value


def _dataclass_in(hint) -> type | None:
    """The dataclass a field annotation names (directly or as `X | None`), if any."""
    if dataclasses.is_dataclass(hint):
        return hint
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        found = [a for a in typing.get_args(hint) if dataclasses.is_dataclass(a)]
        return found[0] if len(found) == 1 else None
    return None


def structure_from_json(structure_type: type, data: Any, name: str = "structure") -> Any:
    """Rebuild a (nested) frozen dataclass from `structure_to_json` output; JSON lists become tuples.

    Args:
        structure_type: The dataclass.
        data: The JSON object (a dict).
        name: What error messages start with.

    Returns:
        The `structure_type` instance; its own `__post_init__` has checked its values.

    Raises:
        ValueError: Naming `name`: `data` not an object, unknown or missing fields, or values the
            dataclass rejects.
    """
    if not isinstance(data, dict):
        raise ValueError(f"{name}: expected a JSON object, got {type(data).__name__}")
    fields = {f.name: f for f in dataclasses.fields(structure_type) if f.init}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise ValueError(f"{name}: unknown field(s) {unknown} for {structure_type.__name__}")
    hints = typing.get_type_hints(structure_type)
    values = {}
    for key, value in data.items():
        nested = _dataclass_in(hints.get(key))
        if nested is not None and value is not None:
            values[key] = structure_from_json(nested, value, f"{name}.{key}")
        else:
            values[key] = _to_tuples(value)
    try:
        return structure_type(**values)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name}: not a valid {structure_type.__name__} ({err})") from err


def _check_leaf(array: np.ndarray, spec: ArraySpec, name: str, sizes: dict[str, int]) -> np.ndarray:
    if array.ndim != len(spec.shape):
        raise ValueError(f"{name}: expected {len(spec.shape)} dimensions {spec.shape}, got shape {array.shape}")
    for want, got in zip(spec.shape, array.shape):
        if isinstance(want, str):
            want = sizes.setdefault(want, got)
        if want != got:
            raise ValueError(f"{name}: expected shape {spec.shape} (with {sizes}), got {array.shape}")
    if spec.dtype == "int":
        if not np.issubdtype(array.dtype, np.integer):
            raise ValueError(f"{name}: expected integers, got dtype {array.dtype}")
        return array.astype(np.int32)
    if not np.issubdtype(array.dtype, np.floating):
        raise ValueError(f"{name}: expected floating point, got dtype {array.dtype}")
    bad = np.isnan(array) | (array == np.inf) if not spec.finite else ~np.isfinite(array)
    if np.any(bad):
        what = "NaN or +inf" if not spec.finite else "NaN or infinite"
        raise ValueError(f"{name}: contains {int(bad.sum())} {what} value(s)")
    with np.errstate(over="ignore"):
        out = array.astype(float_dtype())
    if np.any(np.isinf(out) & ~np.isinf(array)):
        raise ValueError(f"{name}: values overflow {np.dtype(float_dtype()).name}")
    return out


def _checked_model(codec: ModelCodec, structure, arrays: Mapping[str, np.ndarray], where: str):
    """The model of `structure` built from `arrays`, every array checked against the codec's template."""
    is_spec = lambda x: isinstance(x, ArraySpec)  # noqa: E731
    names, specs, treedef = _leaf_names(codec.template(structure), is_leaf=is_spec)
    missing = [n for n in names if n not in arrays]
    extra = sorted(set(arrays) - set(names))
    if missing or extra:
        raise ValueError(f"{where}: arrays do not match a {codec.kind} of this structure "
                         f"(missing {missing}, unexpected {extra})")
    sizes: dict[str, int] = {}
    leaves = [_check_leaf(np.asarray(arrays[n]), s, f"{where} array {n!r}", sizes) for n, s in zip(names, specs)]
    model = jax.tree_util.tree_unflatten(treedef, [jax.numpy.asarray(a) for a in leaves])
    if codec.check is not None:
        try:
            codec.check(model)
        except ValueError as err:
            raise ValueError(f"{where}: {err}") from err
    return model


def _codec_for_type(model, codecs: Sequence[ModelCodec]) -> ModelCodec:
    for codec in codecs:
        if type(model) is codec.model_type:
            return codec
    raise ValueError(f"model: expected one of {[c.model_type.__name__ for c in codecs]}, got {type(model).__name__}")


def save_model(path: str | Path, model: Any, codecs: Sequence[ModelCodec]) -> Path:
    """Write a model: its kind, its structure as JSON and one array per parameter leaf.

    The model is checked as `load_model` would check it, so a file that `save_model` writes always loads.

    Args:
        path: The file (".npz" appended when missing, `model_path`).
        model: An instance of one of the codecs' model types.
        codecs: The library's `ModelCodec`s.

    Returns:
        The path written.

    Raises:
        ValueError: Naming `model`, when no codec takes its type or its arrays disagree with its
            structure (shapes, non-finite values, the codec's own check).
    """
    codec = _codec_for_type(model, codecs)
    structure = codec.structure_of(model)
    names, leaves, _ = _leaf_names(model)
    arrays = dict(zip(names, (np.asarray(leaf) for leaf in leaves)))
    _checked_model(codec, structure, arrays, "model")
    return save_arrays(path, codec.kind, arrays, {"structure": structure_to_json(structure)})


def load_model(path: str | Path, codecs: Sequence[ModelCodec]) -> Any:
    """Read a model written by `save_model`; the stored kind picks the codec.

    Every array is checked against the shapes the structure implies (`ArraySpec`), then the codec's
    own check runs.

    Args:
        path: The file (".npz" appended when missing).
        codecs: The library's `ModelCodec`s.

    Returns:
        The model, its arrays in the compute dtype.

    Raises:
        FileNotFoundError: The file is missing.
        ValueError: Naming the file, for a corrupt one, a kind none of `codecs` reads, a structure
            that does not validate, or arrays that disagree with it.
    """
    kind, arrays, config, _ = read_file(path)
    where = f"path: {model_path(path)}"
    by_kind = {c.kind: c for c in codecs}
    if kind not in by_kind:
        raise ValueError(f"{where} holds a {kind!r}, expected one of {sorted(by_kind)}")
    codec = by_kind[kind]
    if "structure" not in config:
        raise ValueError(f"{where} is an incomplete {kind} file (no structure)")
    structure = structure_from_json(codec.structure_type, config["structure"], f"{where} structure")
    return _checked_model(codec, structure, arrays, where)
