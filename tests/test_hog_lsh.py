"""hog_jax.lsh: recall against exact brute force, bucket structure, candidate counting, autotuning."""
import chex
import jax
import numpy as np
import pytest

from hog_jax import TuneOptions, build_index, query, recall_at_k, tune
from hog_jax._src import lsh as lsh_module
from hog_jax._src.lsh import bucket_ids


def clustered(rng, n, d=16, centres=40):
    """Points around random cluster centres (HOG-like: structured, not uniform)."""
    c = rng.normal(size=(centres, d))
    return (c[rng.integers(0, centres, n)] + 0.3 * rng.normal(size=(n, d))).astype(np.float32)


def brute(data, q, k):
    d = ((q[:, None, :].astype(np.float64) - data[None]) ** 2).sum(-1)
    return np.argsort(d, axis=1, kind="stable")[:, :k]


@pytest.fixture(scope="module")
def setup():
    rng = np.random.default_rng(0)
    data = clustered(rng, 4000)
    q = clustered(np.random.default_rng(1), 100)
    return data, q, brute(data, q, 10)


def test_buckets_are_the_sign_codes(setup):
    data, _, _ = setup
    idx = build_index(jax.random.key(0), data, n_bits=6, n_tables=3)
    chex.assert_shape([idx.planes, idx.center, idx.data, idx.keys, idx.order],
                      [(3, 6, 16), (16,), data.shape, (3, len(data)), (3, len(data))])
    planes, center = np.asarray(idx.planes), np.asarray(idx.center)
    bits = ((data - center) @ planes.transpose(0, 2, 1) > 0)  # (T, N, K)
    codes = (bits * (1 << np.arange(6))).sum(-1)
    for t in range(3):  # K <= table_bits: the bucket is the code itself; the table lists every point once
        order = np.asarray(idx.order[t])
        assert sorted(order.tolist()) == list(range(len(data)))
        np.testing.assert_array_equal(np.asarray(idx.keys[t]), codes[t][order])
        assert np.all(np.diff(np.asarray(idx.keys[t])) >= 0)


def test_hash_into_small_table():
    codes = jax.numpy.arange(1 << 12, dtype=jax.numpy.uint32)
    b = np.asarray(bucket_ids(codes, 12, jax.numpy.int32(5)))
    assert b.min() >= 0 and b.max() < 32 and len(np.unique(b)) == 32  # H = 2^5 buckets, all used


def test_one_table_returns_exactly_the_bucket(setup):
    """With T = 1 and room for every bucket member, the candidates are the query's bucket, ranked exactly."""
    data, q, _ = setup
    idx = build_index(jax.random.key(3), data, n_bits=4, n_tables=1)
    res = query(idx, q, k=5, n_per_table=4000)
    planes, center = np.asarray(idx.planes[0]), np.asarray(idx.center)
    code = lambda x: (((x - center) @ planes.T > 0) * (1 << np.arange(4))).sum(-1)
    cd, cq = code(data), code(q)
    for i in range(len(q)):
        members = np.nonzero(cd == cq[i])[0]
        assert int(res.n_scanned[i]) == len(members)
        want = members[brute(data[members], q[i:i + 1], min(5, len(members)))[0]]
        np.testing.assert_array_equal(np.asarray(res.indices[i][:len(want)]), want)


def test_recall_grows_with_tables_and_reaches_exact(setup):
    data, q, truth = setup
    idx = build_index(jax.random.key(1), data, n_bits=6, n_tables=32)
    recalls = [recall_at_k(query(idx, q, 10, 512, t).indices, truth) for t in (1, 4, 32)]
    assert recalls[0] < recalls[1] < recalls[2]
    assert recalls[2] >= 0.9
    res = query(idx, q, 10, 512)
    chex.assert_shape([res.indices, res.distances], (len(q), 10))
    chex.assert_shape(res.n_scanned, (len(q),))
    assert float(np.mean(res.n_scanned)) < len(data) / 2  # it did not scan everything
    # distances are exact Euclidean distances of the returned points, ascending
    found = np.asarray(res.indices)
    d = np.linalg.norm(data[np.maximum(found, 0)] - q[:, None], axis=-1)
    np.testing.assert_allclose(np.where(found >= 0, np.asarray(res.distances), 0), np.where(found >= 0, d, 0), rtol=1e-4, atol=1e-5)
    assert np.all(np.diff(np.asarray(res.distances), axis=1) >= 0)


