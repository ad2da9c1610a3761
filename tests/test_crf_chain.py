"""Linear-chain CRF: exact inference against brute-force enumeration, padding, gradients, training."""
import dataclasses
import itertools

import chex
import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

import crf_jax
from crf_jax._src import chain as chain, inference as inference, train as train

K, T = 3, 5
# jitted once per shape: eager op-by-op dispatch would dominate the test time
LOG_Z = jax.jit(inference.log_partition, static_argnames="method")
MARGINALS = jax.jit(inference.marginals)
VITERBI = jax.jit(inference.viterbi)
CONST = jax.jit(inference.constant_path_log_prob)
FB = jax.jit(inference.forward_backward)


@pytest.fixture
def x64():
    with jax.enable_x64(True):
        yield


def _enumerate(unary, trans, length):
    """All K^length label sequences with their log scores (float64 numpy reference)."""
    paths = np.array(list(itertools.product(range(unary.shape[1]), repeat=length)))
    scores = unary[np.arange(length), paths].sum(1) + trans[paths[:, :-1], paths[:, 1:]].sum(1)
    return paths, scores


def _lse(a):
    m = np.max(a)
    return m + np.log(np.sum(np.exp(a - m)))


def _problem(seed, k=K, t=T):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(t, k)) * 1.5, rng.normal(size=(k, k))


@pytest.mark.parametrize("length", [1, 2, 5])
def test_log_partition_marginals_viterbi_match_enumeration(x64, length):
    unary, trans = _problem(length)
    paths, scores = _enumerate(unary, trans, length)
    log_z = _lse(scores)
    u, tr = jnp.asarray(unary), jnp.asarray(trans)
    np.testing.assert_allclose(LOG_Z(u, tr, length), log_z, rtol=1e-12)
    np.testing.assert_allclose(LOG_Z(u, tr, length, method="assoc"), log_z, rtol=1e-12)
    probs = np.exp(scores - log_z)
    node_ref = np.zeros((T, K))
    pair_ref = np.zeros((T - 1, K, K))
    for p, pr in zip(paths, probs):
        node_ref[np.arange(length), p] += pr
        pair_ref[np.arange(length - 1), p[:-1], p[1:]] += pr
    node, pair = MARGINALS(u, tr, length)
    chex.assert_shape(node, (T, K))
    chex.assert_shape(pair, (T - 1, K, K))
    np.testing.assert_allclose(node, node_ref, atol=1e-12)
    np.testing.assert_allclose(pair, pair_ref, atol=1e-12)
    labels, best = VITERBI(u, tr, length)
    chex.assert_shape(labels, (T,))
    chex.assert_rank(best, 0)
    expect = np.full(T, -1)
    expect[:length] = paths[np.argmax(scores)]
    np.testing.assert_array_equal(labels, expect)
    np.testing.assert_allclose(best, scores.max(), rtol=1e-12)
    # pre-segmented classifier: probabilities of the constant paths
    const = [np.exp(scores[np.all(paths == k, axis=1)][0] - log_z) for k in range(K)]
    np.testing.assert_allclose(np.exp(CONST(u, tr, length)), const, rtol=1e-10)


def test_forbidden_transitions_and_extreme_ranges_stay_exact(x64):
    unary, trans = _problem(7)
    trans[0, 1] = trans[2, 2] = -np.inf  # forbidden
    u, tr = jnp.asarray(unary), jnp.asarray(trans)
    paths, scores = _enumerate(unary, trans, T)
    np.testing.assert_allclose(LOG_Z(u, tr, T), _lse(scores), rtol=1e-12)
    node, pair = MARGINALS(u, tr, T)
    assert np.all(np.asarray(pair)[:, 0, 1] == 0) and np.all(np.asarray(pair)[:, 2, 2] == 0)
    g = jax.grad(lambda t: LOG_Z(u, t, T))(tr)
    assert np.all(np.isfinite(g))
    # ranges far beyond exp's: the fast max-shifted product underflows, the exact fallback takes over
    big = trans * 400.0
    paths, scores = _enumerate(unary, big, T)
    np.testing.assert_allclose(LOG_Z(u, jnp.asarray(big), T), _lse(scores), rtol=1e-12)
    with jax.enable_x64(False):
        big32 = jnp.asarray(np.where(np.isfinite(big), big, -np.inf), jnp.float32)
        v = LOG_Z(jnp.asarray(unary, jnp.float32), big32, T)
        np.testing.assert_allclose(v, _lse(scores), rtol=1e-5)


