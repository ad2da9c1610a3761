"""HCRF, FCRF (exact and loopy BP), CHCRF fusion and history prior, linear baselines."""
import itertools

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import crf_jax
from crf_jax._src import fcrf as fcrf, hcrf as hcrf


@pytest.fixture
def x64():
    with jax.enable_x64(True):
        yield


def _lse(a, axis=None):
    m = np.max(a, axis=axis, keepdims=True)
    return np.squeeze(m + np.log(np.sum(np.exp(a - m), axis=axis, keepdims=True)), axis=axis)


# ----------------------------------------------------------------------------------------------
# HCRF
# ----------------------------------------------------------------------------------------------
def test_hcrf_log_probs_match_enumeration_over_hidden_paths(x64):
    rng = np.random.default_rng(0)
    D, K, H, T = 3, 2, 2, 4
    model = crf_jax.HCRF(jnp.asarray(rng.normal(size=(3, D, K, H))), jnp.asarray(rng.normal(size=(K, H))),
                         jnp.asarray(rng.normal(size=(K, H, H))))  # connectivity 1
    X = rng.normal(size=(2, T, D))
    lengths = np.array([4, 3])
    got = hcrf.log_probs_jit(model, jnp.asarray(X), jnp.asarray(lengths))
    chex.assert_shape(got, (2, K))
    got = np.asarray(got)
    W, b, tr = (np.asarray(a) for a in model)
    for n in range(2):
        L = lengths[n]
        Xp = np.zeros((T + 2, D))
        Xp[1 : 1 + L] = X[n, :L]
        unary = np.stack([np.einsum("cd,cdkh->kh", Xp[t : t + 3], W) + b for t in range(L)])  # (L, K, H)
        s = np.array([
            _lse(np.array([unary[np.arange(L), y, list(h)].sum() + sum(tr[y, h[t - 1], h[t]] for t in range(1, L))
                           for h in itertools.product(range(H), repeat=L)]))
            for y in range(K)
        ])
        np.testing.assert_allclose(got[n], s - _lse(s), rtol=1e-10)


def test_fit_hcrf_classifies_separable_sequences():
    rng = np.random.default_rng(1)
    y = rng.integers(0, 2, 40)
    X = rng.normal(size=(40, 8, 2)).astype(np.float32)
    X[:, :, 0] += np.where(y == 1, 1.5, -1.5)[:, None]
    model, info = crf_jax.fit_hcrf(X, y, n_hidden=2, l2=0.1, options=crf_jax.FitOptions(max_iter=50))
    assert model.structure == crf_jax.HCRFStructure(n_labels=2, n_hidden=2, n_features=2)
    pred = crf_jax.hcrf_predict(model, X)
    assert isinstance(pred, jax.Array)
    chex.assert_shape(pred, (40,))
    assert np.mean(np.asarray(pred) == y) > 0.9
    chex.assert_shape(crf_jax.hcrf_log_probs(model, X[:3]), (3, 2))
    with pytest.raises(ValueError, match="y"):
        crf_jax.fit_hcrf(X, np.append(y, 1), n_hidden=2)


# ----------------------------------------------------------------------------------------------
# FCRF
# ----------------------------------------------------------------------------------------------
def _fcrf_problem(seed, T=4, Ka=2, Ko=3, couple=1.0, to_scale=1.0):
    rng = np.random.default_rng(seed)
    return (rng.normal(size=(1, T, Ka)), rng.normal(size=(1, T, Ko)), rng.normal(size=(Ka, Ka)),
            to_scale * rng.normal(size=(Ko, Ko)), couple * rng.normal(size=(Ka, Ko)))


def _fcrf_enumerate(ua, uo, Ta, To, C, L):
    Ka, Ko = C.shape
    rows = []
    for a in itertools.product(range(Ka), repeat=L):
        for o in itertools.product(range(Ko), repeat=L):
            s = sum(ua[t, a[t]] + uo[t, o[t]] + C[a[t], o[t]] for t in range(L))
            s += sum(Ta[a[t - 1], a[t]] + To[o[t - 1], o[t]] for t in range(1, L))
            rows.append((a, o, s))
    scores = np.array([r[2] for r in rows])
    log_z = _lse(scores)
    ma, mo = np.zeros((ua.shape[0], Ka)), np.zeros((ua.shape[0], Ko))
    for a, o, s in rows:
        ma[np.arange(L), list(a)] += np.exp(s - log_z)
        mo[np.arange(L), list(o)] += np.exp(s - log_z)
    return log_z, ma, mo


