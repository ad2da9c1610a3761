"""The content-keyed cache: hits and misses, the source of declared packages in the key, round trips of
stored values, corrupt entries, argument validation and the key's equality property."""
from __future__ import annotations

import copy
import dataclasses
import importlib
import sys
import warnings
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from lfd_common import Cache, CacheWarning, cached, clear_source_digests, source_digest


class Pair(NamedTuple):
    left: np.ndarray
    count: int
    label: str
    scale: float


@dataclasses.dataclass(frozen=True)
class Options:
    size: int
    shape: tuple = (2, 3)
    weights: dict = dataclasses.field(default_factory=dict)


@pytest.fixture(autouse=True)
def cache_root(tmp_path, monkeypatch):
    root = tmp_path / "cache"
    monkeypatch.setenv("LFD_JAX_CACHE", str(root))
    monkeypatch.delenv("LFD_JAX_NO_CACHE", raising=False)
    clear_source_digests()
    yield root
    clear_source_digests()


def counted(calls: list, value):
    def compute():
        calls.append(1)
        return value
    return compute


def test_round_trip_keeps_types_dtypes_and_values():
    value = {
        "pair": Pair(np.arange(6, dtype=np.int16).reshape(2, 3), 4, "x", float("inf")),
        "options": Options(3, (1, 2), {"w": np.float32(0.5)}),
        "items": [None, True, 7, -0.0, "text", (1, (2.5,))],
        "jax": jnp.ones((2,), jnp.float32),
        "uint8": np.zeros((2, 2, 3), np.uint8),
    }
    store = Cache("round_trip", compress=True)
    back = store.load(store.save(store.path(n=1), value))
    assert type(back["pair"]) is Pair and type(back["options"]) is Options
    np.testing.assert_array_equal(back["pair"].left, value["pair"].left)
    assert back["pair"].left.dtype == np.int16
    assert back["pair"][1:] == (4, "x", float("inf"))
    assert back["options"].shape == (1, 2) and type(back["options"].weights["w"]) is np.float32
    assert back["items"] == [None, True, 7, -0.0, "text", (1, (2.5,))]
    assert str(back["items"][3]) == "-0.0" and type(back["items"][5]) is tuple
    assert isinstance(back["jax"], type(value["jax"])) and back["jax"].dtype == jnp.float32
    assert back["uint8"].dtype == np.uint8 and back["uint8"].shape == (2, 2, 3)


def test_same_arguments_hit_and_different_arguments_miss():
    calls = []

    @cached("hits", ignore=("progress",))
    def square(x, scale: float = 1.0, progress=None):
        calls.append(x)
        return np.asarray(x, float) ** 2 * scale

    np.testing.assert_array_equal(square(np.arange(3)), [0, 1, 4])
    np.testing.assert_array_equal(square(np.arange(3), progress=print), [0, 1, 4])  # ignored argument
    assert len(calls) == 1
    square(np.arange(3), scale=2.0)
    square(np.arange(4))
    assert len(calls) == 3
    assert len(list(square.cache.directory.glob("*.npz"))) == 3


def test_switch_and_environment_bypass_the_cache(monkeypatch):
    calls = []

    @cached("switch", switch="cache")
    def value(n, cache: bool = True):
        calls.append(n)
        return np.zeros(n)

    value(2, cache=False)
    value(2, cache=False)
    assert len(calls) == 2 and not list(value.cache.directory.glob("*.npz"))
    monkeypatch.setenv("LFD_JAX_NO_CACHE", "1")
    value(2)
    value(2)
    assert len(calls) == 4 and not list(value.cache.directory.glob("*.npz"))


@pytest.fixture
def toy_package(tmp_path, monkeypatch):
    """A two-module package on sys.path: `model.make` calls `helper.factor` (an indirect dependency)."""
    name = "lfdcache_toy_pkg"
    root = tmp_path / "src"
    (root / name).mkdir(parents=True)
    (root / name / "__init__.py").write_text("")
    (root / name / "helper.py").write_text("def factor():\n    return 2\n")
    (root / name / "model.py").write_text(f"import numpy as np\n\nfrom {name}.helper import factor\n\n\n"
                                          "def make(n):\n    return np.arange(n) * factor()\n")
    monkeypatch.syspath_prepend(str(root))
    yield name, root / name
    for module in [m for m in sys.modules if m == name or m.startswith(name + ".")]:
        del sys.modules[module]