def test_batched_and_single_sequence_agree(x64):
    rng = np.random.default_rng(3)
    unary = jnp.asarray(rng.normal(size=(4, T, K)))
    trans = jnp.asarray(rng.normal(size=(K, K)))
    lengths = jnp.array([5, 1, 3, 4])
    batch = LOG_Z(unary, trans, lengths)
    chex.assert_shape(batch, (4,))
    single = [LOG_Z(unary[b], trans, lengths[b]) for b in range(4)]
    np.testing.assert_allclose(batch, single, rtol=1e-12)
    alpha, beta, log_z = FB(unary, trans, lengths)
    chex.assert_shape([alpha, beta], (4, T, K))
    for b in range(4):  # sum_k alpha_t + beta_t = log Z at every real frame
        lz = jax.nn.logsumexp(alpha[b, : lengths[b]] + beta[b, : lengths[b]], axis=-1)
        np.testing.assert_allclose(lz, log_z[b], rtol=1e-12)


def _random_model(seed, d=4, k=K, connectivity=1):
    rng = np.random.default_rng(seed)
    w = 2 * connectivity + 1
    return crf_jax.ChainCRF(jnp.asarray(rng.normal(size=(w, d, k)) * 0.5), jnp.asarray(rng.normal(size=k)),
                            jnp.asarray(rng.normal(size=(k, k))))


def test_connectivity_window_matches_explicit_stacking(x64):
    rng = np.random.default_rng(4)
    model = _random_model(4, connectivity=2)
    X = rng.normal(size=(2, 6, 4))
    lengths = np.array([6, 4])
    unary = chain.unary_potentials(model, jnp.asarray(X), jnp.asarray(lengths))
    chex.assert_shape(unary, (2, 6, K))
    unary = np.asarray(unary)
    W = np.asarray(model.weights)
    for b in range(2):
        Xb = np.zeros((6 + 4, 4))
        Xb[2 : 2 + lengths[b]] = X[b, : lengths[b]]  # zeros outside the real sequence
        for t in range(lengths[b]):
            window = Xb[t : t + 5]  # x_{t-2..t+2}
            ref = np.einsum("cd,cdk->k", window, W) + np.asarray(model.bias)
            np.testing.assert_allclose(unary[b, t], ref, rtol=1e-12)


def test_padding_changes_neither_values_nor_gradients():
    """grad of the objective on a padded batch == grad on the unpadded sequences, and NaN-free."""
    rng = np.random.default_rng(5)
    model = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float32), _random_model(5))
    lengths = np.array([6, 3, 1])
    X = rng.normal(size=(3, 6, 4)).astype(np.float32)
    y = rng.integers(0, K, size=(3, 6)).astype(np.int32)
    X[1, 3:] = 1e6  # garbage in the padding (finite: the public API zeroes NaN padding itself)
    y[1, 3:] = 2

    def loss(m, Xb, yb, lb):
        return jnp.sum(chain.nll(m, jnp.asarray(Xb), jnp.asarray(yb), jnp.asarray(lb)))

    val, grad = jax.value_and_grad(loss)(model, X, y, lengths)
    ref_val, ref_grad = 0.0, jax.tree_util.tree_map(jnp.zeros_like, model)
    for b in range(3):
        L = lengths[b]
        v, g = jax.value_and_grad(loss)(model, X[b : b + 1, :L], y[b : b + 1, :L], lengths[b : b + 1])
        ref_val += v
        ref_grad = jax.tree_util.tree_map(jnp.add, ref_grad, g)
    np.testing.assert_allclose(val, ref_val, rtol=1e-5)
    for a, b in zip(jax.tree_util.tree_leaves(grad), jax.tree_util.tree_leaves(ref_grad)):
        assert np.all(np.isfinite(a))
        np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)
    # NaN in padding through the public API: identical result
    Xn = X.copy()
    Xn[1, 3:] = np.nan
    np.testing.assert_allclose(crf_jax.log_likelihood(model, Xn, y, lengths),
                               crf_jax.log_likelihood(model, X, y, lengths), rtol=1e-6)


