"""hog_jax.skin_adapt: one MAP-EM iteration against float64 NumPy, the prior's limit, segment_adapted;
the adaptation to one person's skin (Reynolds relevance MAP) against a hand computation; the rules for
skin-coloured non-skin and the static-background rule against NumPy."""
import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hog_jax


@pytest.fixture(scope="module")
def model():
    rng = np.random.default_rng(0)
    skin = np.clip(rng.normal([200, 140, 120], 15, (400, 3)), 0, 255)
    bg = np.clip(rng.normal([60, 90, 160], 40, (400, 3)), 0, 255)
    return hog_jax.fit_skin_model(jax.random.key(0), skin, bg, n_components=2, n_background=3, n_iter=30)


def _log_normal(x, mean, cov):
    d = x[:, None, :] - mean
    inv = np.linalg.inv(cov)
    maha = np.einsum("ngi,gij,ngj->ng", d, inv, d)
    return -0.5 * maha - 0.5 * np.log(np.linalg.det(cov)) - np.log(2 * np.pi)


def _reference_step(model, x, relevance, reg=1e-5):
    """One MAP-EM iteration in float64 (the module docstring's equations, written out)."""
    mix = [(np.exp(np.asarray(g.log_weights, float)), np.asarray(g.means, float),
            np.asarray(g.chols, float) @ np.swapaxes(np.asarray(g.chols, float), -1, -2))
           for g in (model.skin, model.background)]
    logp = np.concatenate([np.log(w) + np.log(0.5) + _log_normal(x, m, c) for w, m, c in mix], 1)
    resp = np.exp(logp - logp.max(1, keepdims=True))
    resp /= resp.sum(1, keepdims=True)
    out, start = [], 0
    for w0, m0, c0 in mix:
        r = resp[:, start:start + len(w0)]
        start += len(w0)
        n = r.sum(0)
        mean = (r.T @ x + relevance * m0) / (n + relevance)[:, None]
        second = (np.einsum("ng,ni,nj->gij", r, x, x) + relevance * (c0 + m0[:, :, None] * m0[:, None, :]))
        cov = second / (n + relevance)[:, None, None] - mean[:, :, None] * mean[:, None, :] + reg * np.eye(2)
        w = n + relevance * len(w0) * w0
        out.append((w / w.sum(), mean, cov))
    return out


def test_one_iteration_matches_float64_numpy(model):
    rng = np.random.default_rng(1)
    frame = np.concatenate([np.clip(rng.normal([185, 120, 100], 10, (1, 6, 10, 3)), 0, 255),
                            np.clip(rng.normal([40, 160, 60], 20, (1, 6, 10, 3)), 0, 255)], axis=1)
    adapted = hog_jax.adapt_skin_model(model, frame, n_iter=1, relevance=8.0)
    x = np.asarray(hog_jax.rgb_to_chroma(frame.reshape(-1, 3)), float)
    for got, (w, mean, cov) in zip((adapted.skin, adapted.background), _reference_step(model, x, 8.0)):
        chols = np.asarray(got.chols[0], float)
        np.testing.assert_allclose(np.exp(np.asarray(got.log_weights[0], float)), w, atol=1e-4)
        np.testing.assert_allclose(np.asarray(got.means[0], float), mean, atol=1e-4)
        np.testing.assert_allclose(chols @ np.swapaxes(chols, -1, -2), cov, atol=1e-6, rtol=1e-3)


def test_large_relevance_keeps_the_prior_and_masks_follow(model):
    rng = np.random.default_rng(2)
    frames = np.clip(rng.normal([120, 120, 120], 60, (2, 12, 12, 3)), 0, 255)
    frames[:, 3:9, 3:9] = [185, 120, 100]  # a skin-coloured square
    kept = hog_jax.adapt_skin_model(model, frames, n_iter=3, relevance=1e9)
    np.testing.assert_allclose(np.asarray(kept.skin.means[1]), np.asarray(model.skin.means), atol=1e-5)
    cov = lambda c: np.asarray(c, float) @ np.swapaxes(np.asarray(c, float), -1, -2)
    np.testing.assert_allclose(cov(kept.background.chols[0]), cov(model.background.chols) + 1e-5 * np.eye(2),
                               rtol=1e-3, atol=1e-7)  # the prior's covariance and the floor reg I
    fixed = hog_jax.adapt_skin_model(model, frames, n_iter=3, relevance=4.0, adapt_skin=False)
    np.testing.assert_array_equal(np.asarray(fixed.skin.means[0]), np.asarray(model.skin.means))
    a = hog_jax.segment_adapted(model, frames, np.full((2, 2), 6.0), out_size=16, relevance=1e9)
    b = hog_jax.segment(model, frames, np.full((2, 2), 6.0), out_size=16)
    np.testing.assert_array_equal(np.asarray(a.skin), np.asarray(b.skin))
    assert bool(np.all(np.asarray(a.found)))