def test_no_duplicates_and_missing_marked(setup):
    data, q, _ = setup
    idx = build_index(jax.random.key(2), data, n_bits=16, n_tables=8)
    res = query(idx, q, 10, 8)
    ids = np.asarray(res.indices)
    for row, n in zip(ids, np.asarray(res.n_scanned)):
        real = row[row >= 0]
        assert len(real) == len(set(real.tolist())) == min(10, n)
    assert np.all(np.isinf(np.asarray(res.distances)[ids < 0]))


def test_tune_reaches_target_with_fewest_candidates(setup):
    data, q, truth = setup
    res = tune(jax.random.key(4), data, q, k=10, truth=truth,
               options=TuneOptions(target_recall=0.9, n_bits_grid=(4, 6), n_tables_grid=(2, 8, 32), n_per_table=512))
    assert res.reached and res.recall >= 0.9
    ok = [r for r in res.table if r[2] >= 0.9]
    assert res.mean_scanned <= min(r[3] for r in ok) + 1e-9
    assert len(res.table) == 6


def test_recall_at_k_by_hand():
    assert recall_at_k([[1, 2, 3], [4, -1, -1]], [[3, 2, 9], [4, 5, 6]]) == pytest.approx((2 / 3 + 1 / 3) / 2)


def test_bad_input(setup):
    data, q, _ = setup
    idx = build_index(jax.random.key(0), data[:50], 4, 2)
    with pytest.raises(ValueError, match="k: must be <= 50"):
        query(idx, q, k=51)
    with pytest.raises(ValueError, match="queries: expected dimension D = 16"):
        query(idx, q[:, :5])
    with pytest.raises(ValueError, match="n_bits"):
        build_index(jax.random.key(0), data, 0, 2)
    with pytest.raises(ValueError, match="data: must not be empty"):
        build_index(jax.random.key(0), np.zeros((0, 16)), 4, 2)


# ------------------------------------------------------------------ bad input, edge cases
def test_too_few_candidate_slots_are_named(setup):
    """n_tables * n_per_table < k crashed inside top_k; it is a ValueError naming n_per_table."""
    from hog_jax import fit, predict
    data, q, _ = setup
    idx = build_index(jax.random.key(0), data[:200], 6, 2)
    with pytest.raises(ValueError, match="n_per_table: n_tables \\* n_per_table = 2 \\* 4 = 8 candidate slots"):
        query(idx, q, k=10, n_per_table=4)
    with pytest.raises(ValueError, match="n_per_table: .* = 1 \\* 8 = 8"):
        query(idx, q, k=10, n_per_table=8, n_tables=1)
    model = fit(data[:200], np.arange(200) % 3, sigma=1.0)
    with pytest.raises(ValueError, match="n_per_table"):
        predict(model, q, k=10, index=idx, n_per_table=4)
    with pytest.raises(ValueError, match="n_per_table"):
        tune(jax.random.key(0), data[:200], q[:5], k=10,
             options=TuneOptions(n_bits_grid=(4,), n_tables_grid=(1, 2), n_per_table=4))
    res = query(idx, q, k=10, n_per_table=5)  # exactly k slots: fine
    chex.assert_shape(res.indices, (len(q), 10))


def test_empty_grid_and_int_key_are_named(setup):
    """tune(n_bits_grid=()) crashed on max() of an empty sequence; build_index(0, ...) inside JAX."""
    data, q, _ = setup
    with pytest.raises(ValueError, match="n_bits_grid: must not be empty"):
        tune(jax.random.key(0), data[:100], q[:5], k=3, options=TuneOptions(n_bits_grid=()))
    with pytest.raises(ValueError, match="n_tables_grid: must not be empty"):
        tune(jax.random.key(0), data[:100], q[:5], k=3, options=TuneOptions(n_tables_grid=()))
    with pytest.raises(ValueError, match="n_bits_grid\\[1\\]: must be <= 32"):
        tune(jax.random.key(0), data[:100], q[:5], k=3, options=TuneOptions(n_bits_grid=(4, 40)))
    with pytest.raises(ValueError, match="key: expected a jax.random key"):
        build_index(0, data, 4, 2)
    with pytest.raises(ValueError, match="key: expected a jax.random key"):
        tune(0, data[:100], q[:5], k=3)
    with pytest.raises(ValueError, match="key: expected a single jax.random key"):
        build_index(jax.random.split(jax.random.key(0), 2), data, 4, 2)
    legacy = build_index(jax.random.PRNGKey(0), data[:100], 4, 2)  # raw uint32 keys still work
    chex.assert_shape(legacy.keys, (2, 100))


