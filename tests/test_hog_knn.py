"""hog_jax.knn: eqs. 3-5 by hand on tiny cases, rotation averaging, exact search vs brute force."""
import chex
import jax
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation

import jax.numpy as jnp
from hog_jax import euler_to_quat, exact_search, fit, intra_class_sigma, mean_rotation, predict, quat_to_euler, vote


def brute_knn(data, queries, k):
    d = np.linalg.norm(queries[:, None, :].astype(np.float64) - data[None].astype(np.float64), axis=-1)
    idx = np.argsort(d, axis=1, kind="stable")[:, :k]
    return idx, np.take_along_axis(d, idx, 1)


def test_exact_search_matches_brute_force():
    rng = np.random.default_rng(0)
    data = rng.normal(size=(3000, 12)).astype(np.float32)  # one database block
    q = rng.normal(size=(70, 12)).astype(np.float32)
    res = exact_search(data, q, 7)
    chex.assert_shape([res.indices, res.distances], (70, 7))
    chex.assert_shape(res.n_scanned, (70,))
    assert all(isinstance(a, jax.Array) for a in res)
    one = exact_search(data, q[3], 7)  # one (D,) query -> (k,)
    chex.assert_shape([one.indices, one.distances], (7,))
    idx, d = brute_knn(data, q, 7)
    np.testing.assert_array_equal(np.asarray(res.indices), idx)
    np.testing.assert_allclose(np.asarray(res.distances), d, rtol=1e-5)


def test_exact_search_across_blocks():
    """More points than one database block (16,384): the running top-k merge must be exact."""
    rng = np.random.default_rng(1)
    data = rng.normal(size=(40_000, 4)).astype(np.float32)
    q = rng.normal(size=(5, 4)).astype(np.float32)
    np.testing.assert_array_equal(np.asarray(exact_search(data, q, 5).indices), brute_knn(data, q, 5)[0])
    # queries at rows that the last block (read ending at row N) shares with the block before: each row once
    near = data[[23_616, 30_000, 32_767, 32_768, 39_999]] + 1e-4
    np.testing.assert_array_equal(np.asarray(exact_search(data, near, 5).indices), brute_knn(data, near, 5)[0])


def test_sigma_eq5_by_hand():
    # class 0: points 0, 3, 4 on a line: ordered pairs distances 3,4,1 each twice -> sum 16 over 6 pairs
    # class 1: points (0,0), (0,2): 2 twice -> sum 4 over 2 pairs.  Pooled mean = 20 / 8 = 2.5
    data = np.array([[0, 0], [3, 0], [4, 0], [10, 0], [10, 2]], float)
    labels = np.array([0, 0, 0, 1, 1])
    assert intra_class_sigma(data, labels) == pytest.approx(2.5, rel=1e-12)


def test_sigma_sampled_is_close_to_exact():
    rng = np.random.default_rng(2)
    data = rng.normal(size=(600, 5))
    labels = rng.integers(0, 3, 600)
    exact = intra_class_sigma(data, labels)
    sampled = intra_class_sigma(data, labels, max_exact=50, n_pairs=400_000, seed=1)
    assert sampled == pytest.approx(exact, rel=0.01)


def test_vote_eq3_by_hand():
    sigma = 2.0
    labels = jnp.array([[0, 1, 1, 2]])
    d = jnp.array([[1.0, 1.5, 2.0, 0.5]])
    w = np.exp(-np.array([1.0, 1.5, 2.0, 0.5]) ** 2 / (2 * sigma**2))
    label, scores, _ = vote(labels, d, jnp.tile(jnp.array([1.0, 0, 0, 0]), (1, 4, 1)), sigma, 3)
    np.testing.assert_allclose(np.asarray(scores)[0], [w[0], w[1] + w[2], w[3]], rtol=1e-6)
    assert int(label[0]) == int(np.argmax([w[0], w[1] + w[2], w[3]])) == 1
    # a small sigma makes the nearest neighbour win (class 2)
    label, _, _ = vote(labels, d, jnp.tile(jnp.array([1.0, 0, 0, 0]), (1, 4, 1)), 0.3, 3)
    assert int(label[0]) == 2


def test_vote_ignores_missing_neighbours_and_underflow():
    labels = jnp.array([[-1, 1, 1]])
    d = jnp.array([[0.0, 50.0, 60.0]])  # exp(-d^2/2) underflows to 0 for both real neighbours
    label, scores, _ = vote(labels, d, jnp.tile(jnp.array([1.0, 0, 0, 0]), (1, 3, 1)), 1.0, 2)
    assert int(label[0]) == 1


def test_euler_quat_match_scipy_and_round_trip():
    rng = np.random.default_rng(3)
    e = np.stack([rng.uniform(-np.pi, np.pi, 50), rng.uniform(-1.5, 1.5, 50), rng.uniform(-np.pi, np.pi, 50)], 1)
    q = euler_to_quat(e)  # numpy in, jax out
    assert isinstance(q, jax.Array)
    chex.assert_shape(q, (50, 4))
    q = np.asarray(q)
    ref = Rotation.from_euler("ZYX", e).as_quat()  # (x, y, z, w)
    ref = np.concatenate([ref[:, 3:], ref[:, :3]], 1)
    np.testing.assert_allclose(np.abs(np.sum(q * ref, 1)), 1.0, atol=1e-5)  # same rotation (q ~ -q)
    np.testing.assert_allclose(np.asarray(quat_to_euler(jnp.asarray(q))), e, atol=1e-4)


