"""phmm_jax on bad input and degenerate data: the problem is named, never a NaN model or a
crash deep inside. The fixture's X, cfg, h and G: X (3, 8, 2), two states of 1-4 steps, G two
grid corners of (2, 8, 2) sequences. The promise of every public function, over drawn inputs, is
tests/test_phmm_properties.py.
"""
import dataclasses
import re

import chex
import jax.numpy as jnp
import numpy as np
import pytest

import phmm_jax as P
from lfd_common import save_arrays


def _hmm_file(path, hmm, config=None, **arrays):
    """An HMM file as `save` writes it, with arrays or the structure replaced."""
    fields = {name: np.asarray(getattr(hmm, name)) for name in ("means", "covariances", "log_cont", "log_exit")}
    structure = dataclasses.asdict(config or hmm.config)
    return save_arrays(path, "phmm_jax.HMM", {**fields, **arrays}, {"structure": structure})


@pytest.fixture(scope="module")
def fitted():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(3, 8, 2))
    G = rng.normal(size=(2, 2, 8, 2))
    cfg = P.HMMConfig(n_states=2, max_duration=4)
    options = P.FitOptions(max_iter=5)
    h = P.fit_hmm(X, config=cfg, options=options)
    ph = P.fit_phmm(list(G), (2,), cfg, options=options)
    return X, G, cfg, options, h, ph


def test_singular_covariance_without_floor_is_rejected(fitted):
    X, G, cfg, options, _, _ = fitted
    no_floor = options.replace(reg_covar=0.0)
    zero_feature, one_feature = X.copy(), X.copy()
    zero_feature[..., 0] = 0.0
    one_feature[..., 1] = 1.0  # constant but not exactly representable as a weighted mean in float32
    for data in (np.ones_like(X), zero_feature, one_feature):
        with pytest.raises(ValueError, match="^reg_covar: with reg_covar=0 a state's covariance is singular"):
            P.fit_hmm(data, config=cfg, options=no_floor)
    with pytest.raises(ValueError, match="^reg_covar:"):
        P.fit_hmm(zero_feature, config=P.HMMConfig(n_states=2, max_duration=4, covariance_type="diag"),
                  options=no_floor)
    with pytest.raises(ValueError, match="^reg_covar:"):
        P.fit_hmm_gradient(zero_feature, config=cfg, options=no_floor.replace(gradient_steps=3))
    groups = [G[0], G[1].copy()]
    groups[1][..., 0] = 0.0  # one corner constant in one feature: its local covariance is singular
    with pytest.raises(ValueError, match="^reg_covar:"):
        P.fit_phmm(groups, (2,), cfg, options=no_floor)
    # Pure maximum likelihood on data that supports it is fine, and the default floor handles the rest.
    for model in (P.fit_hmm(X, config=cfg, options=no_floor), P.fit_hmm(zero_feature, config=cfg, options=options)):
        assert np.all(np.isfinite(np.asarray(model.covariances)))
        assert np.all(np.isfinite(np.asarray(P.log_likelihood(model, X))))


def test_values_that_overflow_inside_are_rejected(fitted):
    X, G, cfg, options, h, ph = fitted
    for f in (P.log_likelihood, P.posteriors, P.messages, P.viterbi):
        with pytest.raises(ValueError, match="^X: the data lie too far from the model's means for float32"):
            f(h, X * 1e20)
        with pytest.raises(ValueError, match="^X: values up to .* overflow float32"):
            f(h, X * 1e39)
    with pytest.raises(ValueError, match="^X: values up to .* overflow float32 in the covariance estimates"):
        P.fit_hmm(X * 1e20, config=cfg, options=options)
    with pytest.raises(ValueError, match="^X:"):
        P.fit_hmm_gradient(X * 1e20, config=cfg, options=options.replace(gradient_steps=2))
    with pytest.raises(ValueError, match="^groups: values up to"):
        P.fit_phmm(list(G * 1e20), (2,), cfg, options=options)
    with pytest.raises(ValueError, match="^phi: the data lie too far"):
        P.phmm_log_likelihood(ph, G[0], [1e30])
    with pytest.raises(ValueError, match="^X: the data lie too far"):
        P.phmm_log_likelihood(ph, G[0] * 1e20, [0.5])
    with pytest.raises(ValueError, match="^X: the data lie too far"):
        P.recognize(ph, G[0] * 1e20, n_steps=2, lattice_points=2)
    with pytest.raises(ValueError, match="^epsilon: the data lie too far"):
        P.recognize(ph, G[0], epsilon=1e30, n_steps=2, lattice_points=2)
    with pytest.raises(ValueError, match="^phi: values up to 1e\\+37 extrapolate the means"):
        P.synthesize(ph, [1e37], length=5)
    # Large but representable scales still give finite, correct answers.
    big = np.asarray(P.log_likelihood(h, X * 1e15))
    assert np.all(np.isfinite(big)) and np.all(big < -1e28)
    assert np.all(np.isfinite(np.asarray(P.fit_hmm(X * 1e15, config=cfg, options=options).covariances)))
    assert np.all(np.isfinite(np.asarray(P.phmm_log_likelihood(ph, G[0], [3.0]))))
    assert np.all(np.isfinite(np.asarray(P.synthesize(ph, [1e30], length=5))))


def test_recognize_rejects_bad_steps(fitted):
    _, G, _, _, _, ph = fitted
    bad = {"n_steps": (0, -1, 2.0), "face_steps": (-1, 2.0, "1"),
           "epsilon": (-0.1, float("nan")), "lattice_points": (0,), "chunk_size": (0, 2.0)}
    for name, values in bad.items():
        for value in values:
            with pytest.raises(ValueError, match=f"^{name}:"):
                P.recognize(ph, G[0], **{name: value})
    rec = P.recognize(ph, G[0], n_steps=1, face_steps=0, lattice_points=1)
    chex.assert_shape((rec.label, rec.phi, rec.loglik), [(2,), (2, 1, 1), (2, 1)])
    assert np.all(np.isfinite(np.asarray(rec.phi))) and np.all(np.isfinite(np.asarray(rec.loglik)))


