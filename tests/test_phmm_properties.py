"""Property-based tests of phmm_jax's public functions: each states its promise,
"valid in -> finite, correctly shaped out; invalid in -> ValueError naming the argument".

Shapes are fixed across examples (X (4, 8, 2), two states of 1-4 steps, PHMMs of a 2-corner grid)
and hypothesis draws values, so every jitted function compiles once for the module. float32, the
default compute dtype, where overflow inside a computation is a real risk.
"""
import dataclasses
import re
import tempfile
from pathlib import Path

import numpy as np
import optax
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import phmm_jax as P
from lfd_common import save_arrays

PROPERTY = settings(max_examples=20, deadline=None, database=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])
FEW = settings(PROPERTY, max_examples=6)

B, T, D = 4, 8, 2  # B = the 2 x 2 sequences of a PHMM fit: fit_hmm and fit_phmm share their EM traces
CFG = P.HMMConfig(n_states=2, max_duration=4)  # paths of 2..8 frames
N, PSEUDO = CFG.n_states, CFG.n_pseudo
OPTIONS = P.FitOptions(max_iter=3)
GRADIENT = P.FitOptions(gradient_steps=3, optimizer=optax.adam(0.05))  # L-BFGS: test_phmm_training (its trace is long)
FLOAT32 = st.floats(width=32, allow_nan=False, allow_infinity=False)


@pytest.fixture(scope="module")
def models():
    rng = np.random.default_rng(0)
    hmm = P.fit_hmm(rng.normal(size=(B, T, D)), config=CFG, options=OPTIONS)
    phmm = P.fit_phmm(list(rng.normal(size=(2, 2, T, D))), (2,), CFG, options=OPTIONS)
    mirrored = P.PHMM(phmm.local.replace(means=-phmm.local.means), phmm.grid_shape)
    return hmm, phmm, mirrored


