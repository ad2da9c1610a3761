"""Shapes, strategies and checks shared by the crf_jax property tests (`tests/test_crf_properties*.py`)."""
import dataclasses
import tempfile
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import crf_jax

B, T, D, K, C = 2, 5, 3, 3, 1          # chain: batch, frames, features, labels, connectivity
KA, KO, H = 2, 2, 2                     # FCRF actions / objects, HCRF hidden states per class
N = 6                                   # linear baselines: vectors
W = 2 * C + 1
SETTINGS = settings(max_examples=20, deadline=None)
FEW = settings(max_examples=3, deadline=None)   # fits: one compiled loop each, a few examples
FIT = crf_jax.FitOptions(max_iter=3)


def float_arrays(shape, lo=-2.0, hi=2.0):
    return hnp.arrays(np.float64, shape, elements=st.floats(lo, hi, allow_nan=False, allow_infinity=False))


features = float_arrays((B, T, D), -10.0, 10.0)
scales = st.sampled_from([1.0, 1e3, 1e6])
lengths_st = hnp.arrays(np.int32, (B,), elements=st.integers(1, T))
labels_st = hnp.arrays(np.int32, (B, T), elements=st.integers(0, K - 1))
bad_values = st.sampled_from([np.nan, np.inf, -np.inf, 1e39, -1e39])
frame_index = st.tuples(st.integers(0, B - 1), st.integers(0, T - 1), st.integers(0, D - 1))


def _f32(*arrays):
    return [jnp.asarray(a, jnp.float32) for a in arrays]


def chain_crf(w, b, tr):
    return crf_jax.ChainCRF(*_f32(w, b, tr))


chain_models = st.builds(chain_crf, float_arrays((W, D, K)), float_arrays((K,)), float_arrays((K, K)))
hcrf_models = st.builds(lambda w, b, tr: crf_jax.HCRF(*_f32(w, b, tr)),
                        float_arrays((W, D, KA, H)), float_arrays((KA, H)), float_arrays((KA, H, H)))
fcrf_models = st.builds(lambda a, o, c: crf_jax.FCRF(a, o, jnp.asarray(c, jnp.float32)),
                        st.builds(chain_crf, float_arrays((W, D, KA)), float_arrays((KA,)), float_arrays((KA, KA))),
                        st.builds(chain_crf, float_arrays((W, D, KO)), float_arrays((KO,)), float_arrays((KO, KO))),
                        float_arrays((KA, KO)))
linear_models = st.builds(lambda w, b: crf_jax.LinearModel(*_f32(w, b)), float_arrays((D, K)), float_arrays((K,)))


def real_frames(lengths):
    return np.arange(T)[None, :] < np.asarray(lengths)[:, None]


def lse(a, axis):
    a = np.asarray(a, np.float64)
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        return np.squeeze(np.log(np.sum(np.exp(a - m), axis=axis, keepdims=True)) + m, axis=axis)


def assert_distributions(p, real, atol=1e-5):
    """p (B, T, n): finite, in [0, 1], rows summing to 1 on real frames and 0 on padding."""
    p = np.asarray(p, np.float64)
    assert np.all(np.isfinite(p)) and np.all(p >= 0) and np.all(p <= 1 + atol)
    np.testing.assert_allclose(p.sum(-1), real.astype(float), atol=atol)


def assert_log_probs(lp, shape):
    lp = np.asarray(lp, np.float64)
    assert lp.shape == shape and np.all(np.isfinite(lp)) and np.all(lp <= 0.0)
    return lp


# ----------------------------------------------------------------------------------------------
# linear-chain CRF
# ----------------------------------------------------------------------------------------------
