"""hog_jax's promises as properties: valid input -> finite, correctly shaped output;
invalid input -> ValueError naming the argument.

Shapes are fixed and only values are drawn, so every jitted function compiles once per module run;
a handful of examples per property.
"""
import functools
import warnings

import jax
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from hypothesis.extra.numpy import arrays

import hog_jax as H

PROP = settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
HEAVY = settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
KEY = jax.random.key(0)


def f32(lo=None, hi=None):
    """Finite float32 values (subnormals included), optionally bounded."""
    return st.floats(lo, hi, width=32, allow_nan=False, allow_infinity=False)


not_a_key = st.one_of(st.integers(-5, 2**40), st.none(), st.text(max_size=3), st.floats(allow_nan=False),
                      st.just(np.zeros(3, np.uint32)), st.just(np.zeros(2, np.int64)))

# ----------------------------------------------------------------------------------------- hog
B, S = 3, 16
CFG, RAW = H.HOGConfig(), H.HOGConfig(normalize="none")
LEVEL_SIZES = [4 * 16, 4 * 4, 4 * 1]  # 4 bins; 4x4, 2x2, 1x1 cells


@PROP
@given(arrays(np.float32, (B, S, S), elements=f32()))
def test_hog_any_finite_images(images):
    """Any finite float32 batch (1e38 or subnormal values included): features finite, shaped, each
    level of the global normalisation summing to 1 (0 for a constant image); an all-zero image is named."""
    nonzero = images.reshape(B, -1).any(axis=1)
    if not nonzero.all():
        with pytest.raises(ValueError, match=f"images: image {int(np.argmin(nonzero))} is all zero"):
            H.hog(images, CFG)
        return
    x = np.asarray(H.hog(images, CFG))
    assert x.shape == (B, H.hog_dim(CFG)) and np.isfinite(x).all() and (x >= 0).all()
    for level in np.split(x, np.cumsum(LEVEL_SIZES)[:-1], axis=1):
        sums = level.sum(axis=1)
        assert np.all((np.abs(sums - 1) < 1e-4) | (sums == 0))
    raw = None
    try:
        raw = np.asarray(H.hog(images, RAW))
    except ValueError as err:  # raw gradient sums beyond float32: named, never inf
        assert str(err).startswith("images: the raw")
    if raw is not None:
        assert raw.shape == x.shape and np.isfinite(raw).all()


@PROP
@given(arrays(np.float32, (B, S, S), elements=f32(0, 1)), arrays(bool, (B, S, S)))
def test_hog_mask(images, mask):
    images = images + 1.0  # never all zero
    has = mask.reshape(B, -1).any(axis=1)
    if not has.all():
        with pytest.raises(ValueError, match=f"mask: image {int(np.argmin(has))} has no unmasked pixel"):
            H.hog(images, CFG, mask=mask)
        return
    x = np.asarray(H.hog(images, CFG, mask=mask))
    assert x.shape == (B, 84) and np.isfinite(x).all()


@PROP
@given(st.integers(0, B * S * S - 1), st.sampled_from([np.nan, np.inf, -np.inf]))
def test_hog_rejects_non_finite_pixels(pos, bad):
    images = np.ones((B, S, S), np.float32)
    images.flat[pos] = bad
    with pytest.raises(ValueError, match=f"images: image {pos // (S * S)} contains NaN or infinite"):
        H.hog(images, CFG)


@PROP
@given(st.integers(-3, 0), st.integers(13, 20), st.sampled_from(["x", "pyramid3", ""]))
def test_hog_rejects_bad_config(n_bins, n_levels, name):
    img = np.ones((S, S))
    with pytest.raises(ValueError, match="config.n_bins"):
        H.hog(img, H.HOGConfig(n_bins=n_bins))
    with pytest.raises(ValueError, match="config.n_levels"):
        H.hog(img, H.HOGConfig(n_levels=n_levels))
    with pytest.raises(ValueError, match="config.layout"):
        H.hog(img, H.HOGConfig(layout=name))


# ---------------------------------------------------------------------------- skin and segment
NPIX, NTEST = 6, 8
pixels = arrays(np.uint8, (NPIX, 3))