def test_fcrf_exact_matches_enumeration(x64):
    ua, uo, Ta, To, C = _fcrf_problem(2)
    lengths = jnp.array([3])
    log_z, ma, mo = _fcrf_enumerate(ua[0], uo[0], Ta, To, C, 3)
    args = [jnp.asarray(a) for a in (ua, uo, Ta, To, C)]
    np.testing.assert_allclose(fcrf.exact_log_partition(*args, lengths), [log_z], rtol=1e-12)
    ga, go = fcrf.exact_marginals(*args, lengths)
    chex.assert_shape([ga, go], [(1, 4, 2), (1, 4, 3)])
    np.testing.assert_allclose(ga[0], ma, atol=1e-12)
    np.testing.assert_allclose(go[0], mo, atol=1e-12)


@pytest.mark.parametrize("case", ["comb", "single_frame"])
def test_loopy_bp_is_exact_on_trees(x64, case):
    # comb: object transitions constant -> the ladder's loops carry no information (a tree in effect);
    # single_frame: T = 1, the graph is one edge.
    if case == "comb":
        ua, uo, Ta, To, C = _fcrf_problem(3, T=5, to_scale=0.0, couple=2.0)
        lengths = jnp.array([5])
    else:
        ua, uo, Ta, To, C = _fcrf_problem(4, T=1, couple=2.0)
        lengths = jnp.array([1])
    args = [jnp.asarray(a) for a in (ua, uo, Ta, To, C)]
    bp = fcrf.loopy_bp(*args, lengths, n_iter=10)
    chex.assert_shape(bp.log_z, (1,))
    np.testing.assert_allclose(bp.log_z, fcrf.exact_log_partition(*args, lengths), rtol=1e-10)
    ea, eo = fcrf.exact_marginals(*args, lengths)
    np.testing.assert_allclose(bp.action, ea, atol=1e-10)
    np.testing.assert_allclose(bp.object, eo, atol=1e-10)


def test_loopy_bp_approximates_a_weakly_coupled_ladder(x64):
    ua, uo, Ta, To, C = _fcrf_problem(5, T=5, couple=0.3)
    args = [jnp.asarray(a) for a in (ua, uo, Ta, To, C)]
    lengths = jnp.array([5])
    bp = fcrf.loopy_bp(*args, lengths, n_iter=30)
    exact = fcrf.exact_log_partition(*args, lengths)
    assert abs(float(bp.log_z[0] - exact[0])) < 1e-2
    ea, _ = fcrf.exact_marginals(*args, lengths)
    np.testing.assert_allclose(bp.action, ea, atol=1e-2)
    # the gradient through the unrolled BP rounds is the gradient of the Bethe log Z (finite differences)
    def bethe(c):
        return fcrf.loopy_bp(args[0], args[1], args[2], args[3], c, lengths, n_iter=30).log_z.sum()

    g = np.asarray(jax.grad(bethe)(args[4]))
    eps = 1e-6
    for i, j in [(0, 0), (1, 2)]:
        e = jnp.zeros_like(args[4]).at[i, j].set(eps)
        np.testing.assert_allclose(g[i, j], (bethe(args[4] + e) - bethe(args[4] - e)) / (2 * eps), rtol=1e-5)


def test_fit_fcrf_exact_and_loopy_and_segments():
    rng = np.random.default_rng(6)
    B, T = 30, 6
    a = rng.integers(0, 2, B)
    o = a.copy()  # perfectly co-occurring pairs
    X = rng.normal(size=(B, T, 2)).astype(np.float32)
    X[:, :, 0] += np.where(a == 1, 1.0, -1.0)[:, None]
    ya, yo = np.repeat(a[:, None], T, 1), np.repeat(o[:, None], T, 1)
    lengths = rng.integers(3, T + 1, B)
    # exact inference with L-BFGS; loopy BP with Adam (one BP graph to compile instead of two: fast tests)
    for inference, method in (("exact", "lbfgs"), ("loopy", "adam")):
        options = crf_jax.FitOptions(method=method, learning_rate=0.1, max_iter=60)
        model, info = crf_jax.fit_fcrf(X, ya, yo, lengths, l2=0.1, inference=inference, options=options)
        pa, po = crf_jax.fcrf_predict_segments(model, X, lengths, method=inference)
        chex.assert_shape([pa, po], (B,))
        assert np.mean(np.asarray(pa) == a) > 0.8 and np.mean(np.asarray(po) == o) > 0.8
    assert model.structure == crf_jax.FCRFStructure(n_actions=2, n_objects=2, n_features=2)
    marg = crf_jax.fcrf_marginals(model, X, lengths)
    chex.assert_shape([marg.action, marg.object], (B, T, 2))
    lp = crf_jax.fcrf_segment_log_probs(model, X, lengths)
    chex.assert_shape(lp, (B, 2, 2))
    lp = np.asarray(lp)
    assert np.all(np.exp(lp).sum(axis=(1, 2)) <= 1 + 1e-5)
    with pytest.raises(ValueError, match="y_object"):
        crf_jax.fit_fcrf(X, ya, yo[:-1], lengths)