@st.composite
def sequences(draw, max_exponent=3, max_offset=1e3):
    """(X (B, T, D), lengths (B,)): Gaussian data of a drawn scale and offset, some constant features."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = 10.0 ** draw(st.integers(-3, max_exponent))
    X = draw(st.floats(-max_offset, max_offset)) + scale * rng.normal(size=(B, T, D))
    if draw(st.booleans()):
        X[..., draw(st.integers(0, D - 1))] = draw(st.floats(-10, 10))
    lengths = np.asarray(draw(st.lists(st.integers(CFG.min_length, T), min_size=B, max_size=B)))
    return X, lengths


def raises_named(name, call):
    """Run `call`; it must raise `ValueError` whose message starts with `name:`."""
    with pytest.raises(ValueError, match=f"^{re.escape(name)}:"):
        call()


def assert_finite(*arrays):
    for a in arrays:
        assert np.all(np.isfinite(np.asarray(a))), a


# ------------------------------------------------------------------------------------------------
# Inference
# ------------------------------------------------------------------------------------------------
@PROPERTY
@given(data=sequences())
def test_inference_is_finite_and_shaped(models, data):
    hmm = models[0]
    X, lengths = data
    loglik = np.asarray(P.log_likelihood(hmm, X, lengths))
    post = P.posteriors(hmm, X, lengths)
    msgs = P.messages(hmm, X, lengths)
    states, best = map(np.asarray, P.viterbi(hmm, X, lengths))
    assert loglik.shape == (B,) and states.shape == (B, T) and best.shape == (B,)
    assert [a.shape for a in post] == [(B, T, N), (B, T, N, PSEUDO), (B,)]
    assert [a.shape for a in msgs] == [(B, T, N, PSEUDO), (B, T, N, PSEUDO), (B,)]
    assert_finite(loglik, post.state, post.pseudo, msgs.loglik, best)
    real = np.arange(T)[None] < lengths[:, None]
    np.testing.assert_allclose(np.asarray(post.state).sum(-1), real.astype(float), atol=1e-4)
    assert np.all((states >= 0) == real) and np.all(states < N)
    assert np.all(best <= loglik + 1e-3 * np.abs(loglik) + 1e-3)


@PROPERTY
@given(X=hnp.arrays(np.float32, (B, T, D), elements=FLOAT32))
def test_inference_of_any_float32_data_is_finite_or_names_X(models, X):
    hmm = models[0]
    try:
        loglik = P.log_likelihood(hmm, X)
        post = P.posteriors(hmm, X)
    except ValueError as err:
        assert str(err).startswith("X:"), err
        assert np.max(np.abs(X)) > 1e12
        return
    assert_finite(loglik, post.state)


INVALID_INFERENCE = ["nan", "inf", "dim", "empty", "lengths_zero", "lengths_long", "too_short", "too_long",
                     "model_type", "ragged"]


@PROPERTY
@given(kind=st.sampled_from(INVALID_INFERENCE), where=st.integers(0, B * T * D - 1),
       function=st.sampled_from([P.log_likelihood, P.posteriors, P.messages, P.viterbi]))
def test_inference_rejects_invalid_input_by_name(models, kind, where, function):
    hmm, phmm, _ = models
    X = np.zeros((B, T, D))
    if kind in ("nan", "inf"):
        X.flat[where] = np.nan if kind == "nan" else -np.inf
        raises_named("X", lambda: function(hmm, X))
    elif kind == "dim":
        raises_named("X", lambda: function(hmm, np.zeros((B, T, D + 1))))
    elif kind == "empty":
        raises_named("X", lambda: function(hmm, np.zeros((0, T, D))))
    elif kind == "lengths_zero":
        raises_named("lengths", lambda: function(hmm, X, [T, 0, T, T]))
    elif kind == "lengths_long":
        raises_named("lengths", lambda: function(hmm, X, [T, T + 1, T, T]))
    elif kind == "too_short":
        raises_named("lengths", lambda: function(hmm, X, [T, 1, T, T]))
    elif kind == "too_long":
        raises_named("lengths", lambda: function(hmm, np.zeros((1, CFG.max_length + 1, D))))
    elif kind == "model_type":
        raises_named("hmm", lambda: function(phmm, X))
    else:
        raises_named("X", lambda: function(hmm, [np.zeros((T, D)), np.zeros((T, D + 1))]))


# ------------------------------------------------------------------------------------------------
# Fitting
# ------------------------------------------------------------------------------------------------
def _assert_valid_hmm(hmm, lead=()):
    assert hmm.means.shape == (*lead, N, D) and hmm.covariances.shape == (*lead, N, D, D)
    assert hmm.log_cont.shape == hmm.log_exit.shape == (*lead, N, PSEUDO)
    assert_finite(hmm.means, hmm.covariances)
    assert np.min(np.linalg.eigvalsh(np.asarray(hmm.covariances, np.float64))) > 0
    assert not np.any(np.isnan(np.asarray(hmm.log_cont))) and not np.any(np.isnan(np.asarray(hmm.log_exit)))


def ill_conditioned(X, lengths, reg_covar):
    """Whether the pooled covariance of the frames (+ the floor) is singular at float32 resolution:
    the only data a fit with reg_covar > 0 may reject as a singular model (collinear features)."""
    X = np.asarray(X, np.float64).reshape(-1, *np.shape(X)[-2:])
    frames = np.concatenate([x[:n] for x, n in zip(X, np.asarray(lengths).ravel())])
    eig = np.linalg.eigvalsh(np.cov(frames.T) + reg_covar * np.eye(frames.shape[1]))
    return eig[0] <= 1e-5 * eig[-1]


@PROPERTY
@given(data=sequences(max_exponent=20), reg_covar=st.sampled_from([0.0, 1e-6, 1e-4, 1e-2]))
def test_fit_hmm_is_finite_or_names_the_cause(data, reg_covar):
    X, lengths = data
    try:
        hmm = P.fit_hmm(X, lengths, config=CFG, options=OPTIONS.replace(reg_covar=reg_covar))
    except ValueError as err:
        message = str(err)
        if message.startswith("reg_covar:"):
            assert reg_covar == 0.0
        else:
            assert message.startswith("X:"), message
            assert np.max(np.abs(X)) > 1e12 or ill_conditioned(X, lengths, reg_covar), message
        return
    _assert_valid_hmm(hmm)
    assert_finite(P.log_likelihood(hmm, X, lengths))


@FEW
@given(data=sequences(max_exponent=1, max_offset=10.0))
def test_fit_hmm_gradient_is_finite_and_shaped(data):
    X, lengths = data
    hmm, history = P.fit_hmm_gradient(X, lengths, config=CFG, options=GRADIENT, return_history=True)
    _assert_valid_hmm(hmm)
    assert np.asarray(history).shape == (GRADIENT.gradient_steps,)
    assert_finite(history, P.log_likelihood(hmm, X, lengths))


FIT_OPTION_ERRORS = [("max_iter", -1), ("max_iter", 1.5), ("tol", float("nan")), ("tol", -1.0),
                     ("reg_covar", -1e-4), ("reg_covar", float("inf")), ("duration_pseudocount", -1.0),
                     ("freeze_means_after", -1), ("local_max_iter", -1), ("gradient_steps", -1),
                     ("optimizer", "lbfgs")]


@PROPERTY
@given(case=st.sampled_from(FIT_OPTION_ERRORS + [("config", None), ("config", "full"), ("init", "model"),
                                                 ("options", {"max_iter": 2}), ("n_states", 0),
                                                 ("min_duration", 5), ("covariance_type", "spherical")]),
       fit=st.sampled_from([P.fit_hmm, P.fit_hmm_gradient]))
def test_fit_rejects_invalid_arguments_by_name(models, case, fit):
    name, value = case
    X = np.random.default_rng(1).normal(size=(B, T, D))
    if name in {f.name for f in dataclasses.fields(P.FitOptions)}:
        raises_named(name, lambda: fit(X, config=CFG, options=P.FitOptions(**{name: value})))
    elif name in ("config", "init", "options"):
        raises_named(name, lambda: fit(X, **{"config": CFG, "options": OPTIONS, name: value}))
    elif name == "min_duration":
        raises_named(name, lambda: P.HMMConfig(n_states=2, min_duration=value, max_duration=4))
    else:
        raises_named(name, lambda: P.HMMConfig(**{name: value}))
    raises_named("init", lambda: fit(X, init=models[1], options=OPTIONS))


@PROPERTY
@given(data=sequences(), other=sequences())
def test_fit_phmm_is_finite_or_names_the_groups(data, other):
    groups = [data[0][:2], other[0][:2]]
    try:
        phmm = P.fit_phmm(groups, (2,), CFG, options=OPTIONS)
    except ValueError as err:  # e.g. two corners that differ by an offset along a diagonal only
        assert str(err).startswith("groups: the fit gave a non-finite or singular model"), err
        assert ill_conditioned(np.stack(groups), np.full((2, 2), T), OPTIONS.reg_covar), err
        return
    assert phmm.grid_shape == (2,)
    _assert_valid_hmm(phmm.local, lead=(2,))


@PROPERTY
@given(grid=st.one_of(st.just(()), st.just([]), st.integers(0, 4), st.text(max_size=2),
                      st.tuples(st.integers(-2, 1)), st.tuples(st.integers(2, 3), st.integers(-1, 1)),
                      st.tuples(st.floats(2.0, 3.0))))
def test_grids_are_checked_by_name(grid):
    groups = [np.zeros((1, T, D))] * 2
    raises_named("grid_shape", lambda: P.fit_phmm(groups, grid, CFG, options=OPTIONS))
    raises_named("grid_shape", lambda: P.grid_points(grid))


@PROPERTY
@given(grid=st.lists(st.integers(2, 4), min_size=1, max_size=3))
def test_grid_points_span_the_unit_box(grid):
    points = P.grid_points(tuple(grid))
    assert points.shape == (int(np.prod(grid)), len(grid))
    assert np.min(points) == 0.0 and np.max(points) == 1.0
    assert len(np.unique(points, axis=0)) == len(points)


# ------------------------------------------------------------------------------------------------
# Parametric HMMs: likelihood, recognition, synthesis, targets
# ------------------------------------------------------------------------------------------------
@PROPERTY
@given(data=sequences(), phi=st.floats(-1e38, 1e38, allow_nan=False))
def test_phmm_log_likelihood_is_finite_or_names_phi(models, data, phi):
    phmm = models[1]
    X, lengths = data
    try:
        loglik = P.phmm_log_likelihood(phmm, X, [phi], lengths)
    except ValueError as err:
        assert str(err).startswith("phi:") and abs(phi) > 1e6, err
        return
    assert np.asarray(loglik).shape == (B,)
    assert_finite(loglik)


@PROPERTY
@given(data=sequences(), epsilon=st.floats(0.0, 0.5), face_steps=st.sampled_from([0, 1]))
def test_recognize_is_finite_and_in_range(models, data, epsilon, face_steps):
    _, phmm, mirrored = models
    X, lengths = data
    rec = P.recognize([phmm, mirrored], X, lengths, epsilon=epsilon, face_steps=face_steps,
                      n_steps=2, lattice_points=2)
    label, phi, loglik = map(np.asarray, rec)
    assert label.shape == (B,) and phi.shape == (B, 2, 1) and loglik.shape == (B, 2)
    assert_finite(phi, loglik)
    assert np.all((label >= 0) & (label < 2))
    assert np.all(phi >= -epsilon - 1e-6) and np.all(phi <= 1 + epsilon + 1e-6)
    np.testing.assert_array_equal(label, np.argmax(loglik, axis=1))


@PROPERTY
@given(case=st.sampled_from([("n_steps", 0), ("n_steps", -3), ("n_steps", 1.0), ("face_steps", -1),
                             ("face_steps", 1.5), ("epsilon", -0.1), ("epsilon", float("nan")),
                             ("lattice_points", 0), ("phmms", "model"), ("phmms", [])]))
def test_recognize_rejects_invalid_arguments_by_name(models, case):
    name, value = case
    hmm, phmm, _ = models
    X = np.zeros((B, T, D))
    if name == "phmms":
        raises_named(name, lambda: P.recognize(value, X))
    else:
        raises_named(name, lambda: P.recognize(phmm, X, **{name: value}))
    raises_named("phmms[1]", lambda: P.recognize([phmm, hmm], X))
    raises_named("X", lambda: P.recognize(phmm, np.zeros((B, T, D + 1))))


@PROPERTY
@given(phi=st.floats(-1e38, 1e38, allow_nan=False), batch=st.booleans())
def test_synthesize_is_finite_or_names_phi(models, phi, batch):
    phmm = models[1]
    arg = [[phi], [0.5]] if batch else [phi]
    try:
        movement = np.asarray(P.synthesize(phmm, arg, length=6))
    except ValueError as err:
        assert str(err).startswith("phi:") and abs(phi) > 1e30, err
        return
    assert movement.shape == ((2, 6, D) if batch else (6, D))
    assert_finite(movement)


@PROPERTY
@given(case=st.sampled_from([("length", 1), ("length", 2.5), ("phi", [np.nan]), ("phi", [0.5, 0.5]),
                             ("phi", [[[0.5]]]), ("phmm", None)]))
def test_synthesize_rejects_invalid_arguments_by_name(models, case):
    name, value = case
    phmm = models[1]
    kwargs = {"phmm": phmm, "phi": [0.5], "length": 6, name: value}
    raises_named(name, lambda: P.synthesize(**kwargs))


@PROPERTY
@given(seed=st.integers(0, 2**32 - 1), n_targets=st.just(4))
def test_target_to_phi_inverts_the_grid(seed, n_targets):
    rng = np.random.default_rng(seed)
    origin, edges = rng.normal(size=2), rng.normal(size=(2, 2)) + 3 * np.eye(2)
    corners = np.array([[origin + i * edges[0] + j * edges[1] for j in (0, 1)] for i in (0, 1)])  # (2, 2, 2)
    truth = rng.uniform(-0.2, 1.2, size=(n_targets, 2))
    targets = origin + truth @ edges
    phi = np.asarray(P.target_to_phi(corners, targets))
    assert phi.shape == (n_targets, 2)
    np.testing.assert_allclose(phi, truth, atol=1e-3)
    bad = targets.copy()
    bad[rng.integers(n_targets), rng.integers(2)] = np.nan
    raises_named("targets", lambda: P.target_to_phi(corners, bad))
    raises_named("targets", lambda: P.target_to_phi(corners, targets[:, :1]))
    raises_named("corner_targets", lambda: P.target_to_phi(np.zeros((2, 2, 2)), targets))
    raises_named("n_iter", lambda: P.target_to_phi(corners, targets, n_iter=-1))


# ------------------------------------------------------------------------------------------------
# Persistence: load returns a usable model or names the file
# ------------------------------------------------------------------------------------------------
FIELDS = ("means", "covariances", "log_cont", "log_exit")


@PROPERTY
@given(field=st.sampled_from(FIELDS), change=st.sampled_from(["nan", "inf", "random", "scale", "shape", "drop"]),
       seed=st.integers(0, 2**32 - 1))
def test_load_returns_a_usable_model_or_names_the_file(models, field, change, seed):
    hmm = models[0]
    rng = np.random.default_rng(seed)
    arrays = {name: np.asarray(getattr(hmm, name), np.float64).copy() for name in FIELDS}
    a = arrays[field]
    if change in ("nan", "inf"):
        a.flat[rng.integers(a.size)] = np.nan if change == "nan" else np.inf
    elif change == "random":
        arrays[field] = rng.normal(size=a.shape)
    elif change == "scale":
        arrays[field] = a * rng.choice([-1.0, 0.0, 1e-30, 1e30])
    elif change == "shape":
        arrays[field] = np.zeros(a.shape[:-1] + (a.shape[-1] + 1,))
    else:
        del arrays[field]
    with tempfile.TemporaryDirectory() as folder:
        path = save_arrays(Path(folder) / "model", "phmm_jax.HMM", arrays,
                           {"structure": dataclasses.asdict(hmm.config)})
        try:
            loaded = P.load(path)
        except ValueError as err:
            assert str(err).startswith(f"path: {path}"), err
            return
        assert P.load(P.save(Path(folder) / "again", loaded)) is not None  # what load returns saves
    _assert_valid_hmm(loaded)
    try:
        assert_finite(P.log_likelihood(loaded, np.zeros((B, T, D))))
    except ValueError as err:  # a valid model may lie too far from the data for float32
        assert str(err).startswith("hmm:"), err


@PROPERTY
@given(path=st.one_of(st.none(), st.integers(), st.floats(allow_nan=False), st.lists(st.integers(), max_size=2)))
def test_load_and_save_name_a_path_that_is_not_one(models, path):
    raises_named("path", lambda: P.load(path))
    raises_named("path", lambda: P.save(path, models[0]))
