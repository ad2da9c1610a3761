"""hog_jax.white_balance: gray-world gains against their definition; the balanced skin model against a
float64 NumPy evaluation of the original model at the balanced colour (the YCrCb features written out
from OpenCV's coefficients, not the module's matrix); the video front end's option."""
import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hog_jax
from hog_jax.video import VideoOptions


@pytest.fixture(scope="module")
def model():
    rng = np.random.default_rng(0)
    skin = np.clip(rng.normal([200, 140, 120], 15, (300, 3)), 0, 255)
    bg = np.clip(rng.normal([60, 90, 160], 40, (300, 3)), 0, 255)
    return hog_jax.fit_skin_model(jax.random.key(0), skin, bg, n_components=2, n_background=2, n_iter=20, luma=True)


def _features(rgb):
    """(Cr, Cb, Y) / 255 in float64, as OpenCV's COLOR_RGB2YCrCb defines them."""
    r, g, b = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    y = 0.299 * r + 0.587 * g + 0.114 * b
    return np.stack([(r - y) * 0.713 + 128, (b - y) * 0.564 + 128, y], axis=1) / 255


def _log_density(gmm, x):
    w, means, chols = (np.asarray(a, np.float64) for a in gmm)
    covs = chols @ np.swapaxes(chols, -1, -2)
    d = x[:, None, :] - means
    maha = np.einsum("ngi,gij,ngj->ng", d, np.linalg.inv(covs), d)
    comp = w - 0.5 * maha - 0.5 * np.log(np.linalg.det(covs)) - 1.5 * np.log(2 * np.pi)
    top = comp.max(axis=1)
    return top + np.log(np.exp(comp - top[:, None]).sum(axis=1))


def test_gray_world_gains_make_the_unsaturated_mean_gray():
    rng = np.random.default_rng(1)
    frames = np.concatenate([rng.uniform([40, 60, 90], [120, 140, 160], (2, 5, 8, 3)),
                             np.full((2, 1, 8, 3), 255.0)], axis=1)  # a saturated row, left out
    gains = hog_jax.gray_world_gains(frames)
    means = frames[:, :5].reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(gains * means, np.full(3, means.mean()), rtol=1e-12)


@pytest.mark.parametrize("frames, match", [(np.full((4, 4, 3), 255.0), "saturated"),
                                           (np.zeros((4, 4, 3)), "black"),
                                           (np.full((4, 4, 2), 9.0), "shape"),
                                           (np.full((4, 4, 3), np.nan), "frames")])
def test_gray_world_gains_rejects_what_has_no_light(frames, match):
    with pytest.raises(ValueError, match=match):
        hog_jax.gray_world_gains(frames)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0.5, 2.0), min_size=3, max_size=3))
def test_balanced_model_is_the_model_at_the_balanced_colour(model, gains):
    gains = np.asarray(gains)
    rgb = np.random.default_rng(2).uniform(0, 255 * min(1.0, 1 / gains.max()), (64, 3))  # both in [0, 255]
    balanced = hog_jax.balanced_skin_model(model, gains)
    for got, original in ((balanced.skin, model.skin), (balanced.background, model.background)):
        expected = _log_density(original, _features(rgb * gains)) + np.log(gains).sum()
        np.testing.assert_allclose(_log_density(got, _features(rgb)), expected, atol=2e-3, rtol=1e-5)
    np.testing.assert_allclose(np.asarray(hog_jax.skin_log_ratio(balanced, rgb)),
                               np.asarray(hog_jax.skin_log_ratio(model, rgb * gains)), atol=2e-3, rtol=1e-4)
    assert float(balanced.threshold) == float(model.threshold)


def test_balanced_model_rejects_a_chroma_model_and_bad_gains(model):
    chroma = hog_jax.SkinModel(*(g._replace(means=g.means[:, :2], chols=g.chols[:, :2, :2])
                                 for g in (model.skin, model.background)), model.threshold)
    with pytest.raises(ValueError, match="model"):
        hog_jax.balanced_skin_model(chroma, [1.0, 1.0, 1.0])
    for gains in ([1.0, 0.0, 1.0], [1.0, 1.0], [1.0, np.inf, 1.0]):
        with pytest.raises(ValueError, match="gains"):
            hog_jax.balanced_skin_model(model, gains)


def test_real_video_options_balance_the_skin_model():
    assert VideoOptions.real_video().white_balance and not VideoOptions().white_balance
