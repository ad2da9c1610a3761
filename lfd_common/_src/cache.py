"""One content-keyed on-disk cache for generated data sets, trained models and study stages.

An entry is keyed by a SHA-256 of
- the cache's name and version,
- the arguments, by content (JSON values, tuples, lists, str-keyed dicts, dataclasses, NamedTuples,
  numpy and JAX arrays, nested),
- the source of every module of the packages the cached computation depends on: every `.py` file
  under each declared package's directory (sorted relative paths and bytes), read once per process,
so a stored result is never reused after an edit anywhere in a declared package or with other
arguments. What the key cannot see is what the caller does not declare: third-party libraries (bump
`version` when an upgrade changes results) and data files other than `.py` sources.

Values are one `.npz` per entry, written atomically (a temporary file in the same folder, then
renamed) because concurrent processes share the cache, and read without pickles: arrays, numpy
scalars, Python scalars, strings, None, and tuples, lists, str-keyed dicts, NamedTuples and
dataclasses of them, nested. NamedTuples and dataclasses are rebuilt from their class (imported by
module and qualified name) with their fields as keyword arguments, so their own validation runs.
A truncated or corrupt entry is a miss: it is recomputed and rewritten with a `CacheWarning`.

Entries live under `cache_dir(name)` (`$LFD_JAX_CACHE`, else `~/.cache/lfd-jax`); setting
`LFD_JAX_NO_CACHE=1` computes every value afresh and neither reads nor writes entries.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import importlib.util
import inspect
import json
import math
import os
import re
import tempfile
import warnings
import zipfile
import zlib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import jax
import numpy as np

from lfd_common._src.jaxsetup import cache_dir

T = TypeVar("T")

_NO_CACHE_ENV = "LFD_JAX_NO_CACHE"
_FORMAT = "lfd-jax-cache-1"  # part of every key: a change of the stored layout never reads old entries
_META = "__cache__"
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")
_DOTTED = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")
_KEY_TYPES = ("None, bool, int, float, str, tuples, lists and str-keyed dicts of them, dataclasses, NamedTuples "
              "or arrays")
_DIGESTS: dict[str, str] = {}


class CacheWarning(UserWarning):
    """A stored cache entry could not be read (truncated or corrupt); it is recomputed and rewritten."""


def cache_disabled() -> bool:
    """Whether `LFD_JAX_NO_CACHE` is set (to anything but "" or "0"): every value is then computed afresh.

    Returns:
        True when the cache is bypassed.
    """
    return os.environ.get(_NO_CACHE_ENV, "") not in ("", "0")


# ------------------------------------------------------------------------------------------------
# Source digests
# ------------------------------------------------------------------------------------------------
def _source_files(package: str) -> list[tuple[str, Path]]:
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError) as err:
        raise ValueError(f"packages: cannot find {package!r} ({err})") from err
    if spec is None:
        raise ValueError(f"packages: no package or module named {package!r}")
    if spec.submodule_search_locations:
        files = []
        for root in map(Path, spec.submodule_search_locations):
            files += [(path.relative_to(root).as_posix(), path) for path in root.rglob("*.py")
                      if "__pycache__" not in path.relative_to(root).parts]
        return sorted(files)
    if spec.origin and Path(spec.origin).is_file():
        return [(Path(spec.origin).name, Path(spec.origin))]
    raise ValueError(f"packages: {package!r} has no source file (a built-in or frozen module)")


def source_digest(package: str) -> str:
    """SHA-256 of the source of a package (every `.py` file under its directories) or of one module.

    Computed once per process and package: a file edited while a program runs does not split that
    program's entries between two keys; the next process sees the edit.

    Args:
        package: a dotted package or module name ("hog_jax", "experiments.data.video", "sim.human_hand").

    Returns:
        The hex digest of the sorted relative paths and bytes of the package's `.py` files.

    Raises:
        ValueError: `package` is not a dotted name, cannot be found, or has no source file.
    """
    if not isinstance(package, str) or not _DOTTED.fullmatch(package):
        raise ValueError(f"packages: expected dotted package names, got {package!r}")
    if package not in _DIGESTS:
        digest = hashlib.sha256()
        for rel, path in _source_files(package):
            data = path.read_bytes()
            digest.update(b"%s\0%d\0" % (rel.encode(), len(data)) + data)
        _DIGESTS[package] = digest.hexdigest()
    return _DIGESTS[package]


def clear_source_digests() -> None:
    """Forget the source digests of this process, so the next key reads the sources again (as a new process would).

    Returns:
        None.
    """
    _DIGESTS.clear()


def _function_digest(fn: Callable) -> str:
    """The digest of the module that defines `fn`, or of `fn`'s own source where the module has no file."""
    try:
        return source_digest(fn.__module__)
    except ValueError:
        pass
    try:
        return hashlib.sha256(inspect.getsource(fn).encode()).hexdigest()
    except (OSError, TypeError) as err:
        raise ValueError(f"fn: the source of {fn.__qualname__} cannot be read, so it cannot be keyed ({err})") from err


