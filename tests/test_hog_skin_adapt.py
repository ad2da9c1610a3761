"""hog_jax.skin_adapt: one MAP-EM iteration against float64 NumPy, the prior's limit, segment_adapted."""
import jax
import numpy as np
import pytest

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
