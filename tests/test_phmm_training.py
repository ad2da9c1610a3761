"""EM, gradient fitting, synchronised PHMM training, recognition, synthesis and persistence."""
import dataclasses
import re

import chex
import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

import phmm_jax as P
from lfd_common import pad_sequences, save_arrays
from phmm_jax import em_step
from phmm_jax import batch_phmm_log_likelihood
from phmm_jax import hermite_spline, multilinear_map
from phmm_jax._src import parametric

CORNERS = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0], [0.0, 3.0]])


def square_walk(rng, n, end_shift=0.0, noise=0.2):
    """Sequences visiting 4 corners for 2-5 frames each; the last corner moves with `end_shift`."""
    seqs = []
    for _ in range(n):
        durations = rng.integers(2, 6, size=4)
        points = CORNERS.copy()
        points[3, 0] += end_shift
        x = np.concatenate([np.repeat(points[k:k + 1], d, 0) for k, d in enumerate(durations)])
        seqs.append(x + noise * rng.normal(size=x.shape))
    return seqs


@pytest.mark.parametrize("max_duration", [6, None])
def test_em_increases_likelihood_and_recovers_the_walk(max_duration):
    rng = np.random.default_rng(0)
    cfg = P.HMMConfig(n_states=4, min_duration=2, max_duration=max_duration)
    hmm, history = P.fit_hmm(square_walk(rng, 40), config=cfg, options=P.FitOptions(max_iter=30, tol=1e-6),
                             return_history=True)
    chex.assert_shape((hmm.means, hmm.covariances), [(4, 2), (4, 2, 2)])
    assert np.all(np.diff(history) > -1e-4)  # EM never decreases the likelihood (float32 slack)
    np.testing.assert_allclose(np.asarray(hmm.means), CORNERS, atol=0.15)
    np.testing.assert_allclose(np.asarray(P.expected_durations(hmm)), 3.5, atol=0.5)
    if max_duration is not None:
        # Forbidden transitions stay exactly impossible through EM.
        assert np.all(np.asarray(hmm.log_exit)[:, 0] == -np.inf)
        assert np.all(np.asarray(hmm.log_cont)[:, -1] == -np.inf)


def test_gradient_fit_reaches_the_em_likelihood():
    rng = np.random.default_rng(1)
    seqs = square_walk(rng, 30)
    cfg = P.HMMConfig(n_states=4, min_duration=2, max_duration=6)
    em = P.fit_hmm(seqs, config=cfg, options=P.FitOptions(max_iter=100, tol=1e-7))
    grad = P.fit_hmm_gradient(seqs, config=cfg, options=P.FitOptions(gradient_steps=150))
    n_frames = sum(len(s) for s in seqs)
    em_ll = float(np.sum(P.log_likelihood(em, seqs))) / n_frames
    grad_ll = float(np.sum(P.log_likelihood(grad, seqs))) / n_frames
    assert grad_ll > em_ll - 0.01, (grad_ll, em_ll)


def test_degenerate_data_is_floored_not_nan():
    flat = [np.zeros((12, 3)) for _ in range(4)]  # zero variance in every dimension
    hmm = P.fit_hmm(flat, config=P.HMMConfig(n_states=3, min_duration=2, max_duration=5),
                    options=P.FitOptions(max_iter=3))
    assert np.all(np.isfinite(np.asarray(hmm.covariances)))
    assert np.all(np.isfinite(np.asarray(P.log_likelihood(hmm, flat))))


def phase_walk(rng, phi, n):
    """A 2-D movement whose path depends on φ: out to (3, 3φ) and back, randomly time-warped."""
    seqs, phases = [], []
    for _ in range(n):
        length = int(rng.integers(36, 45))
        u = np.linspace(0, 1, length)
        phase = u + 0.08 * np.sin(2 * np.pi * u) * rng.uniform(-1, 1)
        out = np.sin(np.pi * phase)[:, None] * np.array([3.0, 3.0 * phi])
        seqs.append(out + 0.05 * rng.normal(size=out.shape))
        phases.append(phase)
    return seqs, phases