# ------------------------------------------------------------------------------------------------
# Keys
# ------------------------------------------------------------------------------------------------
def _qualified(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _is_namedtuple(value) -> bool:
    return isinstance(value, tuple) and hasattr(type(value), "_fields")


def _array_part(array: np.ndarray, where: str) -> list:
    if array.dtype.hasobject:
        raise ValueError(f"{where}: object arrays cannot be part of a cache key")
    data = np.ascontiguousarray(array)
    return [data.dtype.str, list(data.shape), hashlib.sha256(data.view(np.uint8).reshape(-1)).hexdigest()]


def _key_part(value, where: str):
    """A JSON value that is equal for equal arguments and differs for unequal ones (types included)."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else {"float": repr(value)}
    if isinstance(value, np.ndarray):
        return {"array": _array_part(value, where)}
    if isinstance(value, np.generic):
        return {"scalar": _array_part(np.asarray(value), where)}
    if isinstance(value, jax.Array):
        try:
            array = np.asarray(value)
        except TypeError as err:  # typed PRNG keys and other extended dtypes
            raise ValueError(f"{where}: this JAX array cannot be part of a cache key ({err})") from err
        return {"array": _array_part(array, where)}
    if _is_namedtuple(value):
        return {"namedtuple": _qualified(type(value)),
                "fields": {f: _key_part(getattr(value, f), f"{where}.{f}") for f in value._fields}}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"dataclass": _qualified(type(value)),
                "fields": {f.name: _key_part(getattr(value, f.name), f"{where}.{f.name}")
                           for f in dataclasses.fields(value)}}
    if isinstance(value, (tuple, list)):
        items = [_key_part(v, f"{where}[{i}]") for i, v in enumerate(value)]
        return {"tuple": items} if isinstance(value, tuple) else items
    if isinstance(value, dict):
        for k in value:
            if not isinstance(k, str):
                raise ValueError(f"{where}: dict keys in a cache key must be strings, got {type(k).__name__}")
        return {"dict": {k: _key_part(v, f"{where}[{k!r}]") for k, v in value.items()}}
    raise ValueError(f"{where}: {type(value).__name__} cannot be part of a cache key (expected {_KEY_TYPES})")


# ------------------------------------------------------------------------------------------------
# Values
# ------------------------------------------------------------------------------------------------
def _store_array(array: np.ndarray, where: str, arrays: dict) -> int:
    if array.dtype.hasobject:
        raise ValueError(f"{where}: object arrays cannot be stored (no pickles)")
    arrays[f"a{len(arrays)}"] = array
    return len(arrays) - 1


def _encode(value, where: str, arrays: dict) -> dict:
    """The JSON description of `value`, its arrays appended to `arrays` (named a0, a1, ...)."""
    if value is None:
        return {"t": "none"}
    if isinstance(value, bool):
        return {"t": "bool", "v": value}
    if isinstance(value, int):
        return {"t": "int", "v": value}
    if isinstance(value, float):
        return {"t": "float", "v": value.hex()}
    if isinstance(value, str):
        return {"t": "str", "v": value}
    if isinstance(value, np.ndarray):
        return {"t": "array", "i": _store_array(value, where, arrays)}
    if isinstance(value, np.generic):
        return {"t": "scalar", "i": _store_array(np.asarray(value), where, arrays)}
    if isinstance(value, jax.Array):
        try:
            array = np.asarray(value)
        except TypeError as err:
            raise ValueError(f"{where}: this JAX array cannot be stored ({err})") from err
        return {"t": "jax", "i": _store_array(array, where, arrays)}
    if _is_namedtuple(value) or (dataclasses.is_dataclass(value) and not isinstance(value, type)):
        cls = type(value)
        if "<locals>" in cls.__qualname__:
            raise ValueError(f"{where}: a {cls.__qualname__} (defined inside a function) cannot be rebuilt on load")
        names = value._fields if _is_namedtuple(value) else [f.name for f in dataclasses.fields(value) if f.init]
        return {"t": "namedtuple" if _is_namedtuple(value) else "dataclass", "cls": _qualified(cls),
                "items": {n: _encode(getattr(value, n), f"{where}.{n}", arrays) for n in names}}
    if isinstance(value, (tuple, list)):
        return {"t": type(value).__name__, "items": [_encode(v, f"{where}[{i}]", arrays) for i, v in enumerate(value)]}
    if isinstance(value, dict):
        for k in value:
            if not isinstance(k, str):
                raise ValueError(f"{where}: dict keys must be strings to be stored, got {type(k).__name__}")
        return {"t": "dict", "items": {k: _encode(v, f"{where}[{k!r}]", arrays) for k, v in value.items()}}
    raise ValueError(f"{where}: {type(value).__name__} cannot be stored in the cache (expected arrays, scalars, "
                     "strings, None, or tuples, lists, str-keyed dicts, NamedTuples and dataclasses of them)")


def _import_class(name: str, kind: str) -> type:
    module, _, qualname = name.partition(":")
    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    ok = isinstance(obj, type) and (issubclass(obj, tuple) and hasattr(obj, "_fields") if kind == "namedtuple"
                                    else dataclasses.is_dataclass(obj))
    if not ok:
        raise ValueError(f"{name} is not a {kind}")
    return obj


def _decode(spec: dict, arrays: Mapping[str, np.ndarray]):
    kind = spec["t"]
    if kind in ("array", "scalar", "jax"):
        array = arrays[f"a{spec['i']}"]
        return array if kind == "array" else array[()] if kind == "scalar" else jax.numpy.asarray(array)
    simple = {"none": lambda v: None, "bool": bool, "int": int, "float": float.fromhex, "str": str}
    if kind in simple:
        return simple[kind](spec.get("v"))
    if kind in ("tuple", "list"):
        items = [_decode(s, arrays) for s in spec["items"]]
        return tuple(items) if kind == "tuple" else items
    if kind == "dict":
        return {k: _decode(s, arrays) for k, s in spec["items"].items()}
    if kind in ("namedtuple", "dataclass"):
        return _import_class(spec["cls"], kind)(**{k: _decode(s, arrays) for k, s in spec["items"].items()})
    raise ValueError(f"unknown entry type {kind!r}")


def _write_npz(path: Path, arrays: Mapping[str, np.ndarray], compress: bool) -> None:
    handle, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as f:
            (np.savez_compressed if compress else np.savez)(f, **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


# ------------------------------------------------------------------------------------------------
# The cache
# ------------------------------------------------------------------------------------------------
class Cache:
    """A named store of computed values, keyed by their arguments and the source they depend on.

    Example::

        _RENDERS = Cache("video", packages=("experiments.data.video", "sim"), version="video-v1",
                         compress=True)
        rec = _RENDERS.get(lambda: render(settings, script), settings=settings, script=script)

    Args:
        name: the folder under the cache root (`cache_dir(name)`); letters, digits, "_", "-", ".".
        packages: dotted names of every package (or module) whose code the value depends on; all their
            `.py` files are part of the key.
        version: part of the key; bump it for what the sources do not show (a library upgrade).
        compress: store with `np.savez_compressed` (images: several times smaller, slower to write).
        encode: optional value -> storable value (see the module docstring), applied before storing.
        decode: optional inverse of `encode`, applied after loading.

    Raises:
        ValueError: an argument has the wrong type or form (the message names it).
    """

    def __init__(self, name: str, packages: Sequence[str] = (), version: int | str = 1, *, compress: bool = False,
                 encode: Callable[[Any], Any] | None = None, decode: Callable[[Any], Any] | None = None):
        if not isinstance(name, str) or not _NAME.fullmatch(name) or name in (".", ".."):
            raise ValueError(f"name: expected a folder name (letters, digits, '_', '-', '.'), got {name!r}")
        if isinstance(packages, str) or not isinstance(packages, Sequence):
            raise ValueError(f"packages: expected a tuple of package names, got {packages!r}")
        for package in packages:
            if not isinstance(package, str) or not _DOTTED.fullmatch(package):
                raise ValueError(f"packages: expected dotted package names, got {package!r}")
        if isinstance(version, bool) or not isinstance(version, (int, str)):
            raise ValueError(f"version: expected an int or a str, got {type(version).__name__}")
        for label, hook in (("encode", encode), ("decode", decode)):
            if hook is not None and not callable(hook):
                raise ValueError(f"{label}: expected a callable or None, got {type(hook).__name__}")
        self.name, self.packages, self.version = name, tuple(packages), version
        self.compress, self.encode, self.decode = bool(compress), encode, decode
        self._function: Callable | None = None  # set by `cached`: its module is part of the key

    def __repr__(self) -> str:
        return f"Cache({self.name!r}, packages={self.packages!r}, version={self.version!r})"

    @property
    def directory(self) -> Path:
        """The folder that holds this cache's entries (created when missing)."""
        return cache_dir(self.name)

    def key(self, /, **args) -> str:
        """The key of the entry for `args`.

        Args:
            **args: what the value depends on besides the declared packages' source.

        Returns:
            A SHA-256 hex digest of the name, version, arguments and the declared packages' source.

        Raises:
            ValueError: an argument (named in the message, with its path inside nested values) is of a
                type a key cannot hold, or a declared package cannot be found.
        """
        parts = {name: _key_part(value, name) for name, value in args.items()}
        sources = {package: source_digest(package) for package in self.packages}
        if self._function is not None:
            fn = self._function
            sources[f"{fn.__module__}:{fn.__qualname__}"] = _function_digest(fn)
        blob = json.dumps({"format": _FORMAT, "name": self.name, "version": self.version, "sources": sources,
                           "args": parts}, sort_keys=True, allow_nan=False, separators=(",", ":"))
        return hashlib.sha256(blob.encode()).hexdigest()

    def path(self, /, **args) -> Path:
        """The file of the entry for `args` (it may not exist yet).

        Args:
            **args: as for `key`.

        Returns:
            `cache_dir(name) / "<key>.npz"` (the first 32 hex digits of the key).

        Raises:
            ValueError: as `key` does.
        """
        return self.directory / f"{self.key(**args)[:32]}.npz"

    def save(self, path: str | Path, value) -> Path:
        """Store `value` at `path`, atomically.

        Args:
            path: the entry's file (from `path`).
            value: a storable value (after `encode`, if given).

        Returns:
            The path written.

        Raises:
            ValueError: part of `value` (named in the message) cannot be stored.
        """
        path = Path(path)
        arrays: dict[str, np.ndarray] = {}
        spec = _encode(self.encode(value) if self.encode else value, "value", arrays)
        meta = json.dumps({"format": _FORMAT, "cache": self.name, "value": spec}, sort_keys=True)
        path.parent.mkdir(parents=True, exist_ok=True)
        _write_npz(path, {_META: np.asarray(meta), **arrays}, self.compress)
        return path

    def load(self, path: str | Path):
        """Read the value stored at `path`.

        Args:
            path: the entry's file (from `path`).

        Returns:
            The stored value (after `decode`, if given); arrays come back as numpy arrays, except those
            stored from JAX arrays, which come back as JAX arrays.

        Raises:
            FileNotFoundError: there is no entry at `path`.
            ValueError: the entry is truncated, corrupt, or not a cache entry (the message names the file).
        """
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"path: no cache entry at {path}")
        try:
            with np.load(path, allow_pickle=False) as npz:
                contents = {name: npz[name] for name in npz.files}
            meta = json.loads(str(contents.pop(_META)))
            if meta.get("format") != _FORMAT:
                raise ValueError(f"format {meta.get('format')!r}, expected {_FORMAT!r}")
            value = _decode(meta["value"], contents)
            return self.decode(value) if self.decode else value
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, TypeError, KeyError, AttributeError,
                ImportError) as err:
            raise ValueError(f"path: {path} is not a readable cache entry ({type(err).__name__}: {err})") from err

    def _get(self, compute: Callable[[], T], args: Mapping[str, Any], enabled: bool) -> T:
        if not enabled or cache_disabled():
            return compute()
        path = self.path(**args)
        try:
            return self.load(path)
        except FileNotFoundError:
            pass
        except ValueError as err:
            warnings.warn(f"{err}; recomputing it", CacheWarning, stacklevel=3)
        value = compute()
        self.save(path, value)
        return value

    def get(self, compute: Callable[[], T], /, *, enabled: bool = True, **args) -> T:
        """The stored value for `args`, else `compute()`, stored for the next call.

        Args:
            compute: called without arguments on a miss; its result is stored and returned.
            enabled: False computes afresh and stores nothing (a caller's own `cache=False` switch).
            **args: what the value depends on besides the declared packages' source (see `key`).

        Returns:
            The value (on a hit, as `load` returns it; on a miss, as `compute` returned it).

        Raises:
            ValueError: an argument cannot be keyed, or the computed value cannot be stored.
        """
        return self._get(compute, args, enabled)


