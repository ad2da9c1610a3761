"""hog_jax.colour_models: BIC (eq. 8) chooses the true number of components, the parameter count and
BIC against a float64 reference, person/background models from frames, bad input. Every fit shares one shape
(N = 2000 points in 3-D, candidates 1-4, 2 starts), so one compilation serves the file."""
import dataclasses

import chex
import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hog_jax import gmm_log_prob
from hog_jax.video import (BICOptions, fit_gmm_bic, fit_person_background_models, gmm_n_params,
    region_log_likelihoods)

N = 2000
FIT = BICOptions(candidates=(1, 2, 3, 4), n_init=2, n_iter=60)
CENTRES = np.array([[0.2, 0.2, 0.2], [0.8, 0.3, 0.3], [0.3, 0.8, 0.3], [0.3, 0.3, 0.8]])


def _mixture(n_components, seed, n=N, spread=0.03):
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, n_components, n)
    return (CENTRES[labels] + rng.normal(0, spread, (n, 3))).astype(np.float32)


@pytest.mark.parametrize("true", [1, 2, 3])
def test_bic_picks_the_true_number_of_components(true):
    x = _mixture(true, seed=true)
    gmm, scores = fit_gmm_bic(jax.random.key(true), x, FIT)
    assert gmm.log_weights.shape == (true,)
    assert int(scores.candidates[np.argmin(np.asarray(scores.bic))]) == true
    chex.assert_shape([scores.bic, scores.log_likelihood, scores.n_params], (4,))
    assert np.all(np.isfinite(np.asarray(gmm.means)))


def _ref_log_likelihood(x, weights, means, covs):
    """ln L of a full-covariance mixture, float64 NumPy."""
    d = x.shape[1]
    comp = []
    for w, m, c in zip(weights, means, covs):
        diff = x - m
        maha = np.einsum("ni,ij,nj->n", diff, np.linalg.inv(c), diff)
        comp.append(np.log(w) - 0.5 * (maha + np.linalg.slogdet(c)[1] + d * np.log(2 * np.pi)))
    comp = np.stack(comp, 1)
    peak = comp.max(1, keepdims=True)
    return float(np.sum(peak[:, 0] + np.log(np.exp(comp - peak).sum(1))))


def test_bic_against_a_float64_reference():
    """Eq. 8 with the exact count: -2 ln L + k ln N recomputed in float64 for the returned mixture."""
    x = _mixture(2, seed=7)
    gmm, scores = fit_gmm_bic(jax.random.key(0), x, FIT)
    t = gmm.log_weights.shape[0]
    chols = np.asarray(gmm.chols, np.float64)
    ll = _ref_log_likelihood(x.astype(np.float64), np.exp(np.asarray(gmm.log_weights, np.float64)),
                             np.asarray(gmm.means, np.float64), chols @ chols.transpose(0, 2, 1))
    k = (t - 1) + t * 3 + t * len(np.triu_indices(3)[0])  # weights, means, symmetric covariances
    assert int(scores.n_params[t - 1]) == k
    np.testing.assert_allclose(float(scores.bic[t - 1]), -2 * ll + k * np.log(N), rtol=1e-5)


def test_parameter_counts():
    for t in range(1, 6):
        for d in (1, 2, 3):
            free_cov = len(np.triu_indices(d)[0])  # a symmetric d x d matrix
            assert gmm_n_params(t, d) == t * d + t * free_cov + t - 1
            assert gmm_n_params(t, d, "tr") == t * (d + 1) * (d + 2) // 2 == gmm_n_params(t, d) + 1


def test_tr_count_shifts_every_bic_by_ln_n():
    x = _mixture(3, seed=3)
    g1, exact = fit_gmm_bic(jax.random.key(1), x, FIT)
    g2, tr = fit_gmm_bic(jax.random.key(1), x, dataclasses.replace(FIT, param_count="tr"))
    np.testing.assert_allclose(np.asarray(tr.bic) - np.asarray(exact.bic), np.log(N), atol=1e-2)  # float32 BICs
    assert g1.log_weights.shape == g2.log_weights.shape


