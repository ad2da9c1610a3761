"""Property tests (hypothesis) of crf_jax's public promise:

* valid input -> finite output of the documented shape: labels in range (-1 on padding), marginals
  that are distributions on real frames (0 on padding), log probabilities <= 0 that normalise;
* invalid input -> `ValueError` whose message starts with the argument's name.

Shapes are fixed (one compilation per function, reused across examples); hypothesis draws values,
including feature scales up to 1e6 (where float32 cancellation once broke the marginals) and -inf log probabilities.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import crf_jax
from tests.crf_properties_common import (  # shapes, strategies and checks
    B, T, D, K, C, H, N, W, SETTINGS, FEW, FIT, features, scales, lengths_st, labels_st, bad_values,
    frame_index, chain_crf, chain_models, real_frames, lse, assert_distributions, assert_log_probs,
)


@SETTINGS
@given(model=chain_models, X=features, scale=scales, lengths=lengths_st, y=labels_st)
def test_chain_inference_promise(model, X, scale, lengths, y):
    X = X * scale
    real = real_frames(lengths)
    labels = np.asarray(crf_jax.predict(model, X, lengths))
    assert labels.shape == (B, T) and labels.dtype == np.int32
    assert np.all((labels[real] >= 0) & (labels[real] < K)) and np.all(labels[~real] == -1)
    assert_distributions(crf_jax.predict_marginals(model, X, lengths), real)
    seg = assert_log_probs(crf_jax.segment_log_probs(model, X, lengths), (B, K))
    if scale == 1.0:  # probabilities of K distinct label sequences: at most 1 in all
        assert np.all(lse(seg, 1) <= 1e-5)
    assert_log_probs(crf_jax.log_likelihood(model, X, y, lengths), (B,))


@SETTINGS
@given(model=chain_models, X=features, lengths=lengths_st, junk=st.sampled_from([np.nan, np.inf, 1e39]))
def test_chain_padding_is_never_read(model, X, lengths, junk):
    padded = X.copy()
    padded[~real_frames(lengths)] = junk
    np.testing.assert_array_equal(crf_jax.predict_marginals(model, padded, lengths),
                                  crf_jax.predict_marginals(model, np.where(real_frames(lengths)[..., None], X, 0.0),
                                                            lengths))


CHAIN_FUNCTIONS = ["predict", "predict_marginals", "segment_log_probs", "log_likelihood"]


def _call_chain(name, model, X, lengths=None, y=None):
    if name == "log_likelihood":
        return crf_jax.log_likelihood(model, X, np.zeros((B, T), np.int32) if y is None else y, lengths)
    return getattr(crf_jax, name)(model, X, lengths)


@SETTINGS
@given(model=chain_models, where=frame_index, bad=bad_values, name=st.sampled_from(CHAIN_FUNCTIONS))
def test_chain_rejects_bad_features_by_name(model, where, bad, name):
    X = np.zeros((B, T, D))
    X[where] = bad
    with pytest.raises(ValueError, match="^X: "):
        _call_chain(name, model, X)


@SETTINGS
@given(model=chain_models, name=st.sampled_from(CHAIN_FUNCTIONS), bad_length=st.sampled_from([0, -1, T + 1]),
       shape=st.sampled_from([(B, T, D + 1), (B, 0, D), (0, T, D), (T, D, 1, 1)]))
def test_chain_rejects_bad_shapes_and_lengths_by_name(model, name, bad_length, shape):
    with pytest.raises(ValueError, match="^lengths: "):
        _call_chain(name, model, np.zeros((B, T, D)), [T, bad_length])
    with pytest.raises(ValueError, match="^lengths: "):
        _call_chain(name, model, np.zeros((B, T, D)), [T])
    with pytest.raises(ValueError, match="^X: "):
        _call_chain(name, model, np.zeros(shape))


@SETTINGS
@given(model=chain_models, where=st.tuples(st.integers(0, B - 1), st.integers(0, T - 1)),
       bad=st.sampled_from([-1, K, 2.5, np.nan]))
def test_log_likelihood_rejects_bad_labels_by_name(model, where, bad):
    y = np.zeros((B, T))
    y[where] = bad
    with pytest.raises(ValueError, match="^y: "):
        crf_jax.log_likelihood(model, np.zeros((B, T, D)), y)


@FEW
@given(X=features, y=labels_st, lengths=lengths_st)
def test_fit_chain_promise(X, y, lengths):
    model, info = crf_jax.fit_chain(X, y, lengths, n_labels=K, connectivity=C, l2=0.1, options=FIT)
    assert model.structure == crf_jax.ChainStructure(K, D, C)
    assert all(np.all(np.isfinite(np.asarray(leaf))) for leaf in model)
    n = int(info.n_iter)
    assert 1 <= n <= FIT.max_iter and np.all(np.isfinite(np.asarray(info.loss)[:n]))
    assert not bool(info.diverged) and np.asarray(info.loss).shape == (FIT.max_iter,)


@SETTINGS
@given(where=frame_index, bad=bad_values, label=st.sampled_from([-1, K]))
def test_fit_chain_rejects_bad_data_by_name(where, bad, label):
    X = np.zeros((B, T, D))
    y = np.zeros((B, T), np.int32)
    X[where] = bad
    with pytest.raises(ValueError, match="^X: "):
        crf_jax.fit_chain(X, y, n_labels=K, options=FIT)
    y[where[:2]] = label
    with pytest.raises(ValueError, match="^y: "):
        crf_jax.fit_chain(np.zeros((B, T, D)), y, n_labels=K, options=FIT)
    with pytest.raises(ValueError, match="^validation\\[0\\]: "):
        crf_jax.fit_chain(np.zeros((B, T, D)), np.zeros((B, T), np.int32), n_labels=K, options=FIT,
                          validation=(X, np.zeros((B, T), np.int32)))


@pytest.mark.parametrize("kwargs, match", [
    (dict(connectivity=-1), "connectivity"), (dict(l2=np.nan), "l2"), (dict(n_labels=0), "n_labels"),
    (dict(options=dict(max_iter=3)), "options"), (dict(init="zeros"), "init"),
    (dict(validation=(np.zeros((B, T, D)),)), "validation"),
])
def test_fit_chain_rejects_bad_arguments_by_name(kwargs, match):
    with pytest.raises(ValueError, match=f"^{match}"):
        crf_jax.fit_chain(np.zeros((B, T, D)), np.zeros((B, T), np.int32), **{"n_labels": K, **kwargs})


# ----------------------------------------------------------------------------------------------
# hidden CRF, factorial CRF
# ----------------------------------------------------------------------------------------------