# ----------------------------------------------------------------------------------------------
# CHCRF
# ----------------------------------------------------------------------------------------------
def test_chcrf_fusion_and_normaliser_by_hand():
    K = crf_jax.cooccurrence([0, 0, 1, 2, 2, 2], [0, 0, 1, 1, 2, 2], 3, 3)
    assert isinstance(K, jax.Array)
    np.testing.assert_allclose(K, np.array([[2, 0, 0], [0, 1, 0], [0, 1, 2]]) / 6, rtol=1e-6)
    Ks = crf_jax.cooccurrence([0], [1], 2, 2, smoothing=0.5)
    np.testing.assert_allclose(Ks, np.array([[0.5, 1.5], [0.5, 0.5]]) / 3, rtol=1e-6)
    pa = np.array([[0.6, 0.3, 0.1]])
    po = np.array([[0.2, 0.5, 0.3]])
    res = crf_jax.fuse(np.log(pa), np.log(po), K)
    chex.assert_shape([res.log_joint, res.log_z, res.log_action, res.log_object], [(1, 3, 3), (1,), (1, 3), (1, 3)])
    joint = K * pa[0][:, None] * po[0][None, :]
    Z = joint.sum()  # = (2*0.6*0.2 + 0.3*0.5 + 0.1*0.5 + 2*0.1*0.3) / 6
    np.testing.assert_allclose(Z, (0.24 + 0.15 + 0.05 + 0.06) / 6)
    np.testing.assert_allclose(np.exp(res.log_z), [Z], rtol=1e-6)
    np.testing.assert_allclose(np.exp(res.log_joint[0]), joint / Z, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(np.exp(res.log_action[0]), (joint / Z).sum(1), rtol=1e-5)
    assert np.all(np.exp(res.log_joint[0])[K == 0] == 0)  # unseen pairs without smoothing: impossible
    with pytest.raises(ValueError, match="log_p_object"):
        crf_jax.fuse(np.log(pa), np.log(np.vstack([po, po])), K)
    with pytest.raises(ValueError, match="cooc"):
        crf_jax.fuse(np.log(pa), np.log(po), K[:2])
    with pytest.raises(ValueError, match="objects"):
        crf_jax.cooccurrence([0, 1], [0], 2, 2)


def test_history_prior_eq10():
    hist = np.zeros((2, 2, 2))
    hist[0, 0, 0] = hist[1, 1, 1] = 1.0
    pos = np.array([[0.0, 0.0], [3.0, 4.0]])
    prior = crf_jax.history_prior(hist, pos, np.array([0.0, 1.0]), default_distance=2.0)
    # (1/3) (0.25/2 + P_1/1 + P_2/sqrt(9+9))
    expect = (np.full((2, 2), 0.25 / 2) + hist[0] / 1.0 + hist[1] / np.sqrt(18.0)) / 3
    chex.assert_shape(prior, (2, 2))
    np.testing.assert_allclose(prior, expect, rtol=1e-6)
    empty = crf_jax.history_prior(np.zeros((0, 2, 2)), np.zeros((0, 2)), np.zeros(2), default_distance=1.0)
    np.testing.assert_allclose(empty, np.full((2, 2), 0.25))
    lj, log_norm = crf_jax.apply_history(np.log(np.full((2, 2), 0.25)), prior)
    chex.assert_shape([lj, log_norm], [(2, 2), ()])
    prior = np.asarray(prior, np.float64)
    np.testing.assert_allclose(np.exp(lj), prior / prior.sum(), rtol=1e-6)
    np.testing.assert_allclose(log_norm, np.log(0.25 * prior.sum()), rtol=1e-6)
    with pytest.raises(ValueError, match="default_distance"):
        crf_jax.history_prior(hist, pos, np.zeros(2), default_distance=0.0)
    with pytest.raises(ValueError, match="history_positions"):
        crf_jax.history_prior(hist, pos[:1], np.zeros(2), default_distance=1.0)


def test_chcrf_from_chain_segment_probabilities():
    rng = np.random.default_rng(7)
    m = crf_jax.ChainCRF(jnp.asarray(rng.normal(size=(1, 2, 3)), jnp.float32), jnp.zeros(3), jnp.zeros((3, 3)))
    X = rng.normal(size=(2, 5, 2)).astype(np.float32)
    la = crf_jax.segment_log_probs(m, X, [5, 2])
    res = crf_jax.fuse(np.asarray(la), np.asarray(la), np.eye(3) / 3)
    np.testing.assert_allclose(np.exp(res.log_joint).sum(axis=(1, 2)), 1.0, rtol=1e-5)


# ----------------------------------------------------------------------------------------------
# linear baselines
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["logistic", "svm"])
def test_linear_baselines(kind):
    rng = np.random.default_rng(8)
    y = rng.integers(0, 3, 300)
    centers = np.array([[2.0, 0.0], [-1.0, 1.7], [-1.0, -1.7]])
    X = centers[y] + 0.5 * rng.normal(size=(300, 2))
    options = crf_jax.FitOptions.for_linear(kind, max_iter=300, learning_rate=0.05)
    model, info = crf_jax.fit_linear(X, y, kind=kind, l2=0.01, options=options)
    assert model.structure == crf_jax.LinearStructure(n_labels=3, n_features=2)
    pred = crf_jax.linear_predict(model, X)
    assert isinstance(pred, jax.Array)
    chex.assert_shape(pred, (300,))
    assert np.mean(np.asarray(pred) == y) > 0.97
    if kind == "logistic":
        lp = np.asarray(crf_jax.linear_log_proba(model, X))
        np.testing.assert_allclose(np.exp(lp).sum(1), 1.0, rtol=1e-5)
    with pytest.raises(ValueError, match="X"):
        crf_jax.linear_predict(model, X[:, :1])


