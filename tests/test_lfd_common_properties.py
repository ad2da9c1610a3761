"""Property tests (hypothesis) of lfd_common's public functions not covered by the numerics, codec,
persistence and rotation tests: the scalar and array checks (valid in -> the value back; invalid in ->
`ValueError` whose message starts with the argument's name), `frame_mask`, `safe_log`, `float_dtype`,
`model_path`, `save_arrays` / `load_arrays` / `read_file` / `write_npz` round trips of random arrays
and configs, `structure_to_json` / `structure_from_json` and `cache_dir`. Fixed small shapes; values drawn.
"""
import dataclasses
import json
import math
import os
import tempfile
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from lfd_common import (as_array, cache_dir, check_choice, check_int, check_real, float_dtype, frame_mask,
                        load_arrays, model_path, read_file, safe_log, save_arrays, structure_from_json,
                        structure_to_json, write_npz)

SETTINGS = settings(max_examples=20, deadline=None)
not_numbers = st.one_of(st.none(), st.text(max_size=3), st.lists(st.integers(), max_size=2), st.just(object()))


# ----------------------------------------------------------------------------------------------
# scalar checks
# ----------------------------------------------------------------------------------------------
@SETTINGS
@given(value=st.integers(-10 ** 6, 10 ** 6), low=st.integers(-100, 100), span=st.integers(0, 100),
       as_numpy=st.booleans())
def test_check_int_promise(value, low, span, as_numpy):
    high = low + span
    given_value = np.int64(value) if as_numpy else value
    if low <= value <= high:
        out = check_int(given_value, "n", min_value=low, max_value=high)
        assert out == value and type(out) is int
    else:
        with pytest.raises(ValueError, match=r"^n: must be [<>]= "):
            check_int(given_value, "n", min_value=low, max_value=high)


@SETTINGS
@given(value=st.one_of(st.floats(), st.booleans(), not_numbers))
def test_check_int_rejects_non_integers_by_name(value):
    with pytest.raises(ValueError, match="^n: expected an integer"):
        check_int(value, "n")


@SETTINGS
@given(value=st.floats(allow_nan=True, allow_infinity=True), low=st.floats(-1e3, 1e3), exclusive=st.booleans())
def test_check_real_promise(value, low, exclusive):
    if not math.isfinite(value):
        with pytest.raises(ValueError, match="^eps: must be finite"):
            check_real(value, "eps", min_value=low, exclusive_min=exclusive)
    elif value > low or (value == low and not exclusive):
        out = check_real(value, "eps", min_value=low, exclusive_min=exclusive)
        assert out == value and type(out) is float
    else:
        with pytest.raises(ValueError, match=f"^eps: must be {'>' if exclusive else '>='} "):
            check_real(value, "eps", min_value=low, exclusive_min=exclusive)


@SETTINGS
@given(value=st.one_of(st.booleans(), not_numbers, st.complex_numbers(allow_nan=False)))
def test_check_real_rejects_non_reals_by_name(value):
    with pytest.raises(ValueError, match="^eps: expected a real number"):
        check_real(value, "eps")


@SETTINGS
@given(choices=st.lists(st.text(min_size=1, max_size=4), min_size=1, max_size=4, unique=True), value=st.text(max_size=4))
def test_check_choice_promise(choices, value):
    if value in choices:
        assert check_choice(value, "kind", choices) == value
    else:
        with pytest.raises(ValueError, match="^kind: expected one of"):
            check_choice(value, "kind", iter(choices))  # any iterable of choices


# ----------------------------------------------------------------------------------------------
# as_array
# ----------------------------------------------------------------------------------------------
@SETTINGS
@given(arr=hnp.arrays(np.float64, (3, 4), elements=st.floats(-1e6, 1e6)), low=st.floats(-1e6, 1e6),
       high=st.floats(-1e6, 1e6))
def test_as_array_bounds_promise(arr, low, high):
    ok = arr.min() >= low and arr.max() <= high
    if ok:
        np.testing.assert_array_equal(as_array(arr, "X", min_value=low, max_value=high), arr)
    else:
        with pytest.raises(ValueError, match=r"^X: values must be [<>]= "):
            as_array(arr, "X", min_value=low, max_value=high)


@SETTINGS
@given(arr=hnp.arrays(np.float64, (2, 3), elements=st.floats(-1e3, 1e3)), dtype=st.sampled_from([np.int32, np.int64]))
def test_as_array_integer_target_promise(arr, dtype):
    if np.all(arr == np.round(arr)):
        out = as_array(arr, "lengths", dtype=dtype)
        assert out.dtype == dtype
        np.testing.assert_array_equal(out, arr)
    else:
        with pytest.raises(ValueError, match="^lengths: expected integers"):
            as_array(arr, "lengths", dtype=dtype)