@pytest.fixture(scope="module")
def walk_phmm():
    rng = np.random.default_rng(2)
    data = [phase_walk(rng, phi, 8) for phi in (0.0, 0.5, 1.0)]
    cfg = P.HMMConfig(n_states=8, min_duration=3, max_duration=6)
    return P.fit_phmm([d[0] for d in data], (3,), cfg, options=P.FitOptions(max_iter=15)), data


def test_synchronised_local_models_are_aligned(walk_phmm):
    phmm, data = walk_phmm
    boundary_phase = []
    for corner, (seqs, phases) in enumerate(data):
        states, _ = P.viterbi(phmm.corner((corner,)), seqs)
        states = np.asarray(states)
        per_state = [[phases[b][np.argmax(states[b] == k)] for b in range(len(seqs))] for k in range(1, 8)]
        boundary_phase.append(np.mean(per_state, axis=1))
    boundary_phase = np.array(boundary_phase)  # (corners, 7 boundaries)
    # The same state starts at the same phase of the movement in every local model.
    assert np.max(np.ptp(boundary_phase, axis=0)) < 0.05, boundary_phase
    # ... and the local means follow φ: the far point of state 4 scales with it.
    far = np.asarray(phmm.local.means)[:, 3:5, 1].mean(axis=1)
    assert far[0] < far[1] < far[2]


def test_interpolation_is_d_linear_and_differentiable(walk_phmm):
    phmm, data = walk_phmm
    x = data[1][0][:2]
    at_corner = np.asarray(P.phmm_log_likelihood(phmm, x, [0.5]))
    np.testing.assert_allclose(at_corner, np.asarray(P.log_likelihood(phmm.corner((1,)), x)), rtol=1e-5)
    mid = P.interpolate(phmm, np.array([0.25]))
    np.testing.assert_allclose(np.asarray(mid.means),
                               0.5 * np.asarray(phmm.local.means[0] + phmm.local.means[1]), atol=1e-5)
    X, lengths = jnp.asarray(np.stack([x[0][:36]])), jnp.asarray([36])
    f = lambda phi: batch_phmm_log_likelihood(phmm, X, lengths, phi[None])[0]  # noqa: E731
    phi = jnp.asarray([0.3])
    grad = float(jax.grad(f)(phi)[0])
    h = 1e-2
    numeric = (float(f(phi + h)) - float(f(phi - h))) / (2 * h)
    assert np.isfinite(grad) and abs(grad - numeric) <= 0.05 * abs(numeric) + 1e-2


def test_recognize_finds_class_and_parameter(walk_phmm):
    phmm, _ = walk_phmm
    rng = np.random.default_rng(3)
    other = P.PHMM(phmm.local.replace(means=phmm.local.means * np.array([1.0, -1.0])), phmm.grid_shape)
    tests, true_phi = [], np.array([0.2, 0.65, 0.9])
    for phi in true_phi:
        tests += phase_walk(rng, phi, 1)[0]
    mirrored = [s * np.array([1.0, -1.0]) for s in tests]
    rec = P.recognize([phmm, other], tests + mirrored)
    chex.assert_shape((rec.label, rec.phi, rec.loglik), [(6,), (6, 2, 1), (6, 2)])
    np.testing.assert_array_equal(rec.label, [0, 0, 0, 1, 1, 1])
    np.testing.assert_allclose(rec.phi[:3, 0, 0], true_phi, atol=0.08)
    with pytest.raises(ValueError, match="phi: expected 1 parameter"):
        P.phmm_log_likelihood(phmm, tests[0], [0.5, 0.5])


