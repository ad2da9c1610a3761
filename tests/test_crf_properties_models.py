"""Property tests (hypothesis) of crf_jax's public promise for the HCRF, FCRF, linear baselines and CHCRF fusion:

* valid input -> finite output of the documented shape: labels in range (-1 on padding), marginals
  that are distributions on real frames (0 on padding), log probabilities <= 0 that normalise;
* invalid input -> `ValueError` whose message starts with the argument's name.

Shapes are fixed (one compilation per function, reused across examples); hypothesis draws values,
including feature scales up to 1e6 (where float32 cancellation once broke the marginals) and -inf log probabilities.
"""

import dataclasses
import tempfile
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import crf_jax
from tests.crf_properties_common import (  # shapes, strategies and checks
    B, T, D, K, C, KA, KO, H, N, W, SETTINGS, FEW, FIT, float_arrays, features, scales, lengths_st,
    labels_st, bad_values, frame_index, chain_crf, chain_models, hcrf_models, fcrf_models,
    linear_models, real_frames, lse, assert_distributions, assert_log_probs,
)


@SETTINGS
@given(model=hcrf_models, X=features, scale=st.sampled_from([1.0, 1e3]), lengths=lengths_st)
def test_hcrf_promise(model, X, scale, lengths):
    lp = assert_log_probs(crf_jax.hcrf_log_probs(model, X * scale, lengths), (B, KA))
    np.testing.assert_allclose(lse(lp, 1), 0.0, atol=1e-5)
    pred = np.asarray(crf_jax.hcrf_predict(model, X * scale, lengths))
    assert pred.shape == (B,) and np.all((pred >= 0) & (pred < KA))


@SETTINGS
@given(model=fcrf_models, X=features, scale=scales, lengths=lengths_st)
def test_fcrf_exact_promise(model, X, scale, lengths):
    X = X * scale
    real = real_frames(lengths)
    marg = crf_jax.fcrf_marginals(model, X, lengths)
    assert_distributions(marg.action, real)
    assert_distributions(marg.object, real)
    lp = assert_log_probs(crf_jax.fcrf_segment_log_probs(model, X, lengths), (B, KA, KO))
    if scale == 1.0:
        assert np.all(lse(lp.reshape(B, -1), 1) <= 1e-5)
    seg = crf_jax.fcrf_predict_segments(model, X, lengths)
    assert np.all((np.asarray(seg.action) >= 0) & (np.asarray(seg.action) < KA))
    assert np.all((np.asarray(seg.object) >= 0) & (np.asarray(seg.object) < KO))


@FEW
@given(model=fcrf_models, X=features, lengths=lengths_st)
def test_fcrf_loopy_beliefs_are_distributions(model, X, lengths):
    marg = crf_jax.fcrf_marginals(model, X, lengths, method="loopy", n_iter=3)
    assert_distributions(marg.action, real_frames(lengths), atol=1e-4)
    assert_distributions(marg.object, real_frames(lengths), atol=1e-4)


@SETTINGS
@given(where=frame_index, bad=bad_values)
def test_hcrf_and_fcrf_reject_bad_input_by_name(where, bad):
    X = np.zeros((B, T, D))
    X[where] = bad
    hcrf = crf_jax.init_hcrf(jax.random.PRNGKey(0), D, KA, H, C)
    fcrf = crf_jax.init_fcrf(D, KA, KO, C)
    for call in (lambda: crf_jax.hcrf_log_probs(hcrf, X), lambda: crf_jax.hcrf_predict(hcrf, X),
                 lambda: crf_jax.fcrf_marginals(fcrf, X), lambda: crf_jax.fcrf_segment_log_probs(fcrf, X),
                 lambda: crf_jax.fcrf_predict_segments(fcrf, X),
                 lambda: crf_jax.fit_hcrf(X, np.zeros(B, np.int32), n_labels=KA, options=FIT),
                 lambda: crf_jax.fit_fcrf(X, np.zeros((B, T), np.int32), np.zeros((B, T), np.int32), options=FIT)):
        with pytest.raises(ValueError, match="^X: "):
            call()
    with pytest.raises(ValueError, match="^method: "):
        crf_jax.fcrf_marginals(fcrf, np.zeros((B, T, D)), method="gibbs")
    with pytest.raises(ValueError, match="^n_iter: "):
        crf_jax.fcrf_marginals(fcrf, np.zeros((B, T, D)), method="loopy", n_iter=0)
    with pytest.raises(ValueError, match="^y: "):
        crf_jax.fit_hcrf(np.zeros((B, T, D)), [0, KA], n_labels=KA, options=FIT)
    with pytest.raises(ValueError, match="^y_object: "):
        crf_jax.fit_fcrf(np.zeros((B, T, D)), np.zeros((B, T), np.int32), np.full((B, T), -1), options=FIT)
    with pytest.raises(ValueError, match="^inference: "):
        crf_jax.fit_fcrf(np.zeros((B, T, D)), np.zeros((B, T), np.int32), np.zeros((B, T), np.int32),
                         inference="gibbs", options=FIT)