@SETTINGS
@given(rows=st.integers(1, 4), cols=st.integers(1, 4), extra=st.integers(1, 3))
def test_as_array_named_sizes_must_agree(rows, cols, extra):
    square = np.zeros((rows, rows))
    assert as_array(square, "S", shape=("N", "N")).shape == (rows, rows)
    with pytest.raises(ValueError, match=r"^S: expected shape \(N, N\)"):
        as_array(np.zeros((rows, rows + extra)), "S", shape=("N", "N"))
    assert as_array(np.zeros((rows, cols)), "S", shape=(rows, None)).shape == (rows, cols)
    with pytest.raises(ValueError, match=r"^S: expected shape \(%d, \?\)" % (rows + extra)):
        as_array(np.zeros((rows, cols)), "S", shape=(rows + extra, None))
    with pytest.raises(ValueError, match=r"^S: expected a 3-D array"):
        as_array(np.zeros((rows, cols)), "S", ndim=3)


@SETTINGS
@given(value=st.one_of(st.just([[1.0], [1.0, 2.0]]), st.just(np.array([{}, 1], dtype=object)), st.text(min_size=1)))
def test_as_array_rejects_ragged_object_and_text_by_name(value):
    with pytest.raises(ValueError, match="^X: "):
        as_array(value, "X")


# ----------------------------------------------------------------------------------------------
# frame_mask, safe_log, float_dtype
# ----------------------------------------------------------------------------------------------
@SETTINGS
@given(lengths=hnp.arrays(np.int32, (4,), elements=st.integers(0, 6)))
def test_frame_mask_promise(lengths):
    mask = frame_mask(lengths, 6)
    assert mask.shape == (4, 6) and mask.dtype == bool
    np.testing.assert_array_equal(mask.sum(1), lengths)
    np.testing.assert_array_equal(mask, np.arange(6)[None, :] < lengths[:, None])


_SAFE_LOG = jax.jit(jax.vmap(jax.value_and_grad(lambda p: safe_log(p))))


@SETTINGS
@given(p=hnp.arrays(np.float32, (6,), elements=st.one_of(st.floats(float(np.float32(1e-30)), float(np.float32(1e30)), width=32), st.just(0.0))))
def test_safe_log_promise(p):
    value, grad = (np.asarray(a) for a in _SAFE_LOG(jnp.asarray(p)))
    with np.errstate(divide="ignore"):
        np.testing.assert_allclose(value, np.log(p.astype(np.float64)), rtol=1e-6, atol=1e-6)
    assert np.all(value[p == 0] == -np.inf) and np.all(np.isfinite(grad))  # no NaN gradient at log 0
    np.testing.assert_allclose(grad[p > 0], 1.0 / p[p > 0].astype(np.float64), rtol=1e-6)


def test_float_dtype_follows_x64():
    assert float_dtype() == np.dtype(jnp.result_type(float))
    with jax.enable_x64(True):
        assert float_dtype() == np.float64
    with jax.enable_x64(False):
        assert float_dtype() == np.float32


# ----------------------------------------------------------------------------------------------
# persistence: model_path, save_arrays / load_arrays / read_file, write_npz
# ----------------------------------------------------------------------------------------------
names = st.text(alphabet="abcdefgh_", min_size=1, max_size=6)


@SETTINGS
@given(name=names, suffix=st.sampled_from(["", ".npz", ".npy", ".tar.gz"]))
def test_model_path_promise(name, suffix):
    path = model_path(f"dir/{name}{suffix}")
    assert path.suffix == ".npz" and model_path(path) == path and model_path(str(path)) == path
    assert path.name.startswith(name + suffix)


@SETTINGS
@given(value=st.one_of(st.none(), st.integers(), st.floats(), st.lists(st.text(), max_size=2)))
def test_model_path_rejects_non_paths_by_name(value):
    with pytest.raises(ValueError, match="^path: "):
        model_path(value)
    with pytest.raises(ValueError, match="^path: "):
        load_arrays(value, "k")


dtypes = st.sampled_from([np.float32, np.float64, np.int32, np.int64, np.uint8, np.bool_])
json_values = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10 ** 9, 10 ** 9), st.floats(allow_nan=False, allow_infinity=False),
              st.text(max_size=5)),
    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=4), inner, max_size=3)),
    max_leaves=8)


@SETTINGS
@given(data=st.data(), n_arrays=st.integers(0, 3), config=st.dictionaries(st.text(max_size=6), json_values, max_size=4),
       kind=st.text(min_size=1, max_size=12), suffix=st.sampled_from(["", ".npz"]))