def test_objective_gradient_matches_finite_differences(x64):
    rng = np.random.default_rng(6)
    model = _random_model(6)
    X = jnp.asarray(rng.normal(size=(3, 5, 4)))
    y = jnp.asarray(rng.integers(0, K, size=(3, 5)))
    lengths = jnp.array([5, 2, 4])
    data = (X, y, lengths, 0.3)
    flat, unravel = jax.flatten_util.ravel_pytree(model)
    f = lambda v: train.chain_objective(unravel(v), data)  # noqa: E731
    g = jax.grad(f)(flat)
    eps = 1e-6
    idx = rng.choice(flat.size, 12, replace=False)
    for i in idx:
        e = jnp.zeros_like(flat).at[i].set(eps)
        fd = (f(flat + e) - f(flat - e)) / (2 * eps)
        np.testing.assert_allclose(g[i], fd, rtol=1e-6, atol=1e-8)


def test_marginals_are_the_gradient_of_log_z(x64):
    unary, trans = _problem(8)
    node, pair = MARGINALS(jnp.asarray(unary), jnp.asarray(trans), 4)
    gu, gt = jax.grad(inference.log_partition, argnums=(0, 1))(jnp.asarray(unary), jnp.asarray(trans), 4)
    np.testing.assert_allclose(gu, node, atol=1e-12)
    np.testing.assert_allclose(gt, pair.sum(0), atol=1e-12)


def _toy_data(rng, n, t=12, d=3, k=3):
    y = np.zeros((n, t), np.int32)
    y[:, 0] = rng.integers(0, k, n)
    for s in range(1, t):
        stay = rng.random(n) < 0.8
        y[:, s] = np.where(stay, y[:, s - 1], rng.integers(0, k, n))
    mu = np.eye(k, d) * 1.2
    X = (mu[y] + rng.normal(size=(n, t, d))).astype(np.float32)
    return X, y


def test_fit_chain_learns_and_stops_by_tolerance_and_early_stopping():
    rng = np.random.default_rng(7)
    X, y = _toy_data(rng, 60)
    lengths = rng.integers(4, 13, 60)
    model, info = crf_jax.fit_chain(X, y, lengths, n_labels=3, l2=0.1, options=crf_jax.FitOptions(max_iter=100))
    assert isinstance(model, crf_jax.ChainCRF) and model.structure == crf_jax.ChainStructure(3, 3, 0)
    chex.assert_shape(info.loss, (100,))
    assert bool(info.converged) and int(info.n_iter) < 100
    losses = np.asarray(info.loss)[: int(info.n_iter)]
    assert losses[-1] < losses[0]
    Xt, yt = _toy_data(rng, 40)
    pred = crf_jax.predict(model, Xt)
    assert isinstance(pred, jax.Array)
    chex.assert_shape(pred, yt.shape)
    pred = np.asarray(pred)
    frame_only = np.argmax(Xt @ np.eye(3, 3).T, axis=-1)  # the class-mean direction alone, no chain
    assert np.mean(pred == yt) > np.mean(frame_only == yt) + 0.05
    # marginals of the fitted model are distributions
    marg = crf_jax.predict_marginals(model, Xt[:3], [12, 5, 1])
    chex.assert_shape(marg, (3, 12, 3))
    np.testing.assert_allclose(marg.sum(-1), (np.arange(12)[None] < np.array([[12], [5], [1]])).astype(float),
                               atol=1e-5)
    # early stopping with Adam and a validation split returns the best-validation iterate
    adam = crf_jax.FitOptions(method="adam", learning_rate=0.5, max_iter=60, patience=3)
    model2, info2 = crf_jax.fit_chain(X, y, lengths, n_labels=3, l2=0.0, validation=(Xt, yt), options=adam)
    val = np.asarray(info2.val_loss)[: int(info2.n_iter)]
    assert int(info2.best_iter) == int(np.nanargmin(val)) + 1
    nll_best = -np.sum(np.asarray(crf_jax.log_likelihood(model2, Xt, yt)))
    np.testing.assert_allclose(nll_best, np.nanmin(val), rtol=1e-4)