def test_recognize_reaches_the_maximum_of_a_dense_scan():
    """d = 2: the search's φ scores within 1 nat of the best of a 41 x 41 scan of [−ε, 1 + ε]² (the
    tolerance the search is held to), and its reported log-likelihood is the model's at that φ."""
    rng = np.random.default_rng(5)

    def walks(phi, n):  # out to (3 + φ₂, 3 φ₁) and back, time-warped
        seqs = []
        for _ in range(n):
            u = np.linspace(0, 1, int(rng.integers(30, 40)))
            phase = u + 0.1 * np.sin(2 * np.pi * u) * rng.uniform(-1, 1)
            out = np.sin(np.pi * phase)[:, None] * np.array([3.0 + phi[1], 3.0 * phi[0]])
            seqs.append(out + 0.1 * rng.normal(size=out.shape))
        return seqs

    phmm = P.fit_phmm([walks(c, 6) for c in P.grid_points((2, 2))], (2, 2),
                      P.HMMConfig(n_states=6, min_duration=3, max_duration=7), options=P.FitOptions(max_iter=10))
    tests = [w for phi in rng.uniform(-0.05, 1.05, (6, 2)) for w in walks(phi, 1)]
    rec = P.recognize(phmm, tests)
    axis = np.linspace(-0.1, 1.1, 41)
    grid = np.stack(np.meshgrid(axis, axis, indexing="ij"), -1).reshape(-1, 2)
    X, lengths = pad_sequences(tests, None, dim=2)
    B, M = len(tests), len(grid)
    scan = np.asarray(batch_phmm_log_likelihood(phmm, jnp.tile(jnp.asarray(X, jnp.float32), (M, 1, 1)),
                                                jnp.tile(jnp.asarray(lengths), M),
                                                jnp.asarray(np.repeat(grid, B, 0), jnp.float32))).reshape(M, B).max(0)
    assert np.all(np.asarray(rec.loglik[:, 0]) >= scan - 1.0), np.asarray(rec.loglik[:, 0]) - scan
    np.testing.assert_allclose(rec.loglik[:, 0], P.phmm_log_likelihood(phmm, tests, rec.phi[:, 0]), rtol=1e-5)


def walk_batch(n):
    """(X (n, T, 2), lengths (n,)): `phase_walk`s for n random φ in [0, 1], padded."""
    rng = np.random.default_rng(9)
    return pad_sequences([phase_walk(rng, phi, 1)[0][0] for phi in rng.uniform(0, 1, n)], None, dim=2)


def test_search_memory_does_not_grow_with_the_batch(walk_phmm):
    """With the chunk size fixed, 64 sequences need no more working memory than 4, beyond a copy of
    the larger inputs and outputs (searched as one batch, 64 need about ten times as much)."""
    phmm, _ = walk_phmm
    X, lengths = walk_batch(64)

    def memory(batch):
        X_b, lengths_b = jnp.asarray(X[:batch], jnp.float32), jnp.asarray(lengths[:batch])
        return P.search_parameters.lower(phmm, X_b, lengths_b, 0.1, 6, 13, 3, 4).compile().memory_analysis()

    small, large = memory(4), memory(64)
    batch_bytes = (large.argument_size_in_bytes - small.argument_size_in_bytes
                   + large.output_size_in_bytes - small.output_size_in_bytes)
    assert large.temp_size_in_bytes - small.temp_size_in_bytes <= batch_bytes, (small, large)


def test_recognize_in_chunks_equals_one_chunk(walk_phmm):
    """64 sequences searched 4 at a time give the labels, φ and log-likelihoods of one search of all
    64 (to float round-off: the products are blocked differently)."""
    phmm, _ = walk_phmm
    other = P.PHMM(phmm.local.replace(means=phmm.local.means * np.array([1.0, -1.0])), phmm.grid_shape)
    X, lengths = walk_batch(64)
    X[1::2] *= np.array([1.0, -1.0])  # every other sequence mirrored: both labels occur
    chunked = P.recognize([phmm, other], X, lengths, lattice_points=13, chunk_size=4)
    whole = P.recognize([phmm, other], X, lengths, lattice_points=13, chunk_size=64)
    np.testing.assert_array_equal(chunked.label, whole.label)
    np.testing.assert_allclose(chunked.loglik, whole.loglik, rtol=1e-5, atol=1e-3)  # nats
    np.testing.assert_allclose(chunked.phi, whole.phi, atol=1e-3)


