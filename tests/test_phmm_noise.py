"""Observation noise: the exact emission model of x = y + n and the blind estimate of σ²."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import phmm_jax as P
from phmm_jax import gaussian_log_density


@pytest.mark.parametrize("sigma", [0.01, 0.05, 0.2])
def test_estimate_noise_variance_recovers_white_noise_on_a_smooth_movement(sigma):
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 100)
    movement = np.stack([0.5 * np.sin(np.pi * t), 0.3 * t, 0.2 * np.cos(2 * np.pi * t)], -1)  # metres
    X = movement[None] + sigma * rng.standard_normal((40, 100, 3))
    lengths = rng.integers(50, 101, 40)
    assert abs(np.sqrt(P.estimate_noise_variance(X, lengths)) / sigma - 1) < 0.05


def test_with_observation_noise_is_the_convolved_gaussian():
    rng = np.random.default_rng(1)
    cfg = P.HMMConfig(n_states=3, min_duration=2, max_duration=4)
    hmm = P.fit_hmm([rng.normal(size=(10, 2)) + np.arange(10)[:, None] / 3 for _ in range(6)], config=cfg,
                    options=P.FitOptions(max_iter=3))
    noisy = P.with_observation_noise(hmm, 0.3)
    np.testing.assert_allclose(noisy.covariances, np.asarray(hmm.covariances) + 0.3 * np.eye(2), rtol=1e-6)
    # Monte Carlo: E_n[N(x + n; μ, Σ)] over n ~ N(0, 0.3 I) equals N(x; μ, Σ + 0.3 I).
    x, mu, cov = np.array([0.4, -0.2]), np.asarray(hmm.means[0]), np.asarray(hmm.covariances[0], np.float64)
    n = np.sqrt(0.3) * rng.standard_normal((200_000, 2))
    inv, (_, logdet) = np.linalg.inv(cov), np.linalg.slogdet(cov)
    r = x + n - mu
    mc = np.mean(np.exp(-0.5 * np.einsum("bi,ij,bj->b", r, inv, r) - 0.5 * logdet - np.log(2 * np.pi)))
    exact = float(gaussian_log_density(x[None], noisy.means[:1], noisy.covariances[:1])[0, 0])
    assert abs(np.log(mc) - exact) < 0.01
    grid = P.PHMM(jax.tree_util.tree_map(lambda a: jnp.stack([a, 2 * a]), hmm), (2,))
    noisy_grid = P.with_observation_noise(grid, 0.1)
    assert isinstance(noisy_grid, P.PHMM) and noisy_grid.grid_shape == (2,)
    np.testing.assert_allclose(noisy_grid.local.covariances, np.asarray(grid.local.covariances) + 0.1 * np.eye(2),
                               rtol=1e-6)


def test_noise_arguments_are_checked_by_name():
    hmm = P.HMM.__new__(P.HMM)
    for bad in (-1.0, float("nan"), float("inf"), "0.1"):
        with pytest.raises(ValueError, match="^variance:"):
            P.with_observation_noise(hmm, bad)
    with pytest.raises(ValueError, match="^model:"):
        P.with_observation_noise("model", 0.1)
    with pytest.raises(ValueError, match="^X:"):
        P.estimate_noise_variance(np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match="^X:"):
        P.estimate_noise_variance(np.full((2, 5, 3), np.nan))