def test_bad_input_is_named(model):
    frames = np.zeros((1, 4, 4, 3))
    for kwargs, name in ((dict(frames=np.zeros((4, 4, 3))), "frames"), (dict(frames=frames, n_iter=0), "n_iter"),
                         (dict(frames=frames, relevance=0.0), "relevance"), (dict(frames=frames + 300), "frames"),
                         (dict(frames=frames, adapt_skin="yes"), "adapt_skin")):
        with pytest.raises(ValueError, match=name):
            hog_jax.adapt_skin_model(model, **kwargs)


def _reynolds_reference(model, x, relevance, adapt_covariances=False):
    """Reynolds et al. (2000) eqs. 11-14, written out in float64 for the skin mixture."""
    w0 = np.exp(np.asarray(model.skin.log_weights, float))
    mu0 = np.asarray(model.skin.means, float)
    L = np.asarray(model.skin.chols, float)
    cov0 = L @ np.swapaxes(L, -1, -2)
    logp = np.log(w0) + _log_normal(x, mu0, cov0)
    gamma = np.exp(logp - logp.max(1, keepdims=True))
    gamma /= gamma.sum(1, keepdims=True)
    n = gamma.sum(0)
    ex = gamma.T @ x / n[:, None]
    alpha = n / (n + relevance)
    mean = alpha[:, None] * ex + (1 - alpha[:, None]) * mu0
    w = alpha * n / len(x) + (1 - alpha) * w0
    cov = cov0
    if adapt_covariances:
        exx = np.einsum("ng,ni,nj->gij", gamma, x, x) / n[:, None, None]
        cov = (alpha[:, None, None] * exx + (1 - alpha[:, None, None]) * (cov0 + mu0[:, :, None] * mu0[:, None, :])
               - mean[:, :, None] * mean[:, None, :])
    return w / w.sum(), mean, cov