def test_coarse_to_fine_start_is_the_best_lattice_point(walk_phmm):
    """d = 2, a 25 x 25 start lattice: the coarse-to-fine start (every second point, the 2 best of
    each sequence refined) is the point a brute-force scan of all 625 finds, also where that point
    is off the coarse lattice (which a coarse scan alone would miss)."""
    walk, _ = walk_phmm
    # A second parameter stretches the movement along x (exactly bilinear in φ).
    stretch = np.array([1.0, 1.25, 1.5])
    means = np.asarray(walk.local.means)[:, None] * np.stack([stretch, np.ones(3)], -1)[None, :, None]
    local = walk.local.replace(means=means.reshape(9, *means.shape[2:]),
                               **{f: np.repeat(np.asarray(getattr(walk.local, f)), 3, axis=0)
                                  for f in ("covariances", "log_cont", "log_exit")})
    phmm = P.PHMM(local, (3, 3))
    rng = np.random.default_rng(11)
    phis = rng.uniform(0, 1, (8, 2))
    X, lengths = pad_sequences([phase_walk(rng, a, 1)[0][0] * np.array([1.0 + 0.5 * b, 1.0]) for a, b in phis],
                               None, dim=2)
    X, lengths = jnp.asarray(X, jnp.float32), jnp.asarray(lengths)
    axis = np.linspace(0.0, 1.0, 25)
    lattice = np.stack(np.meshgrid(axis, axis, indexing="ij"), -1).reshape(-1, 2)
    M, B = len(lattice), len(X)
    scan = np.asarray(batch_phmm_log_likelihood(phmm, jnp.tile(X, (M, 1, 1)), jnp.tile(lengths, M),
                                                jnp.asarray(np.repeat(lattice, B, 0), jnp.float32))).reshape(M, B)
    best = np.argmax(scan, axis=0)
    # Some sequences' best points are off the coarse lattice (odd indices).
    assert np.any(np.stack(np.unravel_index(best, (25, 25)), -1) % 2 == 1)
    start = parametric._start_points(phmm, X, lengths, 25, 2, 2)  # 144 pairs: one model per pair
    np.testing.assert_allclose(np.asarray(start), lattice[best], atol=1e-6)
    # Five copies of the batch: more (candidate, sequence) pairs (720) than lattice points, so the
    # refinement gathers the points' models from a table (`_lattice_models`) instead.
    start = parametric._start_points(phmm, jnp.tile(X, (5, 1, 1)), jnp.tile(lengths, 5), 25, 2, 2)
    np.testing.assert_allclose(np.asarray(start), np.tile(lattice[best], (5, 1)), atol=1e-6)
    with pytest.raises(ValueError, match="coarse_top"):
        P.recognize(phmm, X, lengths, coarse_top=0)

def test_solve_spd_matches_numpy():
    from lfd_common import solve_spd
    rng = np.random.default_rng(6)
    for d in (1, 2, 3):
        a = rng.normal(size=(5, d, d))
        m = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(d)
        r = rng.normal(size=(5, d))
        np.testing.assert_allclose(np.asarray(solve_spd(jnp.asarray(m), jnp.asarray(r))),
                                   np.linalg.solve(m, r[..., None])[..., 0], rtol=1e-4, atol=1e-5)


def test_fit_phmm_rejects_a_missing_corner():
    rng = np.random.default_rng(4)
    groups = [square_walk(rng, 3) for _ in range(3)] + [[]]
    with pytest.raises(ValueError, match=r"groups\[3\]: the grid corner .* has no sequences"):
        P.fit_phmm(groups, (2, 2), P.HMMConfig(n_states=4, min_duration=2, max_duration=5))
    with pytest.raises(ValueError, match="groups: a 3x3 grid needs 9"):
        P.fit_phmm(groups, (3, 3), P.HMMConfig(n_states=4, min_duration=2, max_duration=5))


def test_synthesis_passes_through_the_state_means(walk_phmm):
    phmm, _ = walk_phmm
    hmm = phmm.corner((2,))
    movement = np.asarray(P.synthesize(phmm, [1.0], length=200))
    chex.assert_shape(movement, (200, 2))
    np.testing.assert_allclose(movement[0], np.asarray(hmm.means[0]), atol=1e-4)
    np.testing.assert_allclose(movement[-1], np.asarray(hmm.means[-1]), atol=1e-4)
    chex.assert_shape(P.synthesize(phmm, np.array([[0.0], [1.0]]), length=50), (2, 50, 2))