def cached(name: str, packages: Sequence[str] = (), version: int | str = 1, *, ignore: Sequence[str] = (),
           switch: str | None = None, compress: bool = False, encode: Callable[[Any], Any] | None = None,
           decode: Callable[[Any], Any] | None = None) -> Callable[[Callable[..., T]], Callable[..., T]]:
    """Decorate a function so its results are stored in a `Cache` keyed by its arguments.

    The key holds every argument (defaults applied) except `ignore` and `switch`, the declared
    packages' source and the source of the module that defines the function.

    Example::

        @cached("oac", packages=("experiments.data.oac", "sim"), version="oac-v3", ignore=("progress",),
                switch="cache")
        def generate(settings: OACSettings = OACSettings(), cache: bool = True, progress=None) -> OACData:
            ...

    Args:
        name: as for `Cache`.
        packages: as for `Cache`.
        version: as for `Cache`.
        ignore: names of arguments the result does not depend on (progress bars, verbosity).
        switch: name of a bool argument that turns caching off for a call when False.
        compress: as for `Cache`.
        encode: as for `Cache`.
        decode: as for `Cache`.

    Returns:
        A decorator; the decorated function has a `cache` attribute (its `Cache`).

    Raises:
        ValueError: `ignore` or `switch` names an argument the function does not have, or (when the
            decorated function is called) an argument cannot be keyed.
    """
    if isinstance(ignore, str):
        raise ValueError(f"ignore: expected a tuple of argument names, got {ignore!r}")
    store = Cache(name, packages, version, compress=compress, encode=encode, decode=decode)

    def decorate(fn: Callable[..., T]) -> Callable[..., T]:
        signature = inspect.signature(fn)
        for label, names in (("ignore", tuple(ignore)), ("switch", () if switch is None else (switch,))):
            for arg in names:
                if arg not in signature.parameters:
                    raise ValueError(f"{label}: {fn.__qualname__} has no argument {arg!r}")
        store._function = fn
        skip = set(ignore) | {switch}

        @functools.wraps(fn)
        def wrapper(*args, **kwargs):
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            enabled = True if switch is None else bool(bound.arguments[switch])
            key = {k: v for k, v in bound.arguments.items() if k not in skip}
            return store._get(lambda: fn(*args, **kwargs), key, enabled)

        wrapper.cache = store
        return wrapper

    return decorate


__all__ = ["Cache", "CacheWarning", "cache_disabled", "cached", "clear_source_digests", "source_digest"]