@pytest.mark.parametrize("adapt_covariances", [False, True])
def test_adapt_to_skin_matches_a_hand_computation(model, adapt_covariances):
    rgb = np.array([[190.0, 125, 100], [170, 110, 90], [220, 160, 140], [150, 100, 80], [200, 150, 120]])
    adapted = hog_jax.adapt_to_skin(model, rgb, relevance=3.0, adapt_covariances=adapt_covariances)
    x = np.asarray(hog_jax.rgb_to_chroma(rgb), float)
    w, mean, cov = _reynolds_reference(model, x, 3.0, adapt_covariances)
    np.testing.assert_allclose(np.exp(np.asarray(adapted.skin.log_weights, float)), w, atol=1e-5)
    np.testing.assert_allclose(np.asarray(adapted.skin.means, float), mean, atol=1e-6)
    chols = np.asarray(adapted.skin.chols, float)
    np.testing.assert_allclose(chols @ np.swapaxes(chols, -1, -2), cov, rtol=1e-3, atol=1e-8)
    for a, b in zip(jax.tree.leaves(adapted.background), jax.tree.leaves(model.background)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert float(adapted.threshold) == float(model.threshold)


@settings(max_examples=8, deadline=None)
@given(st.lists(st.tuples(st.integers(120, 255), st.integers(60, 200), st.integers(40, 180)), min_size=1, max_size=12),
       st.floats(0.5, 500.0))
def test_adapted_means_lie_between_the_prior_and_the_data(model, pixels, relevance):
    """mu' = alpha E + (1 - alpha) mu with alpha in [0, 1): each coordinate between the prior and E."""
    rgb = np.array(pixels, float)
    adapted = hog_jax.adapt_to_skin(model, rgb, relevance=relevance)
    x = np.asarray(hog_jax.rgb_to_chroma(rgb), float)
    _, mean, _ = _reynolds_reference(model, x, relevance)
    np.testing.assert_allclose(np.asarray(adapted.skin.means, float), mean, atol=1e-5)
    prior = np.asarray(model.skin.means, float)
    assert np.isclose(np.exp(np.asarray(adapted.skin.log_weights, float)).sum(), 1.0, atol=1e-5)
    far = hog_jax.adapt_to_skin(model, rgb, relevance=1e9)
    np.testing.assert_allclose(np.asarray(far.skin.means), prior, atol=1e-6)


def test_adapt_to_face_box_and_mask_select_the_same_pixels(model):
    rng = np.random.default_rng(5)
    frames = rng.uniform(0, 255, (2, 9, 11, 3))
    box = np.array([2, 3, 6, 8])
    mask = np.zeros((9, 11), bool)
    mask[2:6, 3:8] = True
    by_box = hog_jax.adapt_to_face(model, frames, box, relevance=4.0, only_skin=False)
    by_mask = hog_jax.adapt_to_face(model, frames, mask, relevance=4.0, only_skin=False)
    direct = hog_jax.adapt_to_skin(model, frames[:, 2:6, 3:8].reshape(-1, 3), relevance=4.0)
    for a, b in ((by_box, direct), (by_mask, direct)):
        np.testing.assert_allclose(np.asarray(a.skin.means), np.asarray(b.skin.means), atol=1e-6)
    ratio = np.asarray(hog_jax.skin_log_ratio(model, frames[:, 2:6, 3:8].reshape(-1, 3)))
    kept = frames[:, 2:6, 3:8].reshape(-1, 3)[ratio > float(model.threshold)]
    only = hog_jax.adapt_to_face(model, frames, box, relevance=4.0)
    if len(kept):
        np.testing.assert_allclose(np.asarray(only.skin.means),
                                   np.asarray(hog_jax.adapt_to_skin(model, kept, relevance=4.0).skin.means), atol=1e-6)
    none = hog_jax.adapt_to_face(model, frames, np.zeros((9, 11), bool))
    assert none is model
    for kwargs, name in ((dict(face=np.zeros((3, 3), bool)), "face"), (dict(face=box, relevance=-1.0), "relevance"),
                         (dict(face=box, only_skin=1), "only_skin")):
        with pytest.raises(ValueError, match=name):
            hog_jax.adapt_to_face(model, frames, **kwargs)
    with pytest.raises(ValueError, match="skin_rgb"):
        hog_jax.adapt_to_skin(model, np.full((3, 3), 300.0))


def _rule_features(frames, window):
    """luma, saturation and the local std of luma in float64 NumPy (edges replicated)."""
    f = frames.astype(float)
    y = f @ np.array([0.299, 0.587, 0.114])
    cr = ((f[..., 0] - y) * 0.713 + 128) / 255
    cb = ((f[..., 2] - y) * 0.564 + 128) / 255
    sat = np.hypot(cr - 128 / 255, cb - 128 / 255)
    luma = y / 255
    h = window // 2
    p = np.pad(luma, ((0, 0), (h, h), (h, h)), mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(p, (window, window), axis=(1, 2))
    return luma, sat, windows.std(axis=(-1, -2))


def test_skin_rules_match_numpy():
    rng = np.random.default_rng(6)
    frames = rng.uniform(0, 255, (2, 10, 13, 3))
    frames[0, 2:8, 2:9] = [190, 130, 110] + rng.normal(0, 2, (6, 7, 3))  # a smooth skin-coloured patch
    skin = np.zeros((2, 10, 13), bool)
    skin[0, 2:8, 2:9] = True
    rules = hog_jax.fit_skin_rules(frames, skin, quantile=0.1, window=3)
    luma, sat, tex = _rule_features(frames, 3)
    assert rules.min_luma == pytest.approx(np.quantile(luma[skin], 0.1), abs=1e-5)
    assert rules.max_luma == pytest.approx(np.quantile(luma[skin], 0.9), abs=1e-5)
    assert rules.max_saturation == pytest.approx(np.quantile(sat[skin], 0.9), abs=1e-5)
    assert rules.max_texture == pytest.approx(np.quantile(tex[skin], 0.9), abs=1e-4)
    got = np.asarray(hog_jax.skin_rule_mask(rules, frames))
    ref = ((luma >= rules.min_luma) & (luma <= rules.max_luma) & (sat <= rules.max_saturation)
           & (tex <= rules.max_texture))
    close = (np.abs(tex - rules.max_texture) < 1e-4) | (np.abs(luma - rules.min_luma) < 1e-5) \
        | (np.abs(luma - rules.max_luma) < 1e-5) | (np.abs(sat - rules.max_saturation) < 1e-5)
    np.testing.assert_array_equal(got[~close], ref[~close])
    only_luma = hog_jax.fit_skin_rules(frames, skin, rules=("luma",))
    assert only_luma.max_texture == np.inf and only_luma.max_saturation == np.inf
    assert np.asarray(hog_jax.skin_rule_mask(hog_jax.SkinRules(), frames)).all()  # the defaults: every rule off
    for kwargs, name in ((dict(rules=("colour",)), "rules"), (dict(quantile=0.5), "quantile"),
                         (dict(window=4), "window"), (dict(skin=np.zeros((2, 10, 13), bool)), "skin")):
        with pytest.raises(ValueError, match=name):
            hog_jax.fit_skin_rules(frames, **{"skin": skin, **kwargs})


def test_static_skin_matches_numpy(model):
    rng = np.random.default_rng(7)
    background = rng.uniform(0, 255, (8, 9, 3))
    background[2:6, 2:6] = [190, 130, 110]  # a skin-coloured table
    frames = np.repeat(background[None], 2, axis=0) + rng.normal(0, 5, (2, 8, 9, 3))
    frames[1, 3:5, 3:5] = [120, 80, 60]  # something else passes over it
    frames = frames.clip(0, 255)
    got = np.asarray(hog_jax.static_skin(model, frames, background, threshold=0.0, max_difference=30.0))
    ratio = np.asarray(hog_jax.skin_log_ratio(model, background))
    ref = (ratio > 0.0)[None] & (np.abs(frames - background).max(-1) <= 30.0)
    np.testing.assert_array_equal(got, ref)
    assert got[0, 2:6, 2:6].all() and not got[1, 3:5, 3:5].any()
    with pytest.raises(ValueError, match="background"):
        hog_jax.static_skin(model, frames, background[:4])


def test_luminance_model_log_ratio_save_and_adapt(tmp_path):
    """A (Cr, Cb, Y) model: its log ratio against float64 NumPy, a save / load round trip, and the
    Reynolds adaptation of its means against the hand computation."""
    rng = np.random.default_rng(8)
    skin = np.clip(rng.normal([200, 140, 120], 15, (300, 3)), 0, 255)
    bg = np.clip(rng.normal([60, 90, 160], 40, (300, 3)), 0, 255)
    model = hog_jax.fit_skin_model(jax.random.key(1), skin, bg, n_components=2, n_background=2, n_iter=15, luma=True)
    assert model.skin.means.shape == (2, 3)
    rgb = rng.uniform(0, 255, (7, 3))
    x = np.asarray(hog_jax.skin_features(rgb, luma=True), float)
    np.testing.assert_allclose(x[:, 2], rgb @ [0.299, 0.587, 0.114] / 255, atol=1e-6)

    def log_mix(g):
        L = np.asarray(g.chols, float)
        cov = L @ np.swapaxes(L, -1, -2)
        d = x[:, None, :] - np.asarray(g.means, float)
        maha = np.einsum("ngi,gij,ngj->ng", d, np.linalg.inv(cov), d)
        comp = np.asarray(g.log_weights, float) - 0.5 * maha - 0.5 * np.log(np.linalg.det(cov)) - 1.5 * np.log(2 * np.pi)
        return np.logaddexp.reduce(comp, axis=1)

    np.testing.assert_allclose(np.asarray(hog_jax.skin_log_ratio(model, rgb)), log_mix(model.skin) - log_mix(model.background),
                               rtol=1e-4, atol=1e-3)
    path = hog_jax.save_skin_model(tmp_path / "luma.npz", model)
    loaded = hog_jax.load_skin_model(path)
    np.testing.assert_array_equal(np.asarray(loaded.skin.means), np.asarray(model.skin.means))
    adapted = hog_jax.adapt_to_skin(model, rgb[:4], relevance=2.0)
    w0, mu0 = np.exp(np.asarray(model.skin.log_weights, float)), np.asarray(model.skin.means, float)
    L = np.asarray(model.skin.chols, float)
    cov = L @ np.swapaxes(L, -1, -2)
    d = x[:4, None, :] - mu0
    logp = np.log(w0) - 0.5 * np.einsum("ngi,gij,ngj->ng", d, np.linalg.inv(cov), d) - 0.5 * np.log(np.linalg.det(cov))
    gamma = np.exp(logp - logp.max(1, keepdims=True))
    gamma /= gamma.sum(1, keepdims=True)
    n = gamma.sum(0)
    alpha = n / (n + 2.0)
    mean = alpha[:, None] * (gamma.T @ x[:4]) / n[:, None] + (1 - alpha[:, None]) * mu0
    np.testing.assert_allclose(np.asarray(adapted.skin.means, float), mean, atol=1e-5)