def test_editing_an_indirect_dependency_recomputes(toy_package):
    name, folder = toy_package
    calls = []

    @cached("dependency", packages=(name,))
    def build(n):
        calls.append(n)
        return importlib.import_module(f"{name}.model").make(n)

    np.testing.assert_array_equal(build(3), [0, 2, 4])
    np.testing.assert_array_equal(build(3), [0, 2, 4])
    assert len(calls) == 1
    # the helper, not the cached function's module nor the module it calls, changes
    (folder / "helper.py").write_text("def factor():\n    return 5\n")
    clear_source_digests()  # what a new process sees
    importlib.reload(importlib.import_module(f"{name}.helper"))
    importlib.reload(importlib.import_module(f"{name}.model"))
    np.testing.assert_array_equal(build(3), [0, 5, 10])
    assert len(calls) == 2
    np.testing.assert_array_equal(build(3), [0, 5, 10])
    assert len(calls) == 2


def test_source_digest_covers_every_file_of_a_package(toy_package):
    name, folder = toy_package
    before = source_digest(name)
    (folder / "extra.py").write_text("X = 1\n")
    assert source_digest(name) == before  # once per process
    clear_source_digests()
    assert source_digest(name) != before
    with pytest.raises(ValueError, match="packages"):
        source_digest("lfdcache_no_such_package")


def test_corrupt_entry_is_recomputed_with_a_warning():
    calls = []
    store = Cache("corrupt")
    value = {"a": np.arange(1000.0), "b": np.ones((10, 10))}
    store.get(counted(calls, value), n=1)
    path = store.path(n=1)
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.warns(CacheWarning, match="not a readable cache entry"):
        back = store.get(counted(calls, value), n=1)
    np.testing.assert_array_equal(back["a"], value["a"])
    assert len(calls) == 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(store.get(counted(calls, value), n=1)["b"], value["b"])
    assert len(calls) == 2
    path.write_bytes(b"not a zip file")
    with pytest.raises(ValueError, match="not a readable cache entry"):
        store.load(path)


def test_bad_arguments_and_values_raise_naming_them():
    store = Cache("bad")
    with pytest.raises(ValueError, match="progress: function cannot"):
        store.key(progress=lambda: None)
    with pytest.raises(ValueError, match=r"cfg\['a'\]\[1\]: set cannot"):
        store.key(cfg={"a": [1, {2}]})
    with pytest.raises(ValueError, match=r"options\.weights: dict keys"):
        store.key(options=Options(1, weights={1: 2}))
    with pytest.raises(ValueError, match="x: object arrays"):
        store.key(x=np.array([None, 1]))
    with pytest.raises(ValueError, match=r"value\['f'\]: function cannot be stored"):
        store.get(lambda: {"f": lambda: None}, n=1)
    calls = []

    @cached("bad_args")
    def f(x):
        calls.append(x)
        return np.zeros(1)

    with pytest.raises(ValueError, match="x: object cannot"):
        f(object())
    assert not calls
    for kwargs, match in ((dict(name="a/b"), "name"), (dict(name="n", packages="sim"), "packages"),
                          (dict(name="n", packages=("not a name",)), "packages"), (dict(name="n", version=1.5),
                                                                                   "version")):
        with pytest.raises(ValueError, match=match):
            Cache(**kwargs)
    with pytest.raises(ValueError, match="ignore: .* no argument 'verbose'"):
        cached("n", ignore=("verbose",))(lambda x: x)


_leaves = (st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=4))
_values = st.recursive(_leaves, lambda inner: (st.lists(inner, max_size=3) | st.tuples(inner, inner)
                                               | st.dictionaries(st.text(max_size=3), inner, max_size=3)),
                       max_leaves=8)
_arguments = st.dictionaries(st.sampled_from(("a", "b", "c", "d")), _values, min_size=1)
_KEYS = Cache("property")


@settings(max_examples=60, deadline=None)
@given(_arguments, st.data())
def test_key_equal_for_equal_arguments_and_changed_by_any_change(args, data):
    key = _KEYS.key(**args)
    assert _KEYS.key(**copy.deepcopy(args)) == key
    assert _KEYS.key(**dict(reversed(list(args.items())))) == key
    name = data.draw(st.sampled_from(sorted(args)))
    new = data.draw(_values)
    assume(new != args[name])  # Python equality: 1 == 1.0 == True; such swaps may or may not keep the key
    assert _KEYS.key(**{**args, name: new}) != key


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 11), st.sampled_from((np.float32, np.float64, np.int32)))
def test_key_of_arrays_follows_content_dtype_and_shape(index, dtype):
    x = np.arange(12).astype(dtype)
    key = _KEYS.key(x=x, options=Options(1))
    assert _KEYS.key(x=x.copy(), options=Options(1)) == key
    changed = x.copy()
    changed[index] += 1
    assert _KEYS.key(x=changed, options=Options(1)) != key
    assert _KEYS.key(x=x.reshape(3, 4), options=Options(1)) != key
    assert _KEYS.key(x=x.astype(np.int64), options=Options(1)) != key
    assert _KEYS.key(x=x, options=Options(2)) != key