def test_synthesize_with_one_state_repeats_its_mean(fitted):
    _, G, _, options, _, _ = fitted
    one = P.fit_phmm(list(G), (2,), P.HMMConfig(n_states=1, max_duration=8), options=options)
    movement = np.asarray(P.synthesize(one, [0.25], length=7))
    chex.assert_shape(movement, (7, 2))
    np.testing.assert_allclose(movement, np.broadcast_to(np.asarray(P.interpolate(one, jnp.asarray([0.25])).means[0]),
                                                          (7, 2)), rtol=1e-6)
    chex.assert_shape(P.synthesize(one, [[0.0], [1.0], [0.5]], length=4), (3, 4, 2))


def test_load_checks_the_contents(tmp_path, fitted):
    _, _, _, _, h, ph = fitted
    means = np.asarray(h.means).copy()
    means[0, 0] = np.nan
    not_pd = np.asarray(h.covariances).copy()
    not_pd[0] = np.diag([1.0, -1.0])
    hmm_cases = {
        "nan_means": ({"means": means}, None, "array 'means': contains 1 NaN"),
        "not_pd": ({"covariances": not_pd}, None, "covariances: not positive definite"),
        "three_means": ({"means": np.zeros((3, 2))}, None, r"array 'means': expected shape \(2, 'D'\)"),
        "five_states": ({}, P.HMMConfig(n_states=5, max_duration=4), r"expected shape \(5, 'D'\)"),
    }
    for name, (arrays, config, message) in hmm_cases.items():
        path = _hmm_file(tmp_path / name, h, config, **arrays)
        with pytest.raises(ValueError, match=f"^path: {re.escape(str(path))}.*{message}"):
            P.load(path)
    local = {f"local/{k}": np.asarray(getattr(ph.local, k)) for k in ("means", "covariances", "log_cont", "log_exit")}
    grid_3x3 = save_arrays(tmp_path / "grid_3x3", "phmm_jax.PHMM", local,
                           {"structure": {"hmm": dataclasses.asdict(ph.config), "grid_shape": [3, 3]}})
    with pytest.raises(ValueError, match=re.escape(f"path: {grid_3x3}") + r".*expected shape \(9, 2, 'D'\)"):
        P.load(grid_3x3)
    no_grid = save_arrays(tmp_path / "no_grid", "phmm_jax.PHMM", local,
                          {"structure": {"hmm": dataclasses.asdict(ph.config)}})
    with pytest.raises(ValueError, match=re.escape(f"path: {no_grid}") + ".*not a valid PHMMStructure"):
        P.load(no_grid)
    chex.assert_trees_all_close(P.load(P.save(tmp_path / "good", ph)), ph, rtol=0, atol=0)


def test_degenerate_grids_and_iterations_are_rejected(fitted):
    X, G, cfg, options, _, _ = fitted
    for grid in ((), [], (1,), (2, 0)):
        with pytest.raises(ValueError, match="^grid_shape:"):
            P.fit_phmm(list(G), grid, cfg, options=options)
    for field in ("local_max_iter", "freeze_means_after", "max_iter"):
        with pytest.raises(ValueError, match=f"^{field}: must be >= 0"):
            options.replace(**{field: -1})
    with pytest.raises(ValueError, match="^grid_shape:"):
        P.grid_points(())
    # local_max_iter=0 asks for no local EM: every corner is the global model.
    same = P.fit_phmm(list(G), [2], cfg, options=options.replace(local_max_iter=0))
    assert same.grid_shape == (2,)
    np.testing.assert_array_equal(np.asarray(same.local.means[0]), np.asarray(same.local.means[1]))


def test_wrong_types_are_named(fitted):
    X, G, cfg, options, h, ph = fitted
    cases = [
        ("config", lambda: P.fit_hmm(X, config=None, options=options)),
        ("config", lambda: P.fit_hmm_gradient(X, config="full", options=options)),
        ("config", lambda: P.fit_phmm(list(G), (2,), None, options=options)),
        ("init", lambda: P.fit_hmm(X, config=cfg, init=ph, options=options)),
        (r"phmms\[0\]", lambda: P.recognize([h], G[0])),
        ("phmms", lambda: P.recognize(h, G[0])),
        ("grid_shape", lambda: P.fit_phmm([X, X], 2, cfg, options=options)),
        ("groups", lambda: P.fit_phmm(3, (2,), cfg, options=options)),
        ("path", lambda: P.load(123)),
        ("path", lambda: P.save(None, h)),
        ("model", lambda: P.save("unused", X)),
        ("hmm", lambda: P.log_likelihood(ph, X)),
        ("hmm", lambda: P.viterbi(None, X)),
        ("hmm", lambda: P.expand_to_dense(ph)),
        ("phmm", lambda: P.phmm_log_likelihood(h, X, [0.5])),
        ("phmm", lambda: P.synthesize(h, [0.5])),
    ]
    for name, call in cases:
        with pytest.raises(ValueError, match=f"^{name}:"):
            call()


def test_save_and_load_take_the_same_path(tmp_path, monkeypatch, fitted):
    _, _, _, _, h, ph = fitted
    monkeypatch.chdir(tmp_path)
    for name, model in (("model", h), ("nested/phmm", ph), ("explicit.npz", h)):
        written = P.save(name, model)
        assert written.name.endswith(".npz") and written.exists()
        chex.assert_trees_all_close(P.load(name), model, rtol=0, atol=0)