def test_bad_input_raises_value_error():
    model = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float32), _random_model(9, connectivity=0))
    X = np.zeros((2, 4, 4), np.float32)
    y = np.zeros((2, 4), np.int32)
    with pytest.raises(ValueError, match="lengths"):
        crf_jax.predict(model, X, [4, 0])
    with pytest.raises(ValueError, match="lengths"):
        crf_jax.predict(model, X, [5, 1])
    with pytest.raises(ValueError, match="X"):
        crf_jax.predict(model, np.zeros((2, 0, 4)))
    with pytest.raises(ValueError, match="X"):
        crf_jax.predict(model, np.zeros((2, 4, 5)))  # wrong D
    Xn = X.copy()
    Xn[0, 1, 2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        crf_jax.predict(model, Xn)
    bad = y.copy()
    bad[1, 2] = 3
    with pytest.raises(ValueError, match="y: labels must be in"):
        crf_jax.fit_chain(X, bad, n_labels=3)
    with pytest.raises(ValueError, match="y"):
        crf_jax.fit_chain(X, y[:1], n_labels=3)
    with pytest.raises(ValueError, match="options"):
        crf_jax.fit_chain(X, y, n_labels=3, options={"method": "adam"})
    with pytest.raises(ValueError, match="l2"):
        crf_jax.fit_chain(X, y, n_labels=3, l2=-1.0)
    with pytest.raises(ValueError, match="length 0"):
        crf_jax.pad_sequences([np.zeros((3, 2)), np.zeros((0, 2))])


@pytest.mark.parametrize("field, value", [
    ("method", "sgd"), ("optimizer", "adam"), ("max_iter", 0), ("memory_size", 1.5), ("learning_rate", 0.0),
    ("gtol", -1.0), ("delta", float("nan")), ("period", 0), ("patience", 0), ("eval_every", True),
])
def test_fit_options_reject_bad_fields_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        crf_jax.FitOptions(**{field: value})


def test_fit_options_defaults_and_linear_defaults():
    assert crf_jax.FitOptions() == crf_jax.FitOptions(method="lbfgs", max_iter=200, learning_rate=0.05, gtol=1e-5,
                                                      delta=1e-5, period=10, patience=5, eval_every=1)
    svm = crf_jax.FitOptions.for_linear("svm", max_iter=50)
    assert (svm.method, svm.max_iter, svm.learning_rate, svm.delta, svm.patience) == ("adam", 50, 0.01, 1e-6, 10)
    assert crf_jax.FitOptions.for_linear("logistic").method == "lbfgs"
    with pytest.raises(ValueError, match="kind"):
        crf_jax.FitOptions.for_linear("tree")


def _quadratic(params, data):
    _TRACES.append(1)
    return jnp.sum(jnp.square(params - data))


_TRACES: list = []


def test_traced_options_do_not_recompile_and_any_optax_optimizer_works():
    target = jnp.arange(3.0)
    base = crf_jax.FitOptions(method="adam", max_iter=30, learning_rate=0.1)
    first = crf_jax.minimize(_quadratic, jnp.zeros(3), target, options=base)
    n_traces = len(_TRACES)
    for change in (dict(gtol=1e-3), dict(delta=1e-2), dict(learning_rate=0.3), dict(period=3), dict(patience=2)):
        crf_jax.minimize(_quadratic, jnp.zeros(3), target, options=dataclasses.replace(base, **change))
    assert len(_TRACES) == n_traces  # tolerances, learning rate and counts are traced, not static
    assert isinstance(first, crf_jax.FitResult) and float(first.info.loss[0]) < 14.0
    sgd = crf_jax.FitOptions(optimizer=optax.sgd(0.25), max_iter=100, gtol=1e-6)
    model, info = crf_jax.minimize(_quadratic, jnp.zeros(3), target, options=sgd)
    np.testing.assert_allclose(model, target, atol=1e-4)
    assert bool(info.converged)


# ----------------------------------------------------------------------------------------------
# large features: float32 cancellation and overflow
# ----------------------------------------------------------------------------------------------
def test_marginals_sum_to_one_for_large_features():
    """float32 cancellation in exp(alpha + beta - log Z) made rows sum to 1.016 at 1e4 and 1.63 at 1e6."""
    rng = np.random.default_rng(17)
    model = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float32), _random_model(17, connectivity=1))
    X = rng.normal(size=(3, 8, 4))
    lengths = np.array([8, 5, 1])
    real = (np.arange(8)[None] < lengths[:, None]).astype(float)
    for scale in (1e4, 1e6, 1e20):
        marg = np.asarray(crf_jax.predict_marginals(model, X * scale, lengths), np.float64)
        assert np.all(np.isfinite(marg)) and np.all(marg >= 0) and np.all(marg <= 1 + 1e-6)
        np.testing.assert_allclose(marg.sum(-1), real, atol=1e-5)
        with jax.enable_x64(True):  # the float64 reference of the same model
            ref = np.asarray(crf_jax.predict_marginals(jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float64),
                                                                              model), X * scale, lengths))
        np.testing.assert_allclose(marg, ref, atol=1e-3)
        lp = np.asarray(crf_jax.segment_log_probs(model, X * scale, lengths))
        assert np.all(np.isfinite(lp)) and np.all(lp <= 0)


