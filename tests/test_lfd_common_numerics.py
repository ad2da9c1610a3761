"""Shared log-space numerics and padded batches of `lfd_common` against float64 NumPy."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from lfd_common import float_dtype, frame_mask, pad_sequences, safe_log, safe_logaddexp, safe_logsumexp

NEG_INF = -np.inf


def _ref_logsumexp(a, axis):
    a = np.asarray(a, np.float64)
    peak = np.max(a, axis=axis, keepdims=True)
    peak = np.where(np.isfinite(peak), peak, 0.0)
    with np.errstate(divide="ignore"):
        return np.log(np.sum(np.exp(a - peak), axis=axis)) + np.squeeze(peak, axis)


log_values = hnp.arrays(np.float64, (3, 4), elements=st.one_of(
    st.floats(-50, 50), st.just(NEG_INF)))


@settings(max_examples=40, deadline=None)
@given(log_values)
def test_logsumexp_and_logaddexp_match_numpy_with_finite_gradients(a):
    x = jnp.asarray(a, jnp.float32)
    np.testing.assert_allclose(safe_logsumexp(x, axis=1), _ref_logsumexp(a, 1), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(safe_logaddexp(x[0], x[1]), np.logaddexp(a[0], a[1]), rtol=1e-5, atol=1e-5)
    for f in (lambda v: jnp.sum(jnp.where(jnp.isfinite(o := safe_logsumexp(v, 0)), o, 0.0)),
              lambda v: jnp.sum(jnp.where(jnp.isfinite(o := safe_logaddexp(v[0], v[1])), o, 0.0))):
        assert np.all(np.isfinite(np.asarray(jax.grad(f)(x))))


def test_all_minus_inf_slices_give_minus_inf_and_zero_gradient():
    x = jnp.array([[NEG_INF, NEG_INF], [0.0, NEG_INF]])
    out = safe_logsumexp(x, axis=1)
    np.testing.assert_array_equal(out, [NEG_INF, 0.0])
    g = jax.grad(lambda v: safe_logsumexp(v, axis=1)[1])(x)
    np.testing.assert_array_equal(g, [[0.0, 0.0], [1.0, 0.0]])
    np.testing.assert_array_equal(jax.grad(lambda p: safe_log(p))(0.0), 0.0)
    assert safe_log(jnp.float32(0.0)) == NEG_INF


def test_nan_stays_nan():
    assert np.isnan(safe_logsumexp(jnp.array([np.nan, 0.0])))
    assert np.isnan(safe_log(jnp.float32(np.nan)))
    assert np.isnan(safe_logaddexp(jnp.float32(np.nan), jnp.float32(NEG_INF)))


def test_pad_sequences_accepts_the_three_layouts():
    seqs = [np.ones((3, 2)), 2 * np.ones((5, 2))]
    X, lengths = pad_sequences(seqs)
    assert X.shape == (2, 5, 2) and X.dtype == float_dtype()
    np.testing.assert_array_equal(lengths, [3, 5])
    np.testing.assert_array_equal(X[0, 3:], 0.0)
    X1, l1 = pad_sequences(np.ones((4, 2)))
    assert X1.shape == (1, 4, 2) and list(l1) == [4]
    padded = np.full((2, 5, 2), np.nan)
    padded[0, :3], padded[1] = 1.0, 2.0
    X2, _ = pad_sequences(padded, [3, 5])
    np.testing.assert_array_equal(X2, X)
    images, ln = pad_sequences([np.ones((2, 4, 4)), np.ones((1, 4, 4))], frame_ndim=2)
    assert images.shape == (2, 2, 4, 4) and list(ln) == [2, 1]


@pytest.mark.parametrize("args, kwargs, match", [
    ((np.zeros((0, 3, 2)),), {}, "^X: the batch is empty"),
    ((np.zeros((2, 0, 2)),), {}, "^X: must not be empty"),
    ((np.zeros((2, 3, 2)), [1, 4]), {}, "^lengths: values must be <= 3"),
    ((np.zeros((2, 3, 2)), [0, 3]), {}, "^lengths: values must be >= 1"),
    ((np.full((1, 3, 2), np.nan),), {}, "^X: contains 6 NaN"),
    ((np.full((1, 3, 2), 1e39),), {}, "^X: values up to 1e\\+39 overflow float32"),
    ((np.zeros((1, 3, 2)),), {"dim": 3}, "^X: expected feature dimension D=3"),
    (([np.zeros((2, 2)), np.zeros((2, 3))],), {}, "^X: sequences have different per-frame shapes"),
    (([np.zeros((2, 2))], [2]), {}, "^lengths: give either"),
    (("abc",), {}, "^X: expected a numeric array"),
])
def test_pad_sequences_rejects_bad_input_naming_the_argument(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        pad_sequences(*args, **kwargs)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.integers(1, 6), min_size=1, max_size=4), st.integers(1, 3))
def test_pad_sequences_promise(lengths, dim):
    rng = np.random.default_rng(len(lengths) * 10 + dim)
    seqs = [rng.normal(size=(n, dim)) for n in lengths]
    X, got = pad_sequences(seqs)
    assert X.shape == (len(lengths), max(lengths), dim)
    np.testing.assert_array_equal(got, lengths)
    mask = frame_mask(got, X.shape[1])
    for b, s in enumerate(seqs):
        np.testing.assert_allclose(X[b, : len(s)], s, rtol=1e-6)
    assert np.all(X[~mask] == 0.0)