def test_save_load_arrays_round_trip(data, n_arrays, config, kind, suffix):
    arrays = {}
    for i in range(n_arrays):
        dtype = data.draw(dtypes)
        arrays[f"a{i}"] = data.draw(hnp.arrays(dtype, (2, 3)))  # any values: NaN and +-inf too
    with tempfile.TemporaryDirectory() as tmp:
        given_path = f"{tmp}/file{suffix}"
        written = save_arrays(given_path, kind, arrays, config)
        assert written == model_path(given_path) and written.exists()
        loaded, loaded_config, version = load_arrays(given_path, kind)  # the same path string loads
        assert loaded_config == config and version == 1 and set(loaded) == set(arrays)
        for name, value in arrays.items():
            assert loaded[name].dtype == value.dtype
            np.testing.assert_array_equal(loaded[name], value)  # NaN compares equal here
        stored_kind, stored, _, _ = read_file(written)
        assert stored_kind == kind and set(stored) == set(arrays)
        with pytest.raises(ValueError, match="^path: .* holds a"):
            load_arrays(given_path, kind + "x")
        assert sorted(p.name for p in Path(tmp).iterdir()) == [written.name]  # no temporary file left


@SETTINGS
@given(bad=st.sampled_from(["kind", "arrays", "config", "ragged", "object"]))
def test_save_arrays_rejects_bad_input_by_name(bad):
    args = dict(kind="k", arrays={"x": np.zeros(2)}, config={"a": 1})
    if bad == "kind":
        args["kind"] = ""
    elif bad == "arrays":
        args["arrays"] = [np.zeros(2)]
    elif bad == "config":
        args["config"] = [("a", 1)]
    elif bad == "ragged":
        args["arrays"] = {"x": [[1.0], [1.0, 2.0]]}
    else:
        args["arrays"] = {"x": np.array([{}, 1], dtype=object)}
    name = {"ragged": "arrays", "object": "arrays"}.get(bad, bad)
    with tempfile.TemporaryDirectory() as tmp:
        with pytest.raises(ValueError, match=f"^{name}"):
            save_arrays(f"{tmp}/m", **args)
        assert not any(Path(tmp).iterdir())  # nothing written


@SETTINGS
@given(arr=hnp.arrays(np.float64, (3,), elements=st.floats(allow_nan=False)))
def test_write_npz_round_trip(arr):
    with tempfile.TemporaryDirectory() as tmp:
        path = write_npz(Path(tmp) / "sub" / "x.npz", x=arr)
        with np.load(path) as npz:
            np.testing.assert_array_equal(npz["x"], arr)
        assert [p.name for p in path.parent.iterdir()] == ["x.npz"]


# ----------------------------------------------------------------------------------------------
# structures as JSON, cache_dir
# ----------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Inner:
    size: int
    grid: tuple = (1, 1)


@dataclasses.dataclass(frozen=True)
class _Outer:
    name: str
    inner: _Inner
    extra: _Inner | None = None

    def __post_init__(self):
        if not self.name:
            raise ValueError("name: must not be empty")


@SETTINGS
@given(name=st.text(min_size=1, max_size=5), size=st.integers(), grid=st.tuples(st.integers(), st.integers()),
       with_extra=st.booleans())
def test_structure_json_round_trip(name, size, grid, with_extra):
    s = _Outer(name, _Inner(size, grid), _Inner(size + 1) if with_extra else None)
    data = json.loads(json.dumps(structure_to_json(s)))
    assert structure_from_json(_Outer, data) == s  # JSON lists become tuples again
    with pytest.raises(ValueError, match=r"^structure: unknown field\(s\) \['zzz'\]"):
        structure_from_json(_Outer, {**data, "zzz": 1})
    with pytest.raises(ValueError, match="^structure.inner: unknown field"):
        structure_from_json(_Outer, {**data, "inner": {"size": 1, "nope": 2}})
    with pytest.raises(ValueError, match="^structure: not a valid _Outer"):
        structure_from_json(_Outer, {**data, "name": ""})
    with pytest.raises(ValueError, match="^structure: expected a JSON object"):
        structure_from_json(_Outer, [data])
    with pytest.raises(ValueError, match="^structure: expected a dataclass instance"):
        structure_to_json(_Outer)


@SETTINGS
@given(parts=st.lists(names, min_size=1, max_size=3))
def test_cache_dir_promise(parts):
    old = os.environ.get("LFD_JAX_CACHE")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["LFD_JAX_CACHE"] = tmp
        try:
            path = cache_dir(*parts)
        finally:
            if old is None:
                del os.environ["LFD_JAX_CACHE"]
            else:
                os.environ["LFD_JAX_CACHE"] = old
        assert path == Path(tmp).joinpath(*parts) and path.is_dir()