@functools.cache
def toy_model():
    rng = np.random.default_rng(7)
    skin = rng.normal([200, 140, 110], 8, (500, 3)).clip(0, 255)
    bg = rng.uniform(0, 255, (500, 3))
    return H.fit_skin_model(jax.random.key(1), skin, bg, n_components=2, n_background=2, n_iter=10)


def assert_valid_gmm(g, n):
    assert g.log_weights.shape == (n,) and g.means.shape == (n, 2) and g.chols.shape == (n, 2, 2)
    for a in g:
        assert np.isfinite(np.asarray(a)).all()
    assert np.exp(np.asarray(g.log_weights, np.float64)).sum() == pytest.approx(1.0, abs=1e-4)
    assert np.all(np.diagonal(np.asarray(g.chols), axis1=1, axis2=2) > 0)


@HEAVY
@given(pixels, pixels, arrays(np.uint8, (NTEST, 3)))
def test_skin_model_from_any_pixels(skin, bg, test):
    """Any labelled pixels (duplicates, a single colour) give a finite model and finite ratios."""
    model = H.fit_skin_model(KEY, skin, bg, n_components=2, n_background=2, n_iter=5)
    assert_valid_gmm(model.skin, 2)
    assert_valid_gmm(model.background, 2)
    r = np.asarray(H.skin_log_ratio(model, test))
    assert r.shape == (NTEST,) and np.isfinite(r).all()


@PROP
@given(arrays(np.float64, (NPIX, 3), elements=st.floats(-1e6, 1e6)), st.integers(NPIX + 1, 50), not_a_key)
def test_skin_model_rejects_bad_input(rgb, n_components, key):
    good = np.full((NPIX, 3), 100.0)
    if (rgb < 0).any() or (rgb > 255).any():
        with pytest.raises(ValueError, match="skin_rgb: values must be"):
            H.fit_skin_model(KEY, rgb, good)
    with pytest.raises(ValueError, match="n_components: must be <="):
        H.fit_skin_model(KEY, good, good, n_components=n_components)
    with pytest.raises(ValueError, match="key: expected"):
        H.fit_skin_model(key, good, good)
    with pytest.raises(ValueError, match="key: expected"):
        H.fit_gmm(key, good[:, :2], 2)


@HEAVY
@given(arrays(np.uint8, (2, 12, 12, 3)))
def test_segment_any_frames(frames):
    seg = H.segment(toy_model(), frames, out_size=16)
    assert seg.images.shape == (2, 16, 16) and seg.masks.shape == (2, 16, 16)
    assert seg.found.shape == (2,) and seg.boxes.shape == (2, 4) and seg.skin.shape == (2, 12, 12)
    imgs, found, boxes = np.asarray(seg.images), np.asarray(seg.found), np.asarray(seg.boxes)
    assert np.isfinite(imgs).all() and imgs.min() >= -1e-5 and imgs.max() <= 1 + 1e-5
    assert np.all((boxes == -1).all(axis=1) == ~found)
    assert not np.asarray(seg.masks)[~found].any()


@PROP
@given(st.integers(0, 2 * 12 * 12 * 3 - 1), st.sampled_from([-1.0, 255.5, 1e9, np.nan]))
def test_segment_rejects_out_of_range_frames(pos, bad):
    frames = np.full((2, 12, 12, 3), 100.0)
    frames.flat[pos] = bad
    with pytest.raises(ValueError, match="frames: "):
        H.segment(toy_model(), frames, out_size=16)


# ------------------------------------------------------------------- exact search, LSH, kNN
N, D, Q, K = 24, 5, 4, 4
features = arrays(np.float32, (N, D), elements=f32(-1e6, 1e6))
queries_st = arrays(np.float32, (Q, D), elements=f32(-1e6, 1e6))
ORI = np.random.default_rng(3).uniform(-np.pi, np.pi, (N, 3))


def brute(data, q):
    return np.sqrt(((q[:, None, :].astype(np.float64) - data[None].astype(np.float64)) ** 2).sum(-1))