def test_hermite_spline_is_c1():
    times = jnp.asarray([0.0, 1.0, 2.5, 4.0])
    knots = jnp.asarray([[0.0], [1.0], [0.0], [2.0]])
    eps = 1e-3
    for t in (1.0, 2.5):
        left, mid, right = np.asarray(hermite_spline(times, knots, jnp.asarray([t - eps, t, t + eps])))[:, 0]
        assert abs((mid - left) / eps - (right - mid) / eps) < 1e-2  # no kink at a knot
        assert abs(mid - float(knots[list(np.asarray(times)).index(t), 0])) < 1e-6


def test_target_to_phi_rectangular_and_warped():
    rect = np.stack(np.meshgrid(np.linspace(-0.4, 0.4, 3), np.linspace(0.2, 0.5, 3), indexing="ij"), -1)
    phi = P.target_to_phi(rect, np.array([[0.0, 0.35], [0.2, 0.2], [-0.48, 0.5]]))
    np.testing.assert_allclose(phi, [[0.5, 0.5], [0.75, 0.0], [-0.1, 1.0]], atol=1e-5)
    warped = np.array([[[0.0, 0.0], [0.1, 1.0]], [[1.0, 0.2], [1.3, 1.4]]])
    truth = np.array([[0.3, 0.6], [0.8, 0.1]])
    targets = np.stack([np.asarray(multilinear_map(jnp.asarray(warped), jnp.asarray(p))) for p in truth])
    np.testing.assert_allclose(P.target_to_phi(warped, targets), truth, atol=1e-4)
    with pytest.raises(ValueError, match="targets: expected points of dimension 2"):
        P.target_to_phi(warped, np.zeros((1, 3)))


def test_fit_options_are_validated_and_never_retrace():
    for field, value in (("local_max_iter", -1), ("freeze_means_after", -1), ("max_iter", -2), ("tol", -1.0),
                         ("reg_covar", float("nan")), ("gradient_steps", 1.5), ("optimizer", "adam")):
        with pytest.raises(ValueError, match=f"^{field}:"):
            P.FitOptions(**{field: value})
    with pytest.raises(ValueError, match="options: expected a phmm_jax.FitOptions"):
        P.fit_hmm(square_walk(np.random.default_rng(5), 4), config=P.HMMConfig(4, 2, 5), options={"max_iter": 2})
    with pytest.raises(TypeError):
        P.HMMConfig(n_states=4, n_iter=3)  # fit options are no longer part of the structure
    seqs = square_walk(np.random.default_rng(6), 6)
    cfg = P.HMMConfig(n_states=4, min_duration=2, max_duration=5)
    P.fit_hmm(seqs, config=cfg, options=P.FitOptions(max_iter=2))
    traces = em_step._cache_size()
    for options in (P.FitOptions(max_iter=2, tol=1e-7), P.FitOptions(max_iter=3, reg_covar=1e-2, duration_pseudocount=0.1)):
        hmm = P.fit_hmm(seqs, config=cfg, options=options)
    assert em_step._cache_size() == traces  # real-valued options are traced, not static
    assert hmm.config == cfg
    adam = P.fit_hmm_gradient(seqs, config=cfg, options=P.FitOptions(gradient_steps=30, optimizer=optax.adam(0.05)),
                              return_history=True)[1]
    chex.assert_shape(adam, (30,))
    assert float(adam[-1]) < float(adam[0])  # any optax optimiser fits