def test_mean_rotation_of_symmetric_perturbations_is_the_centre():
    """R0 exp(+v) and R0 exp(-v) pairs, equal weights: the chordal (quaternion) mean is exactly R0."""
    rng = np.random.default_rng(4)
    r0 = Rotation.from_euler("ZYX", [2.5, 0.4, -2.9])
    vs = rng.normal(scale=0.4, size=(6, 3))
    rots = [r0 * Rotation.from_rotvec(s * v) for v in vs for s in (1, -1)]
    q = np.stack([np.roll(r.as_quat(), 1) for r in rots]) * rng.choice([-1, 1], size=(12, 1))  # random signs
    w = np.repeat(rng.uniform(0.2, 1.0, 6), 2)
    m = np.asarray(mean_rotation(jnp.asarray(q, jnp.float32), jnp.asarray(w, jnp.float32)))
    want = np.roll(r0.as_quat(), 1)
    assert abs(np.dot(m, want)) == pytest.approx(1.0, abs=1e-5)


def test_mean_orientation_is_cyclic():
    """Yaw 179 deg and -179 deg average to 180 deg, not to 0 (the naive Euler mean)."""
    e = np.radians([[179.0, 0, 0], [-179.0, 0, 0]])
    m = mean_rotation(euler_to_quat(jnp.asarray(e, jnp.float32)), jnp.ones(2))
    yaw = float(quat_to_euler(m)[0])
    assert abs(abs(yaw) - np.pi) < 1e-4


def test_predict_orientation_uses_only_the_winning_class():
    # database: class 0 near the origin with yaw 10 deg (two points), class 1 a bit further with yaw 90
    data = np.array([[0.0, 0.0], [0.0, 0.1], [0.3, 0.0], [5.0, 5.0]])
    labels = np.array([0, 0, 1, 1])
    ori = np.radians([[10.0, 0, 0], [10.0, 0, 0], [90.0, 0, 0], [90.0, 0, 0]])
    model = fit(data, labels, ori, sigma=1.0)
    pred = predict(model, np.array([[0.1, 0.0]]), k=3)
    chex.assert_shape([pred.label, pred.scores, pred.quat, pred.euler, pred.indices, pred.distances],
                      [(1,), (1, 2), (1, 4), (1, 3), (1, 3), (1, 3)])
    assert all(isinstance(a, jax.Array) for a in pred)
    assert int(pred.label[0]) == 0
    np.testing.assert_allclose(np.degrees(np.asarray(pred.euler[0])), [10.0, 0, 0], atol=1e-3)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**16))
def test_predict_weighted_mean_yaw_matches_circular_mean(seed):
    """Rotations about one axis: the quaternion mean equals the weighted circular mean of half-angles."""
    rng = np.random.default_rng(seed)
    n = 5
    data = rng.normal(scale=0.3, size=(n, 3))
    yaw = rng.uniform(-0.8, 0.8, n) + rng.uniform(-np.pi, np.pi)
    model = fit(data, np.zeros(n, int), np.stack([yaw, np.zeros(n), np.zeros(n)], 1), sigma=0.5)
    q = rng.normal(scale=0.3, size=(1, 3))
    pred = predict(model, q, k=n)
    d = np.linalg.norm(data - q, axis=1)
    w = np.exp(-d**2 / (2 * 0.5**2))
    # for rotations about z, q = (cos(y/2), 0, 0, sin(y/2)); the top eigenvector of sum w q q^T is the
    # direction of the principal axis of the weighted half-angle vectors
    qs = np.stack([np.cos(yaw / 2), np.sin(yaw / 2)], 1)
    m = (w[:, None, None] * qs[:, :, None] * qs[:, None, :]).sum(0)
    v = np.linalg.eigh(m)[1][:, -1]
    want = 2 * np.arctan2(v[1], v[0])
    got = float(pred.euler[0, 0])
    assert abs(np.angle(np.exp(1j * (got - want)))) < 1e-3


def test_bad_input():
    data = np.random.default_rng(5).normal(size=(10, 4))
    labels = np.arange(10) % 2
    with pytest.raises(ValueError, match="orientations: expected shape \\(10, 3\\)"):
        fit(data, labels, np.zeros((9, 3)))
    with pytest.raises(ValueError, match="labels: expected 10 labels"):
        fit(data, labels[:-1])
    model = fit(data, labels)
    with pytest.raises(ValueError, match="k: must be <= 10"):
        predict(model, data[:2], k=11)
    with pytest.raises(ValueError, match="queries: expected dimension D = 4"):
        predict(model, np.zeros((2, 3)), k=3)
    with pytest.raises(ValueError, match="queries: contains 1 NaN"):
        exact_search(data, np.array([[np.nan, 0, 0, 0]]), 3)
    with pytest.raises(ValueError, match="data: must not be empty"):
        exact_search(np.zeros((0, 4)), data, 1)
    with pytest.raises(ValueError, match="labels: every class has a single point"):
        intra_class_sigma(data[:2], np.array([0, 1]))