def tolerance(data, q):  # float32 distance error bound, relative to the values' scale
    return 1e-2 * max(np.abs(data).max(), np.abs(q).max()) + 1e-6


@PROP
@given(features, queries_st)
def test_exact_search_is_exact(data, q):
    res = H.exact_search(data, q, K)
    idx, dist = np.asarray(res.indices), np.asarray(res.distances)
    assert idx.shape == dist.shape == (Q, K) and np.asarray(res.n_scanned).tolist() == [N] * Q
    assert np.all((idx >= 0) & (idx < N)) and all(len(set(r)) == K for r in idx.tolist())
    assert np.isfinite(dist).all() and np.all(np.diff(dist, axis=1) >= 0)
    d = brute(data, q)
    tol = tolerance(data, q)
    np.testing.assert_allclose(dist, np.take_along_axis(d, idx, 1), atol=tol, rtol=1e-5)
    np.testing.assert_allclose(dist, np.sort(d, axis=1)[:, :K], atol=tol, rtol=1e-5)


@PROP
@given(st.integers(61, 120), st.booleans(), st.sampled_from([0, N + 1, -1]))
def test_exact_search_rejects(exponent, in_queries, k):
    data = np.ones((N, D), np.float32)
    big = data * np.float32(2.0**exponent)  # beyond 2^60 / sqrt(D)
    with pytest.raises(ValueError, match="queries: values up to" if in_queries else "data: values up to"):
        H.exact_search(data if in_queries else big, big[:Q] if in_queries else data[:Q], K)
    with pytest.raises(ValueError, match="k: must be"):
        H.exact_search(data, data[:Q], k)
    with pytest.raises(ValueError, match="queries: expected dimension D = 5"):
        H.exact_search(data, np.ones((Q, D + 1)), K)


@HEAVY
@given(features, queries_st)
def test_lsh_query(data, q):
    index = H.build_index(KEY, data, n_bits=3, n_tables=2)
    res = H.query(index, q, K, n_per_table=8)
    idx, dist, n = (np.asarray(a) for a in res)
    assert idx.shape == dist.shape == (Q, K) and n.shape == (Q,)
    assert np.all((idx >= -1) & (idx < N)) and np.all((n >= 0) & (n <= 16))
    found = idx >= 0
    assert np.all(np.isinf(dist[~found])) and np.isfinite(dist[found]).all()
    assert np.all(np.diff(found.astype(int), axis=1) <= 0)  # the missing ones last
    d = brute(data, q)
    tol = tolerance(data, q)
    np.testing.assert_allclose(dist[found], np.take_along_axis(d, np.maximum(idx, 0), 1)[found], atol=tol, rtol=1e-5)
    assert np.all(dist[found] >= np.sort(d, axis=1)[:, :K][found] - tol)  # never better than exact


@HEAVY
@given(st.integers(1, 8), st.integers(1, 3), not_a_key, st.integers(-2, 0))
def test_lsh_rejects(n_per_table, n_tables, key, bad_bits):
    data = np.random.default_rng(0).normal(size=(N, D)).astype(np.float32)
    index = H.build_index(KEY, data, n_bits=3, n_tables=3)
    k = n_per_table * n_tables + 1  # one more than the candidate slots
    if k <= N:
        with pytest.raises(ValueError, match="n_per_table: n_tables \\* n_per_table"):
            H.query(index, data[:Q], k, n_per_table=n_per_table, n_tables=n_tables)
    with pytest.raises(ValueError, match="key: expected"):
        H.build_index(key, data, 3, 2)
    with pytest.raises(ValueError, match="n_bits: must be >= 1"):
        H.build_index(KEY, data, bad_bits, 2)
    with pytest.raises(ValueError, match="k: must be <= 24"):
        H.query(index, data[:Q], N + n_per_table)