def test_multi_probe_reads_the_one_bit_neighbour_buckets(setup):
    """With T = 1 and P probes, the candidates are the members of the query's bucket and of the P buckets
    whose codes flip the bits of the P hyperplanes nearest the query (brute force in NumPy)."""
    data, q, truth = setup
    idx = build_index(jax.random.key(3), data, n_bits=5, n_tables=1)
    planes, center = np.asarray(idx.planes[0], np.float64), np.asarray(idx.center, np.float64)
    proj = lambda x: (x - center) @ planes.T
    code = lambda p: ((p > 0) * (1 << np.arange(5))).sum(-1)
    cd = code(proj(data))
    res = query(idx, q, k=5, n_per_table=4000, n_probes=2)
    for i in range(len(q)):
        p = proj(q[i:i + 1])[0]
        probes = [code(p)] + [code(p) ^ (1 << int(j)) for j in np.argsort(np.abs(p))[:2]]
        members = np.nonzero(np.isin(cd, probes))[0]
        assert int(res.n_scanned[i]) == len(members)
        want = members[brute(data[members], q[i:i + 1], min(5, len(members)))[0]]
        np.testing.assert_array_equal(np.asarray(res.indices[i][:len(want)]), want)
    # more probes never lose recall on the same index, and P = 0 is the plain query
    idx = build_index(jax.random.key(4), data, n_bits=10, n_tables=4)
    recalls = [recall_at_k(query(idx, q, 10, 64, n_probes=p).indices, truth) for p in (0, 2, 6)]
    assert recalls[0] < recalls[1] <= recalls[2]
    np.testing.assert_array_equal(np.asarray(query(idx, q, 10, 64).indices),
                                  np.asarray(query(idx, q, 10, 64, n_probes=0).indices))
    with pytest.raises(ValueError, match="n_probes"):
        query(idx, q, 10, 64, n_probes=11)
    tuned = [tune(jax.random.key(5), data, q, k=10,
                  options=TuneOptions(target_recall=1.0, n_bits_grid=(8,), n_tables_grid=(2,), n_probes=p))
             for p in (0, 3)]
    assert tuned[1].recall > tuned[0].recall and tuned[1].max_rerank == 2 * 64 * 4


@pytest.mark.parametrize("rows_per_slot", [64, 0], ids=["table", "sort"])
def test_candidates_are_the_distinct_bucket_members_in_either_deduplication(setup, monkeypatch, rows_per_slot):
    """Both de-duplications of `_candidates` (an N-row table for moderate N, sorting beyond) give the
    distinct members of the read bucket slots (brute force in NumPy); when R is smaller than that, the
    table keeps the first R in table order and the sort the R smallest ids of its first 4 R slots."""
    monkeypatch.setattr(lsh_module, "_TABLE_DEDUP_ROWS_PER_SLOT", rows_per_slot)
    data, q, _ = setup
    T, C = 4, 16
    idx = build_index(jax.random.key(6), data, n_bits=6, n_tables=T)
    keys, order = np.asarray(idx.keys), np.asarray(idx.order)
    for x in q[:5]:
        buckets = np.asarray(lsh_module.bucket_ids(lsh_module.hash_codes(jax.numpy.asarray(x[None]), idx.planes, idx.center),
                                                6, idx.table_bits))[:, 0]
        slots = np.concatenate([order[t][keys[t] == buckets[t]][:C] for t in range(T)])
        in_order = list(dict.fromkeys(slots.tolist()))  # distinct, first appearance first
        ids, n = lsh_module._candidates(idx, jax.numpy.asarray(x), C, jax.numpy.int32(T), T * C, 0)
        ids = np.asarray(ids)
        assert int(n) == len(in_order) and sorted(ids[ids < len(data)].tolist()) == sorted(in_order)
        R = max(1, len(in_order) // 2)
        ids, _ = lsh_module._candidates(idx, jax.numpy.asarray(x), C, jax.numpy.int32(T), R, 0)
        # the sort reads at most 4 R filled slots, in table order
        want = in_order[:R] if rows_per_slot else sorted(set(slots[:4 * R].tolist()))[:R]
        assert sorted(np.asarray(ids)[np.asarray(ids) < len(data)].tolist()) == sorted(want)