@FEW
@given(X=features, lengths=lengths_st, y=labels_st)
def test_fit_hcrf_and_fcrf_promise(X, lengths, y):
    ya, yo = y % KA, (y // KA) % KO
    model, info = crf_jax.fit_hcrf(X, ya[:, 0], lengths, n_labels=KA, n_hidden=H, connectivity=C, options=FIT)
    assert model.structure == crf_jax.HCRFStructure(KA, H, D, C)
    assert all(np.all(np.isfinite(np.asarray(leaf))) for leaf in model) and not bool(info.diverged)
    model, info = crf_jax.fit_fcrf(X, ya, yo, lengths, n_actions=KA, n_objects=KO, connectivity=C, options=FIT)
    assert model.structure == crf_jax.FCRFStructure(KA, KO, D, C)
    assert all(np.all(np.isfinite(np.asarray(leaf))) for leaf in jax.tree_util.tree_leaves(model))
    assert not bool(info.diverged)


# ----------------------------------------------------------------------------------------------
# linear baselines
# ----------------------------------------------------------------------------------------------
vectors = float_arrays((N, D), -10.0, 10.0)


@SETTINGS
@given(model=linear_models, X=vectors, scale=scales)
def test_linear_predict_promise(model, X, scale):
    pred = np.asarray(crf_jax.linear_predict(model, X * scale))
    assert pred.shape == (N,) and np.all((pred >= 0) & (pred < K))
    lp = assert_log_probs(crf_jax.linear_log_proba(model, X * scale), (N, K))
    np.testing.assert_allclose(lse(lp, 1), 0.0, atol=1e-5)


@FEW
@given(X=vectors, y=hnp.arrays(np.int32, (N,), elements=st.integers(0, K - 1)))
def test_fit_linear_promise(X, y):
    model, info = crf_jax.fit_linear(X, y, n_labels=K, options=crf_jax.FitOptions.for_linear(max_iter=3))
    assert model.structure == crf_jax.LinearStructure(K, D)
    assert all(np.all(np.isfinite(np.asarray(leaf))) for leaf in model) and not bool(info.diverged)


@SETTINGS
@given(model=linear_models, where=st.tuples(st.integers(0, N - 1), st.integers(0, D - 1)), bad=bad_values)
def test_linear_rejects_bad_input_by_name(model, where, bad):
    X = np.zeros((N, D))
    X[where] = bad
    for call in (crf_jax.linear_predict, crf_jax.linear_log_proba):
        with pytest.raises(ValueError, match="^X: "):
            call(model, X)
    with pytest.raises(ValueError, match="^X: "):
        crf_jax.fit_linear(X, np.zeros(N, np.int32))
    with pytest.raises(ValueError, match="^X: "):
        crf_jax.linear_predict(model, np.zeros((N, D + 1)))
    with pytest.raises(ValueError, match="^kind: "):
        crf_jax.fit_linear(np.zeros((N, D)), np.zeros(N, np.int32), kind="tree")


# ----------------------------------------------------------------------------------------------
# CHCRF fusion, co-occurrence, object history
# ----------------------------------------------------------------------------------------------
log_scores = st.one_of(st.floats(-30.0, 5.0), st.just(-np.inf))
rates = st.one_of(st.floats(0.0, 1.0), st.just(0.0))


@SETTINGS
@given(la=hnp.arrays(np.float64, (3, KA), elements=log_scores), lo=hnp.arrays(np.float64, (3, KO + 1), elements=log_scores),
       cooc=hnp.arrays(np.float64, (KA, KO + 1), elements=rates))
# found by CI: every product but -inf is a rate of 5e-324 (log -744), and the fused marginals summed to
# exp(-2e-5) while joint - log Z lost float32 digits to that magnitude
@example(la=np.array([[-np.inf, 0.0], [0.0, 0.0], [0.0, 0.0]]), lo=np.zeros((3, 3)),
         cooc=np.array([[1.0, 5e-324, 5e-324], [5e-324, 5e-324, 5e-324]]))
def test_fuse_promise(la, lo, cooc):
    if cooc.sum() <= 0:
        with pytest.raises(ValueError, match="^cooc: "):
            crf_jax.fuse(la, lo, cooc)
        return
    res = crf_jax.fuse(la, lo, cooc)
    with np.errstate(divide="ignore"):
        ref = np.log(cooc)[None] + la[:, :, None] + lo[:, None, :]
    impossible = np.all(ref == -np.inf, axis=(1, 2))
    np.testing.assert_array_equal(res.impossible, impossible)
    joint = np.asarray(res.log_joint, np.float64)
    assert joint.shape == (3, KA, KO + 1) and not np.any(np.isnan(joint))
    for field in ("log_z", "log_action", "log_object"):
        assert not np.any(np.isnan(np.asarray(getattr(res, field)))), field
    assert np.all(joint[impossible] == -np.inf) and np.all(np.asarray(res.log_z)[impossible] == -np.inf)
    ok = ~impossible
    if ok.any():
        ref_z = lse(ref[ok].reshape(ok.sum(), -1), 1)
        np.testing.assert_allclose(np.asarray(res.log_z)[ok], ref_z, rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(np.exp(joint[ok]), np.exp(ref[ok] - ref_z[:, None, None]), atol=1e-5)
        np.testing.assert_allclose(lse(np.asarray(res.log_action)[ok], 1), 0.0, atol=1e-5)
        np.testing.assert_allclose(lse(np.asarray(res.log_object)[ok], 1), 0.0, atol=1e-5)


@SETTINGS
@given(bad=st.sampled_from([np.nan, np.inf, 1e39]), which=st.sampled_from(["log_p_action", "log_p_object"]),
       where=st.tuples(st.integers(0, 1), st.integers(0, 1)))
def test_fuse_rejects_bad_input_by_name(bad, which, where):
    args = {"log_p_action": np.zeros((2, KA)), "log_p_object": np.zeros((2, KO))}
    args[which][where] = bad
    with pytest.raises(ValueError, match=f"^{which}: "):
        crf_jax.fuse(args["log_p_action"], args["log_p_object"], np.ones((KA, KO)))
    with pytest.raises(ValueError, match="^cooc: "):
        crf_jax.fuse(np.zeros((2, KA)), np.zeros((2, KO)), -np.ones((KA, KO)))
    with pytest.raises(ValueError, match="^cooc: "):
        crf_jax.fuse(np.zeros((2, KA)), np.zeros((2, KO)), np.ones((KA + 1, KO)))
    with pytest.raises(ValueError, match="^log_p_object: "):
        crf_jax.fuse(np.zeros((2, KA)), np.zeros((3, KO)), np.ones((KA, KO)))


@SETTINGS
@given(pairs=st.lists(st.tuples(st.integers(0, KA - 1), st.integers(0, KO - 1)), max_size=8),
       smoothing=st.one_of(st.just(0.0), st.floats(1e-3, 10.0)))
def test_cooccurrence_promise(pairs, smoothing):
    actions, objects = [a for a, _ in pairs], [o for _, o in pairs]
    if not pairs and smoothing == 0.0:
        with pytest.raises(ValueError, match="^actions: "):
            crf_jax.cooccurrence(actions, objects, KA, KO, smoothing=smoothing)
        return
    k = np.asarray(crf_jax.cooccurrence(actions, objects, KA, KO, smoothing=smoothing), np.float64)
    counts = np.zeros((KA, KO))
    np.add.at(counts, (np.asarray(actions, int), np.asarray(objects, int)), 1.0)
    np.testing.assert_allclose(k, (counts + smoothing) / (counts + smoothing).sum(), rtol=1e-5)
    with pytest.raises(ValueError, match="^actions: "):
        crf_jax.cooccurrence(actions + [KA], objects + [0], KA, KO, smoothing=smoothing)
    with pytest.raises(ValueError, match="^objects: "):
        crf_jax.cooccurrence(actions + [0], objects + [-1], KA, KO, smoothing=smoothing)
    with pytest.raises(ValueError, match="^smoothing: "):
        crf_jax.cooccurrence(actions, objects, KA, KO, smoothing=-smoothing - 1.0)


@SETTINGS
@given(history=hnp.arrays(np.float64, (2, KA, KO), elements=st.floats(0.0, 1.0)),
       positions=float_arrays((2, 3), -1.0, 1.0), position=float_arrays((3,), -1.0, 1.0), d0=st.floats(1e-3, 10.0),
       log_joint=hnp.arrays(np.float64, (KA, KO), elements=log_scores))
def test_history_prior_and_apply_history_promise(history, positions, position, d0, log_joint):
    prior = np.asarray(crf_jax.history_prior(history, positions, position, default_distance=d0))
    assert prior.shape == (KA, KO) and np.all(np.isfinite(prior)) and np.all(prior > 0)
    if np.all(log_joint == -np.inf):
        with pytest.raises(ValueError, match="^log_joint: "):
            crf_jax.apply_history(log_joint, prior)
        return
    post = crf_jax.apply_history(log_joint, prior)
    lj = np.asarray(post.log_joint, np.float64)
    assert lj.shape == (KA, KO) and not np.any(np.isnan(lj)) and np.isfinite(float(post.log_normaliser))
    np.testing.assert_allclose(lse(lj.reshape(-1), 0), 0.0, atol=1e-5)
    assert np.all(lj[log_joint == -np.inf] == -np.inf)


@SETTINGS
@given(bad=st.sampled_from([np.nan, np.inf, -1.0]), d0=st.sampled_from([0.0, -1.0, np.nan]))
def test_history_rejects_bad_input_by_name(bad, d0):
    hist, pos, p = np.ones((2, KA, KO)), np.zeros((2, 3)), np.zeros(3)
    with pytest.raises(ValueError, match="^default_distance: "):
        crf_jax.history_prior(hist, pos, p, default_distance=d0)
    bad_hist = hist.copy()
    bad_hist[1, 0, 1] = bad
    with pytest.raises(ValueError, match="^history: "):
        crf_jax.history_prior(bad_hist, pos, p, default_distance=1.0)
    with pytest.raises(ValueError, match="^position: "):
        crf_jax.history_prior(hist, pos, np.array([0.0, bad if bad != -1.0 else np.nan, 0.0]), default_distance=1.0)
    with pytest.raises(ValueError, match="^history_positions: "):
        crf_jax.history_prior(hist, pos[:1], p, default_distance=1.0)
    with pytest.raises(ValueError, match="^prior: "):
        crf_jax.apply_history(np.zeros((KA, KO)), np.full((KA, KO), bad))
    with pytest.raises(ValueError, match="^log_joint: "):
        crf_jax.apply_history(np.full((KA, KO), np.nan if bad != np.inf else np.inf), np.ones((KA, KO)))


# ----------------------------------------------------------------------------------------------
# solver, options, init, persistence
# ----------------------------------------------------------------------------------------------
def _quadratic(params, target):
    return jnp.sum(jnp.square(params - target))


@SETTINGS
@given(target=float_arrays((3,), -100.0, 100.0), method=st.sampled_from(["lbfgs", "adam"]))
def test_minimize_promise(target, method):
    res = crf_jax.minimize(_quadratic, jnp.zeros(3), jnp.asarray(target, jnp.float32),
                           options=crf_jax.FitOptions(method=method, max_iter=20, learning_rate=0.5))
    info = res.info
    assert np.all(np.isfinite(np.asarray(res.model))) and not bool(info.diverged)
    n = int(info.n_iter)
    assert 1 <= n <= 20 and np.all(np.isfinite(np.asarray(info.loss)[:n]))
    assert np.all(np.isnan(np.asarray(info.loss)[n:]))
    if method == "lbfgs":
        np.testing.assert_allclose(res.model, target, rtol=1e-4, atol=1e-3)


BAD_OPTIONS = {
    "method": st.sampled_from(["sgd", "", None, 1]),
    "optimizer": st.sampled_from(["adam", 1.0]),
    "max_iter": st.sampled_from([0, -1, 2.0, True, None]),
    "memory_size": st.sampled_from([0, 1.5]),
    "learning_rate": st.sampled_from([0.0, -1.0, np.nan, np.inf, "0.1"]),
    "gtol": st.sampled_from([-1e-3, np.nan]),
    "delta": st.sampled_from([-1e-3, np.inf]),
    "period": st.sampled_from([0, 1.0]),
    "patience": st.sampled_from([0, -2]),
    "eval_every": st.sampled_from([0, False]),
}


@SETTINGS
@given(data=st.data(), field=st.sampled_from(sorted(BAD_OPTIONS)))
def test_fit_options_reject_bad_fields_by_name(data, field):
    value = data.draw(BAD_OPTIONS[field])
    with pytest.raises(ValueError, match=f"^{field}: "):
        crf_jax.FitOptions(**{field: value})
    assert dataclasses.replace(crf_jax.FitOptions(), max_iter=7).max_iter == 7


@pytest.mark.parametrize("seed", [0, 1])
def test_init_shapes_and_structures(seed):
    d, k, c = D, K, C  # fixed shapes: one compilation of the random initialisers
    key = jax.random.PRNGKey(seed)
    chain = crf_jax.init_chain(d, k, c, key=key, scale=0.5)
    assert chain.structure == crf_jax.ChainStructure(k, d, c)
    assert crf_jax.init_hcrf(key, d, k, 2, c).structure == crf_jax.HCRFStructure(k, 2, d, c)
    assert crf_jax.init_fcrf(d, k, k + 1, c).structure == crf_jax.FCRFStructure(k, k + 1, d, c)
    assert crf_jax.init_linear(d, k).structure == crf_jax.LinearStructure(k, d)
    for model in (chain, crf_jax.init_hcrf(key, d, k, 2, c)):
        assert all(np.all(np.isfinite(np.asarray(leaf))) for leaf in model)
    with pytest.raises(ValueError, match="^n_labels: "):
        crf_jax.ChainStructure(0, d, c)
    with pytest.raises(ValueError, match="^connectivity: "):
        crf_jax.ChainStructure(k, d, -1)


@SETTINGS
@given(model=st.one_of(chain_models, hcrf_models, fcrf_models, linear_models),
       name=st.sampled_from(["model", "model.npz", "a.b"]))
def test_save_load_round_trip(model, name):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / name
        crf_jax.save(str(path), model)
        loaded = crf_jax.load(str(path))  # the same path string loads
        assert type(loaded) is type(model) and loaded.structure == model.structure
        for a, b in zip(jax.tree_util.tree_leaves(model), jax.tree_util.tree_leaves(loaded)):
            np.testing.assert_array_equal(a, b)
        with pytest.raises(ValueError, match="^path: "):
            crf_jax.load(str(path), model_type=int)
    with pytest.raises(ValueError, match="^model: "):
        crf_jax.save(str(Path(tmp) / "x"), {"weights": np.zeros(2)})