def test_save_load_round_trip(tmp_path, walk_phmm, monkeypatch):
    phmm, _ = walk_phmm
    hmm = phmm.corner((0,))
    for model in (hmm, phmm):
        path = P.save(tmp_path / type(model).__name__, model)
        loaded = P.load(path)
        assert type(loaded) is type(model)
        a = loaded.local if isinstance(loaded, P.PHMM) else loaded
        b = model.local if isinstance(model, P.PHMM) else model
        assert a.config == b.config
        chex.assert_trees_all_close(loaded, model, rtol=0, atol=0)
    assert P.load(tmp_path / "PHMM.npz").grid_shape == (3,)
    monkeypatch.chdir(tmp_path)
    P.save("model", hmm)  # the same name loads: ".npz" is appended by both
    chex.assert_trees_all_close(P.load("model"), hmm, rtol=0, atol=0)
    broken = tmp_path / "broken.npz"
    broken.write_bytes((tmp_path / "HMM.npz").read_bytes()[:200])
    with pytest.raises(ValueError, match="truncated or corrupt"):
        P.load(broken)
    other = save_arrays(tmp_path / "other", "crf_jax.ChainCRF", {"w": np.zeros(2)})
    with pytest.raises(ValueError, match=r"other.npz holds a 'crf_jax.ChainCRF', expected one of \['phmm_jax.HMM'"):
        P.load(other)


def _hmm_file(path, hmm, config=None, **arrays):
    """An HMM file as `save` writes it, with arrays or the structure replaced."""
    fields = {name: np.asarray(getattr(hmm, name)) for name in ("means", "covariances", "log_cont", "log_exit")}
    structure = dataclasses.asdict(config or hmm.config)
    return save_arrays(path, "phmm_jax.HMM", {**fields, **arrays}, {"structure": structure})


def _two_state_hmm():
    """2 states of 1-2 steps each, D = 2."""
    half = np.log(0.5)
    return P.HMM(jnp.asarray([[0.0, 0.0], [1.0, 1.0]]), jnp.stack([jnp.eye(2)] * 2),
                 jnp.asarray([[half, -np.inf]] * 2), jnp.asarray([[half, 0.0]] * 2),
                 P.HMMConfig(n_states=2, min_duration=1, max_duration=2))


def test_load_rejects_arrays_that_disagree_with_the_structure(tmp_path):
    hmm = _two_state_hmm()
    P.load(_hmm_file(tmp_path / "good", hmm))
    means = np.asarray(hmm.means).copy()
    means[1, 1] = np.nan
    not_pd = np.asarray(hmm.covariances).copy()
    not_pd[1] = np.diag([1.0, -1.0])
    cases = {
        "nan_means": ({"means": means}, None, "array 'means': contains 1 NaN"),
        "not_pd": ({"covariances": not_pd}, None, "covariances: not positive definite"),
        "unnormalised": ({"log_exit": np.asarray(hmm.log_exit) - 0.5}, None, "do not sum to 1"),
        "forbidden": ({"log_cont": np.zeros((2, 2))}, None, "log_cont: .* -inf where the structure forbids"),
        "three_means": ({"means": np.zeros((3, 2))}, None, r"array 'means': expected shape \(2, 'D'\)"),
        "five_states": ({}, P.HMMConfig(n_states=5, min_duration=1, max_duration=2), r"expected shape \(5, 'D'\)"),
        "other_dim": ({"means": np.zeros((2, 3))}, None, "array 'covariances': expected shape"),
    }
    for name, (arrays, config, message) in cases.items():
        path = _hmm_file(tmp_path / name, hmm, config, **arrays)
        with pytest.raises(ValueError, match=f"path: {re.escape(str(path))}.*{message}"):
            P.load(path)
    corners = P.PHMM(jax.tree_util.tree_map(lambda a: jnp.stack([a] * 4), hmm), (2, 2))
    P.load(P.save(tmp_path / "grid_2x2", corners))
    local = {f"local/{k}": np.asarray(getattr(corners.local, k)) for k in ("means", "covariances", "log_cont", "log_exit")}
    structure = {"hmm": dataclasses.asdict(hmm.config), "grid_shape": [3, 3]}  # 9 corners, the arrays have 4
    path = save_arrays(tmp_path / "grid_3x3", "phmm_jax.PHMM", local, {"structure": structure})
    with pytest.raises(ValueError, match=re.escape(f"path: {path}") + r".*array 'local/means': expected shape \(9, 2, 'D'\)"):
        P.load(path)
    with pytest.raises(ValueError, match="model: .*not positive definite"):
        P.save(tmp_path / "bad", hmm.replace(covariances=jnp.asarray(not_pd)))