def _scene(seed=0, T=8, H=30, W=40):
    """Frames whose person (a block in two colours) stands on a background of three colours."""
    rng = np.random.default_rng(seed)
    bg = np.array([[40, 60, 200], [200, 200, 60], [60, 180, 60]], float)
    person = np.array([[200, 40, 40], [230, 160, 200]], float)
    ys, xs = np.mgrid[:H, :W]
    frames = bg[(xs // 14) % 3][None].repeat(T, 0)
    masks = np.zeros((T, H, W), bool)
    for t in range(T):
        masks[t, 5:28, 4 + 2 * t:18 + 2 * t] = True
        frames[t][masks[t]] = person[(ys[masks[t]] // 8) % 2]
    return np.clip(frames + rng.normal(0, 4, frames.shape), 0, 255).astype(np.uint8), masks


@pytest.fixture(scope="module")
def scene_fit():
    frames, masks = _scene()
    return frames, masks, fit_person_background_models(jax.random.key(0), frames, masks, FIT, max_pixels=N)


def test_ghost_pixels_teach_neither_model():
    """Moving pixels of the background's colour (the wall a seated person uncovers) teach the person
    under the TR's rule and are dropped by the ghost rule: the person GMM then scores the background's
    colours below the person's own."""
    frames, masks = _scene()
    ghost = masks.copy()
    ghost[:, :, 20:32] = True  # the background beside the person counted as moving too
    wall = frames[0, 10, 34].astype(np.float32)[None] / 255.0  # a background colour (third stripe)
    clothing = frames[0, 10, 10].astype(np.float32)[None] / 255.0
    with_ghosts = fit_person_background_models(jax.random.key(0), frames, ghost, FIT, max_pixels=N, ghost_quantile=None)
    without = fit_person_background_models(jax.random.key(0), frames, ghost, FIT, max_pixels=N, ghost_quantile=0.01)
    person_ll = lambda fit, x: float(gmm_log_prob(fit.models.person, x)[0])  # noqa: E731
    assert person_ll(with_ghosts, wall) > person_ll(with_ghosts, clothing) - 10.0  # learnt the wall as person
    assert person_ll(without, wall) < person_ll(without, clothing) - 20.0


def test_person_and_background_models_from_frames(scene_fit):
    frames, masks, fit = scene_fit
    assert masks.sum() >= N and (~masks).sum() >= N
    assert (fit.structure.n_person_components, fit.structure.n_background_components) == (2, 3)
    ll = region_log_likelihoods(fit.models, frames, fit.structure.space)
    chex.assert_shape(ll, (8, 2, 30, 40))  # person, background
    chex.assert_tree_all_finite(ll)
    person = np.asarray(ll[:, 0] > ll[:, 1])
    assert (person == masks).mean() > 0.99


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_log_likelihoods_of_any_frames_are_finite(scene_fit, seed):
    frames = np.random.default_rng(seed).integers(0, 256, (2, 5, 7, 3)).astype(np.uint8)
    ll = region_log_likelihoods(scene_fit[2].models, frames)
    chex.assert_shape(ll, (2, 2, 5, 7))
    chex.assert_tree_all_finite(ll)


BAD = np.zeros((2, 6, 8, 3), np.uint8)
X = _mixture(1, seed=0, n=50)
BAD_CALLS = {
    "key: expected a jax.random key": lambda: fit_gmm_bic(0, X),
    "x: contains": lambda: fit_gmm_bic(jax.random.key(0), np.full((50, 3), np.nan)),
    "x: expected a 2-D": lambda: fit_gmm_bic(jax.random.key(0), X[0]),
    "candidates: must not be empty": lambda: fit_gmm_bic(jax.random.key(0), X, BICOptions(candidates=())),
    "candidates: must be >= 1": lambda: fit_gmm_bic(jax.random.key(0), X, BICOptions(candidates=(0, 1))),
    "candidates: expected distinct": lambda: fit_gmm_bic(jax.random.key(0), X, BICOptions(candidates=(2, 2))),
    "x: 50 points cannot support": lambda: fit_gmm_bic(jax.random.key(0), X, BICOptions(candidates=(1, 6))),
    "param_count: expected one of": lambda: fit_gmm_bic(jax.random.key(0), X, BICOptions(param_count="aic")),
    "n_init: must be >= 1": lambda: fit_gmm_bic(jax.random.key(0), X, BICOptions(n_init=0)),
    "frames: expected a 4-D": lambda: fit_person_background_models(jax.random.key(0), BAD[0], BAD[0, ..., 0]),
    "frames: values must be <= 255": lambda: fit_person_background_models(jax.random.key(0), BAD + 300.0,
                                                                          BAD[..., 0] > 0),
    "person_masks: expected shape": lambda: fit_person_background_models(jax.random.key(0), BAD, BAD[..., 0, 0]),
    "person_masks: expected a boolean": lambda: fit_person_background_models(jax.random.key(0), BAD,
                                                                             BAD[..., 0] + 3),
    "person_masks: 0 person": lambda: fit_person_background_models(jax.random.key(0), BAD, BAD[..., 0] > 0),
    "space: expected one of": lambda: fit_person_background_models(jax.random.key(0), BAD, BAD[..., 0] > 0,
                                                                   space="hsv"),
    "ghost_quantile: expected a quantile": lambda: fit_person_background_models(jax.random.key(0), BAD,
                                                                               BAD[..., 0] > 0, ghost_quantile=1.0),
    "max_pixels: must be >= 1": lambda: fit_person_background_models(jax.random.key(0), BAD, BAD[..., 0] > 0,
                                                                     max_pixels=0),
}


@pytest.mark.parametrize("message", sorted(BAD_CALLS))
def test_bad_input_names_the_argument(message):
    with pytest.raises(ValueError, match=message):
        BAD_CALLS[message]()