@HEAVY
@given(features, arrays(np.int64, (N,), elements=st.integers(0, 2)), queries_st)
def test_fit_predict(data, labels, q):
    """Any features (identical, all zero, spread over 1e6) and labels: a finite positive sigma and a
    finite prediction; with an index, "not found" rows are flagged and carry label -1 and NaN angles."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # sigma floored for coinciding classes
        model = H.fit(data, labels, ORI, n_classes=3)
    sigma = float(model.sigma)
    assert np.isfinite(sigma) and sigma > 0
    p = H.predict(model, q, k=K)
    assert p.label.shape == (Q,) and p.scores.shape == (Q, 3) and p.quat.shape == (Q, 4)
    assert p.euler.shape == (Q, 3) and p.indices.shape == (Q, K) and p.found.shape == (Q,)
    label, scores, quat = np.asarray(p.label), np.asarray(p.scores), np.asarray(p.quat)
    assert np.all((label >= 0) & (label < 3)) and np.asarray(p.found).all()
    assert np.isfinite(scores).all() and (scores >= 0).all()
    assert np.isfinite(quat).all() and np.allclose(np.linalg.norm(quat, axis=1), 1, atol=1e-4)
    assert np.isfinite(np.asarray(p.euler)).all()
    index = H.build_index(KEY, data, n_bits=3, n_tables=2)
    p = H.predict(model, q, k=K, index=index, n_per_table=8)
    found, label, euler = np.asarray(p.found), np.asarray(p.label), np.asarray(p.euler)
    assert np.all((label >= 0) == found) and np.all(label < 3)
    assert np.isfinite(euler[found]).all() and np.isnan(euler[~found]).all()
    assert np.isfinite(np.asarray(p.scores)).all()


@PROP
@given(st.one_of(st.floats(max_value=2.0**-61), st.floats(min_value=2.0**63), st.just(np.nan), st.just(np.inf)),
       st.integers(-5, -1))
def test_fit_rejects(sigma, bad_label):
    data = np.random.default_rng(1).normal(size=(N, D))
    labels = np.arange(N) % 3
    with pytest.raises(ValueError, match="sigma: "):
        H.fit(data, labels, sigma=sigma)
    with pytest.raises(ValueError, match="labels: values must be >= 0"):
        H.fit(data, np.where(labels == 0, bad_label, labels))
    with pytest.raises(ValueError, match="orientations: expected shape"):
        H.fit(data, labels, ORI[:-1])
    with pytest.raises(ValueError, match="labels: every class has a single point"):
        H.fit(data[:3], [0, 1, 2])


# ----------------------------------------------------------------------------------------- tune
TUNE_DATA = np.random.default_rng(2).normal(size=(N, D)).astype(np.float32)


@settings(max_examples=4, deadline=None)
@given(arrays(np.float32, (Q, D), elements=f32(-10, 10)))
def test_tune(q):
    # the programs of test_exact_search_is_exact and test_lsh_query (same N, D, Q, k, K, C): no new compiles
    res = H.tune(KEY, TUNE_DATA, q, k=K,
                 options=H.TuneOptions(target_recall=0.5, n_bits_grid=(3,), n_tables_grid=(1, 2), n_per_table=8))
    assert res.n_bits == 3 and res.n_tables in (1, 2) and res.n_per_table == 8
    assert 0 <= res.recall <= 1 and np.isfinite(res.mean_scanned) and res.max_rerank >= K
    assert len(res.table) == 2


@PROP
@given(st.lists(st.integers(-3, 40), max_size=3).filter(lambda g: not g or any(v < 1 or v > 32 for v in g)),
       st.lists(st.integers(-3, 0), max_size=2), not_a_key)
def test_tune_rejects(bits_grid, tables_grid, key):
    q = TUNE_DATA[:Q] + 0.5
    with pytest.raises(ValueError, match="n_bits_grid"):
        H.tune(KEY, TUNE_DATA, q, k=3, options=H.TuneOptions(n_bits_grid=tuple(bits_grid)))
    with pytest.raises(ValueError, match="n_tables_grid"):
        H.tune(KEY, TUNE_DATA, q, k=3, options=H.TuneOptions(n_bits_grid=(2,), n_tables_grid=tuple(tables_grid)))
    with pytest.raises(ValueError, match="key: expected"):
        H.tune(key, TUNE_DATA, q, k=3)