# ----------------------------------------------------------------------------------------------
# fusion without mass, co-occurrence from smoothing alone
# ----------------------------------------------------------------------------------------------
def test_fuse_without_any_mass_is_flagged_not_nan():
    res = crf_jax.fuse([[0.0, -np.inf]], [[0.0, -np.inf]], [[0.0, 1.0], [1.0, 1.0]])
    for field in ("log_joint", "log_z", "log_action", "log_object"):
        value = np.asarray(getattr(res, field))
        assert not np.any(np.isnan(value)) and np.all(value == -np.inf), field
    np.testing.assert_array_equal(res.impossible, [True])
    # a batch mixing an impossible row with possible ones: only that row is flagged; the others are
    # distributions, also for large unnormalised scores (shifted before the sum)
    la = np.array([[0.0, -np.inf], [-1.0, -2.0], [3e38, 3e38]])
    lo = np.array([[0.0, -np.inf], [-0.5, -np.inf], [1e38, -1e38]])
    res = crf_jax.fuse(la, lo, [[0.0, 1.0], [1.0, 1.0]])
    np.testing.assert_array_equal(res.impossible, [True, False, False])
    joint = np.asarray(res.log_joint, np.float64)
    assert not np.any(np.isnan(joint))
    np.testing.assert_allclose(np.exp(joint[1:]).sum(axis=(1, 2)), 1.0, rtol=1e-6)
    np.testing.assert_allclose(np.exp(joint[1]), [[0, 0], [1, 0]], atol=1e-7)  # only (1, 0) has mass
    np.testing.assert_allclose(res.log_z[1], -2.5, rtol=1e-6)
    with pytest.raises(ValueError, match="log_p_action: contains NaN or \\+inf"):
        crf_jax.fuse([[np.nan, 0.0]], [[0.0, 0.0]], np.ones((2, 2)))
    with pytest.raises(ValueError, match="log_p_object: values up to 1e\\+39 overflow"):
        crf_jax.fuse([[0.0, 0.0]], [[1e39, 0.0]], np.ones((2, 2)))
    with pytest.raises(ValueError, match="log_joint: every"):
        crf_jax.apply_history(np.full((2, 2), -np.inf), np.ones((2, 2)))


def test_cooccurrence_from_smoothing_alone():
    K = crf_jax.cooccurrence([], [], 3, 2, smoothing=1.0)
    chex.assert_shape(K, (3, 2))
    np.testing.assert_allclose(K, np.full((3, 2), 1 / 6), rtol=1e-6)
    with pytest.raises(ValueError, match="actions: no training pairs and smoothing=0"):
        crf_jax.cooccurrence([], [], 3, 2)
    with pytest.raises(ValueError, match="objects: expected 0 labels"):
        crf_jax.cooccurrence([], [1], 3, 2, smoothing=1.0)
