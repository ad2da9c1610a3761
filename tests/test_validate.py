import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from lfd_common import as_array, check_choice, check_int, check_real


def test_as_array_converts_and_keeps_values():
    out = as_array([[1, 2], [3, 4]], "X", shape=("T", 2))
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, [[1.0, 2.0], [3.0, 4.0]])


@pytest.mark.parametrize(
    "value, kwargs, message",
    [
        (np.zeros((2, 3)), {"shape": ("T", 4)}, r"X: expected shape \(T, 4\), got \(2, 3\)"),
        (np.zeros((2, 3)), {"shape": ("B", "T", "D")}, r"X: expected shape \(B, T, D\)"),
        (np.zeros((2, 3)), {"shape": ("N", "N")}, r"X: expected shape \(N, N\)"),
        (np.zeros((2, 3)), {"ndim": 3}, r"X: expected a 3-D array"),
        (np.zeros((2, 3)), {"ndim": (1, 3)}, r"X: expected a 1 or 3-D array"),
        (np.zeros((0, 3)), {}, r"X: must not be empty"),
        (np.array([1.0, np.nan, np.inf]), {}, r"X: contains 2 NaN or infinite"),
        (np.array([0.5, 2.0]), {"max_value": 1.0}, r"X: values must be <= 1.0"),
        (np.array([-0.5, 0.0]), {"min_value": 0.0}, r"X: values must be >= 0.0"),
        (np.array([1.5]), {"dtype": np.int64}, r"X: expected integers"),
        (np.array(["a", "b"]), {}, r"X: expected a numeric array"),
        ([[1.0], [1.0, 2.0]], {}, r"X: "),
    ],
)
def test_as_array_rejects_with_named_error(value, kwargs, message):
    with pytest.raises(ValueError, match=message):
        as_array(value, "X", **kwargs)


@pytest.mark.parametrize("value", [np.array(["a", "b"]), np.array([b"1"]), np.array(["2024-01-01"], "datetime64[D]"),
                                   np.zeros(2, [("x", float)])])
def test_as_array_keeping_the_input_dtype_still_rejects_non_numeric_values(value):
    with pytest.raises(ValueError, match=r"^X: expected a numeric array, got dtype"):
        as_array(value, "X", dtype=None)


def test_as_array_keeping_the_input_dtype_keeps_numbers_and_bools():
    for value in (np.array([True, False]), np.arange(3, dtype=np.uint8), np.ones(2, np.float32)):
        out = as_array(value, "X", dtype=None)
        assert out.dtype == value.dtype and np.array_equal(out, value)


def test_as_array_allows_empty_and_nonfinite_when_asked():
    assert as_array(np.zeros((0, 3)), "X", nonempty=False).shape == (0, 3)
    assert np.isnan(as_array([np.nan], "X", finite=False)[0])


def test_as_array_integer_target_accepts_integral_floats():
    out = as_array(np.array([1.0, 3.0]), "lengths", dtype=np.int32, min_value=1)
    assert out.dtype == np.int32 and out.tolist() == [1, 3]


@settings(max_examples=40, deadline=None)
@given(hnp.arrays(np.float64, hnp.array_shapes(min_dims=1, max_dims=3, min_side=1, max_side=5),
                  elements=st.floats(-1e6, 1e6)),
       st.data())
def test_as_array_finite_passes_and_any_nan_fails(arr, data):
    np.testing.assert_array_equal(as_array(arr, "X"), arr)
    bad = arr.copy()
    index = tuple(data.draw(st.integers(0, n - 1)) for n in arr.shape)
    bad[index] = data.draw(st.sampled_from([np.nan, np.inf, -np.inf]))
    with pytest.raises(ValueError, match="X: contains 1 NaN"):
        as_array(bad, "X")


def test_scalar_checks():
    assert check_int(np.int64(4), "n", min_value=1) == 4
    with pytest.raises(ValueError, match="n: expected an integer"):
        check_int(2.0, "n")
    with pytest.raises(ValueError, match="n: expected an integer"):
        check_int(True, "n")
    with pytest.raises(ValueError, match="n: must be >= 1, got 0"):
        check_int(0, "n", min_value=1)
    with pytest.raises(ValueError, match="n: must be <= 3"):
        check_int(4, "n", max_value=3)
    assert check_real(1, "eps", min_value=0.0) == 1.0
    with pytest.raises(ValueError, match="eps: must be finite"):
        check_real(float("nan"), "eps")
    with pytest.raises(ValueError, match="eps: must be > 0.0"):
        check_real(0.0, "eps", min_value=0.0, exclusive_min=True)
    assert check_choice("full", "covariance", ("full", "diag")) == "full"
    with pytest.raises(ValueError, match=r"covariance: expected one of \('full', 'diag'\)"):
        check_choice("tied", "covariance", ("full", "diag"))