def test_overflow_is_rejected_and_a_non_finite_objective_never_converges():
    rng = np.random.default_rng(16)
    X, y = _toy_data(rng, 4, t=6)
    huge = X.astype(np.float64) / np.abs(X).max() * 1e39  # finite in float64, not in float32
    # rejected by name, not fitted to zero weights with converged=True / predicted as label 0
    with pytest.raises(ValueError, match="X: values up to 1e\\+39 overflow float32"):
        crf_jax.fit_chain(huge, y, n_labels=3)
    model = crf_jax.init_chain(3, 3, key=jax.random.PRNGKey(0), scale=1.0)
    with pytest.raises(ValueError, match="X: values up to"):
        crf_jax.predict(model, huge)
    with pytest.raises(ValueError, match="X: values up to"):
        crf_jax.predict_marginals(model, huge)
    # finite in float32, but the gradient at the start overflows: a named error, not converged=True
    with pytest.raises(ValueError, match="X: the fit_chain objective or its gradient is not finite"):
        crf_jax.fit_chain(np.full(X.shape, 3e38), np.zeros_like(y), n_labels=3,
                          options=crf_jax.FitOptions(max_iter=5))
    with pytest.raises(ValueError, match="init: contains NaN"):
        crf_jax.fit_chain(X, y, n_labels=3, init=model._replace(bias=jnp.full(3, jnp.nan)))
    # an objective that turns NaN mid-way: stopped at the last finite point, diverged, never converged
    res = crf_jax.minimize(_nan_beyond_one, jnp.zeros(2), jnp.full(2, 3.0),
                           options=crf_jax.FitOptions(method="adam", learning_rate=0.3, max_iter=50))
    assert bool(res.info.diverged) and not bool(res.info.converged)
    assert np.all(np.isfinite(np.asarray(res.model))) and np.all(np.asarray(res.model) <= 1.0)
    n = int(res.info.n_iter)
    assert 0 < n < 50 and np.all(np.isfinite(np.asarray(res.info.loss)[:n]))
    # ... and a NaN start does not iterate at all
    res = crf_jax.minimize(_nan_beyond_one, jnp.full(2, 2.0), jnp.full(2, 3.0),
                           options=crf_jax.FitOptions(method="adam", max_iter=50))
    assert bool(res.info.diverged) and not bool(res.info.converged) and int(res.info.n_iter) == 0
    # a normal fit is not diverged
    _, info = crf_jax.fit_chain(X, y, n_labels=3, options=crf_jax.FitOptions(max_iter=5))
    assert not bool(info.diverged)


def _nan_beyond_one(params, target):
    """(params - target)^2, NaN once any parameter exceeds 1."""
    return jnp.where(jnp.all(params <= 1.0), jnp.sum(jnp.square(params - target)), jnp.nan)