# ------------------------------------------------------------------ bad input, edge cases
@pytest.mark.parametrize("offset", [0.0, 0.25])
def test_identical_features_floor_sigma(offset):
    """All-zero (or identical per class) features: eq. 5 gives sigma = 0 and predict divided by it
    (NaN scores and Euler angles, label 0). sigma is floored with a warning; eq. 3 becomes the
    nearest-neighbour vote."""
    data = np.repeat(np.array([[0.0, 0.0, 0.0], [offset, 0.0, 0.0]]), 3, axis=0)  # offset 0: all zero
    labels = np.array([0, 0, 0, 1, 1, 1])
    ori = np.radians(np.repeat([[10.0, 0, 0], [80.0, 0, 0]], 3, axis=0))
    with pytest.warns(UserWarning, match="sigma: eq. 5 gives 0"):
        model = fit(data, labels, ori)
    assert 0 < float(model.sigma) <= 1e-6
    q = np.array([[0.0, 0.0, 0.0], [offset, 0.0, 0.0], [0.2, 0.3, 0.0], [1e15, 0.0, 0.0]])  # last: exp(-inf)
    pred = predict(model, q, k=4)
    for a in (pred.scores, pred.quat, pred.euler):
        assert np.isfinite(np.asarray(a)).all()
    assert set(np.asarray(pred.label).tolist()) <= {0, 1} and np.asarray(pred.found).all()
    if offset:
        assert np.asarray(pred.label)[:3].tolist() == [0, 1, 1]  # the nearest class wins
        np.testing.assert_allclose(np.degrees(np.asarray(pred.euler[:2, 0])), [10.0, 80.0], atol=1e-3)
    with pytest.raises(ValueError, match="sigma: must be >="):
        fit(data, labels, sigma=1e-30)  # sigma^2 would underflow float32


def test_exact_search_is_exact_up_to_the_feature_limit():
    """Values 1e20 made the expanded squared distances overflow (wrong neighbours). Features beyond
    2^60 / sqrt(D) are rejected naming the argument; up to that bound the neighbours are exact."""
    from hog_jax import feature_limit
    rng = np.random.default_rng(6)
    data = rng.normal(size=(200, 8))
    q = rng.normal(size=(9, 8))
    with pytest.raises(ValueError, match="data: values up to .* exceed the supported range"):
        exact_search(data * 1e20, q, 3)
    with pytest.raises(ValueError, match="queries: values up to .* exceed the supported range"):
        exact_search(data, q * 1e20, 3)
    with pytest.raises(ValueError, match="data: values up to"):
        fit(data * 1e20, np.arange(200) % 2)
    scale = 0.99 * feature_limit(8) / max(np.abs(data).max(), np.abs(q).max())
    res = exact_search(data * scale, q * scale, 5)
    idx, d = brute_knn(data, q, 5)
    np.testing.assert_array_equal(np.asarray(res.indices), idx)
    np.testing.assert_allclose(np.asarray(res.distances), d * scale, rtol=1e-5)
    model = fit(data * scale, np.arange(200) % 2)
    pred = predict(model, q * scale, k=5)
    assert np.isfinite(np.asarray(pred.scores)).all() and np.all(np.asarray(pred.label) >= 0)


def test_no_neighbour_found_is_flagged():
    """An index that finds no neighbour for a query gave label 0, scores 0 and the identity
    orientation. Now: found False, label -1, scores 0, NaN orientation; exact search finds all."""
    from hog_jax import build_index
    rng = np.random.default_rng(7)
    data = rng.normal(size=(40, 6)).astype(np.float32)
    labels = np.arange(40) % 3
    model = fit(data, labels, rng.uniform(-1, 1, (40, 3)), sigma=0.1)
    index = build_index(jax.random.key(0), data, n_bits=16, n_tables=1)
    planes, center = np.asarray(index.planes[0]), np.asarray(index.center)
    code = lambda x: (((x - center) @ planes.T > 0) * (1 << np.arange(16))).sum(-1)
    cands = rng.normal(size=(200, 6)).astype(np.float32)
    empty = cands[~np.isin(code(cands), code(data))][0]  # a query whose bucket holds no point
    pred = predict(model, np.stack([empty, data[5]]), k=3, index=index)
    assert np.asarray(pred.found).tolist() == [False, True]
    assert int(pred.label[0]) == -1 and np.all(np.asarray(pred.scores[0]) == 0)
    assert np.isnan(np.asarray(pred.quat[0])).all() and np.isnan(np.asarray(pred.euler[0])).all()
    assert np.all(np.asarray(pred.indices[0]) == -1)
    assert int(pred.label[1]) == labels[5] and np.isfinite(np.asarray(pred.euler[1])).all()
    exact = predict(model, np.stack([empty, data[5]]), k=3)
    assert np.asarray(exact.found).all() and np.all(np.asarray(exact.label) >= 0)
