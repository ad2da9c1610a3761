"""hog_jax.metric: whitened LDA against a float64 NumPy reference and Fisher's discriminant."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import hog_jax


def _classes(rng, n=300, d=6):
    """Three anisotropic Gaussian classes sharing one within-class covariance."""
    a = rng.normal(size=(d, d))
    means = rng.normal(scale=3.0, size=(3, d))
    y = rng.integers(0, 3, n)
    return (means[y] + rng.normal(size=(n, d)) @ a).astype(np.float32), y


def test_whitening_makes_the_shrunk_within_class_scatter_the_identity():
    x, y = _classes(np.random.default_rng(0))
    for lam in (0.0, 0.3):
        m = hog_jax.fit_metric(x, y, shrinkage=lam)
        z = np.asarray(hog_jax.apply_metric(m, x), np.float64)
        xd = x.astype(np.float64)
        means = np.stack([xd[y == c].mean(0) for c in range(3)])
        s_w = (xd - means[y]).T @ (xd - means[y]) / len(x)
        s = (1 - lam) * s_w + lam * np.trace(s_w) / 6 * np.eye(6)
        w = np.asarray(m.matrix, np.float64)
        np.testing.assert_allclose(w.T @ s @ w, np.eye(6), atol=2e-4)
        np.testing.assert_allclose(z, (xd - xd.mean(0)) @ w, atol=1e-3)
        if lam == 0.0:  # all components: a rotation of the whitened space, so the Mahalanobis distance of S_w
            d_ref = (xd[0] - xd[1]) @ np.linalg.solve(s_w, xd[0] - xd[1])
            assert np.sum((z[0] - z[1]) ** 2) == pytest.approx(d_ref, rel=1e-3)


def test_first_component_is_fishers_direction_for_two_classes():
    rng = np.random.default_rng(1)
    x, y = _classes(rng)
    keep = y < 2
    x, y = x[keep], y[keep]
    m = hog_jax.fit_metric(x, y, shrinkage=0.0, n_components=1)
    xd = x.astype(np.float64)
    mu = [xd[y == c].mean(0) for c in range(2)]
    s_w = sum((xd[y == c] - mu[c]).T @ (xd[y == c] - mu[c]) for c in range(2)) / len(x)
    fisher = np.linalg.solve(s_w, mu[1] - mu[0])
    w = np.asarray(m.matrix[:, 0], np.float64)
    cos = abs(w @ fisher) / np.linalg.norm(w) / np.linalg.norm(fisher)
    assert cos == pytest.approx(1.0, abs=1e-4)
    assert m.matrix.shape == (6, 1)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.01, 1.0))
def test_metric_keeps_shape_and_is_finite(seed, lam):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(20, 5)).astype(np.float32)
    x[:, 4] = 1.0  # a constant feature: shrinkage keeps the scatter invertible
    y = np.arange(20) % 2
    z = np.asarray(hog_jax.apply_metric(hog_jax.fit_metric(x, y, shrinkage=lam, n_components=3), x))
    assert z.shape == (20, 3) and np.all(np.isfinite(z))


def test_bad_input_is_named():
    x = np.ones((10, 3), np.float32) + np.arange(10)[:, None]
    y = np.arange(10) % 2
    for kwargs, name in ((dict(x=x[:, 0], labels=y), "x"), (dict(x=x, labels=y[:5]), "labels"),
                         (dict(x=x, labels=np.zeros(10, int)), "labels"), (dict(x=x, labels=y, shrinkage=2.0), "shrinkage"),
                         (dict(x=x, labels=y, n_components=4), "n_components"),
                         (dict(x=x, labels=y, shrinkage=0.0), "shrinkage")):  # rank-1 scatter without shrinkage
        with pytest.raises(ValueError, match=name):
            hog_jax.fit_metric(**kwargs)
    m = hog_jax.fit_metric(x, y)
    with pytest.raises(ValueError, match="x"):
        hog_jax.apply_metric(m, np.full((2, 3), np.nan))
