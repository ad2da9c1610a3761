"""phmm_jax inference against brute-force enumeration, a dense float64 numpy HMM and hmmlearn."""
import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.special import logsumexp

import phmm_jax as P
from phmm_jax._src import batched as _batched, inference as inference, model as _model
from phmm_jax import gaussian_log_density, gaussian_log_density_columns, stacked_log_density_columns
from phmm_jax import transitions_from_durations
from tests.phmm_reference import brute_force, dense_forward_backward, emission_table

STRUCTURES = [
    P.HMMConfig(n_states=3, min_duration=2, max_duration=4),
    P.HMMConfig(n_states=3, min_duration=1, max_duration=3, covariance_type="diag"),
    P.HMMConfig(n_states=3, min_duration=1),
    P.HMMConfig(n_states=2, min_duration=3),
]


@pytest.fixture(autouse=True)
def float64():
    previous = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", previous)


def random_hmm(cfg, rng, dim=2):
    n, p = cfg.n_states, cfg.n_pseudo
    means = rng.normal(scale=1.5, size=(n, dim))
    if cfg.covariance_type == "full":
        a = rng.normal(size=(n, dim, dim))
        covs = a @ a.transpose(0, 2, 1) + 0.5 * np.eye(dim)
    else:
        covs = rng.uniform(0.5, 2.0, size=(n, dim))[:, :, None] * np.eye(dim)
    if cfg.explicit_duration:
        log_p = np.log(rng.dirichlet(np.ones(p), size=n))
        log_p[:, : cfg.min_duration - 1] = -np.inf
        log_p -= logsumexp(log_p, axis=1, keepdims=True)
        log_cont, log_exit = transitions_from_durations(cfg, jnp.asarray(log_p))
    else:
        stay = rng.uniform(0.3, 0.8, size=n)
        log_cont = np.zeros((n, p))
        log_exit = np.full((n, p), -np.inf)
        log_cont[:, -1], log_exit[:, -1] = np.log(stay), np.log1p(-stay)
    return P.HMM(jnp.asarray(means), jnp.asarray(covs), jnp.asarray(log_cont), jnp.asarray(log_exit), cfg)


@pytest.mark.parametrize("cfg", STRUCTURES)
def test_loglik_viterbi_posteriors_against_enumeration(cfg):
    rng = np.random.default_rng(1)
    hmm = random_hmm(cfg, rng)
    X = rng.normal(scale=1.5, size=(3, 9, 2))
    lengths = np.array([9, 7, 6])
    loglik = np.asarray(P.log_likelihood(hmm, X, lengths))
    states, best = map(np.asarray, P.viterbi(hmm, X, lengths))
    post = P.posteriors(hmm, X, lengths)
    msgs = P.messages(hmm, X, lengths)
    n, p = cfg.n_states, cfg.n_pseudo
    chex.assert_shape((loglik, states, best), [(3,), (3, 9), (3,)])
    chex.assert_shape(list(post), [(3, 9, n), (3, 9, n, p), (3,)])
    chex.assert_shape(list(msgs), [(3, 9, n, p), (3, 9, n, p), (3,)])
    chex.assert_trees_all_close(msgs.loglik, post.loglik, rtol=1e-10)
    # The messages give the same pseudo-state posteriors, batch-first like `posteriors`.
    from_messages = jnp.exp(msgs.log_alpha + msgs.log_beta - msgs.loglik[:, None, None, None])
    chex.assert_trees_all_close(from_messages, post.pseudo, atol=1e-10)
    dense = P.expand_to_dense(hmm)
    for b, length in enumerate(lengths):
        x = X[b, :length]
        ref_ll, ref_best, ref_path = brute_force(hmm, x)
        np.testing.assert_allclose(loglik[b], ref_ll, rtol=1e-10)
        np.testing.assert_allclose(best[b], ref_best, rtol=1e-10)
        np.testing.assert_array_equal(states[b, :length], ref_path)
        assert np.all(states[b, length:] == -1)
        dense_ll, dense_post = dense_forward_backward(dense, x)
        np.testing.assert_allclose(dense_ll, ref_ll, rtol=1e-10)
        np.testing.assert_allclose(np.asarray(post.pseudo[b, :length]).reshape(length, -1), dense_post, atol=1e-10)
        assert np.all(np.asarray(post.state[b, length:]) == 0)
    np.testing.assert_allclose(np.asarray(post.state.sum(-1)), (np.arange(9) < lengths[:, None]).astype(float),
                               atol=1e-10)


@pytest.mark.parametrize("cfg", STRUCTURES[:3])
def test_loglik_matches_hmmlearn_on_expanded_model(cfg):
    hmm_module = pytest.importorskip("hmmlearn.hmm")
    from hmmlearn import _hmmc

    rng = np.random.default_rng(2)
    hmm = random_hmm(cfg, rng, dim=3)
    dense = P.expand_to_dense(hmm)
    X = rng.normal(scale=1.5, size=(4, 9, 3))
    lengths = np.array([9, 8, 6, 7])
    ours = np.asarray(P.log_likelihood(hmm, X, lengths))
    ref = hmm_module.GaussianHMM(n_components=len(dense.means), covariance_type="full")
    ref.n_features = 3
    ref.startprob_ = np.exp(dense.log_initial)
    ref.means_ = dense.means
    ref.covars_ = dense.covariances
    for b, length in enumerate(lengths):
        log_frameprob = ref._compute_log_likelihood(X[b, :length])
        _, fwd = _hmmc.forward_log(np.exp(dense.log_initial), np.exp(dense.log_transition), log_frameprob)
        # hmmlearn has no end state: the end constraint is applied to its forward lattice.
        theirs = logsumexp(fwd[-1] + dense.log_final)
        assert abs(ours[b] - theirs) <= 1e-5 * abs(theirs)


def test_expand_to_dense_is_stochastic_with_the_end():
    hmm = random_hmm(STRUCTURES[0], np.random.default_rng(3))
    dense = P.expand_to_dense(hmm)
    out_mass = logsumexp(np.concatenate([dense.log_transition, dense.log_final[:, None]], axis=1), axis=1)
    reachable = np.isfinite(out_mass)
    np.testing.assert_allclose(out_mass[reachable], 0.0, atol=1e-12)
    assert dense.log_transition[0, 2 * 4] == -np.inf  # no skipping a state


@pytest.mark.parametrize("cfg", STRUCTURES)
def test_gradient_posteriors_and_counts_match_forward_backward(cfg):
    """The E-step statistics (gradients of the log-likelihood) equal the explicit float64 numpy
    forward-backward's posteriors and expected transition counts, and our log-space messages."""
    rng = np.random.default_rng(4)
    hmm = random_hmm(cfg, rng)
    X, lengths = rng.normal(size=(3, 9, 2)), np.array([9, 7, 8])  # feasible for every structure
    weights = np.array([1.0, 0.5, 2.0])
    log_b = _batched.emission_columns(hmm, jnp.asarray(X))
    chex.assert_shape(log_b, (9, cfg.n_states, 3))  # column layout (T, N, B)
    chain = inference.chain(hmm)
    stats = inference.expected_statistics(chain, log_b, jnp.asarray(lengths), jnp.asarray(weights))
    state, pseudo, _ = inference.posteriors(chain, log_b, jnp.asarray(lengths))  # (T, N, B), (T, B, N, P)
    pseudo = jnp.transpose(pseudo, (0, 2, 3, 1))
    messages = inference.forward_backward(chain, log_b, jnp.asarray(lengths))
    np.testing.assert_allclose(pseudo, inference.pseudo_posteriors(messages), atol=1e-10)
    np.testing.assert_allclose(state, pseudo.sum(2), atol=1e-10)
    n, p = cfg.n_states, cfg.n_pseudo
    dense = P.expand_to_dense(hmm)
    cont_ref, exit_ref = np.zeros((n, p)), np.zeros((n, p))
    for b, length in enumerate(lengths):
        loglik, post, counts, end = dense_forward_backward(dense, X[b, :length], with_counts=True)
        np.testing.assert_allclose(stats.loglik[b], loglik, rtol=1e-10)
        np.testing.assert_allclose(stats.state[:length, :, b], weights[b] * post.reshape(length, n, p).sum(-1),
                                   atol=1e-10)
        np.testing.assert_allclose(pseudo[:length, :, :, b], post.reshape(length, n, p), atol=1e-10)
        assert np.all(np.asarray(stats.state[length:, :, b]) == 0)
        for i, j in np.ndindex(n, p):
            s = i * p + j
            cont_ref[i, j] += weights[b] * counts[s, i * p + min(j + 1, p - 1)]
            exit_ref[i, j] += weights[b] * (counts[s, (i + 1) * p] if i + 1 < n else end[s])
    np.testing.assert_allclose(stats.cont[..., 0], cont_ref, atol=1e-10)
    np.testing.assert_allclose(stats.exits[..., 0], exit_ref, atol=1e-10)
    if cfg.explicit_duration:  # every explicit-duration state is left exactly once per sequence
        np.testing.assert_allclose(stats.exits[..., 0].sum(-1), weights.sum(), atol=1e-10)


def test_padding_leaks_into_neither_values_nor_gradients():
    cfg = STRUCTURES[0]
    rng = np.random.default_rng(5)
    hmm = random_hmm(cfg, rng)
    x = rng.normal(size=(7, 2))
    padded = np.concatenate([x, np.full((5, 2), 1e3)])[None]

    def loglik_of_means(means, X, lengths):
        return _batched.batch_log_likelihood(hmm.replace(means=means), X, lengths)[0]

    short = jax.value_and_grad(loglik_of_means)(hmm.means, jnp.asarray(x[None]), jnp.asarray([7]))
    long = jax.value_and_grad(loglik_of_means)(hmm.means, jnp.asarray(padded), jnp.asarray([7]))
    np.testing.assert_allclose(short[0], long[0], rtol=1e-12)
    assert np.all(np.isfinite(long[1]))
    np.testing.assert_allclose(short[1], long[1], rtol=1e-10)


def test_emissions_match_scipy():
    """All three layouts: frames (T, D), columns (T, D, B) and one model per sequence (B models)."""
    rng = np.random.default_rng(6)
    hmms = [random_hmm(STRUCTURES[0], rng, dim=4) for _ in range(3)]
    X = rng.normal(size=(3, 5, 4))  # (B, T, D)
    tables = np.stack([emission_table(np.asarray(h.means), np.asarray(h.covariances), x) for h, x in zip(hmms, X)])
    hmm = hmms[0]
    ours = np.asarray(gaussian_log_density(jnp.asarray(X[0]), hmm.means, hmm.covariances))
    np.testing.assert_allclose(ours, tables[0], rtol=1e-10)
    shared = emission_table(np.asarray(hmm.means), np.asarray(hmm.covariances), X.reshape(-1, 4)).reshape(3, 5, -1)
    columns = gaussian_log_density_columns(jnp.asarray(X), hmm.means, hmm.covariances)
    np.testing.assert_allclose(np.transpose(columns, (2, 0, 1)), shared, rtol=1e-10)
    stacked = stacked_log_density_columns(jnp.asarray(X), jnp.stack([h.means for h in hmms]),
                                          jnp.stack([h.covariances for h in hmms]))
    np.testing.assert_allclose(np.transpose(stacked, (2, 0, 1)), tables, rtol=1e-10)


def test_emission_gradients_match_finite_differences():
    """The closed-form gradient of `whitening` (custom VJP) against central differences, along random
    directions of the means and symmetric directions of the covariances."""
    rng = np.random.default_rng(8)
    hmm = random_hmm(STRUCTURES[0], rng, dim=3)
    x = jnp.asarray(rng.normal(size=(6, 3)))
    weights = jnp.asarray(rng.normal(size=(6, hmm.n_states)))

    def objective(means, covariances):
        return jnp.sum(weights * gaussian_log_density(x, means, covariances))

    g_means, g_cov = jax.grad(objective, argnums=(0, 1))(hmm.means, hmm.covariances)
    eps = 1e-6
    for _ in range(3):
        d_means = rng.normal(size=hmm.means.shape)
        d_cov = rng.normal(size=hmm.covariances.shape)
        d_cov = d_cov + np.swapaxes(d_cov, -1, -2)
        central = (objective(hmm.means + eps * d_means, hmm.covariances + eps * d_cov)
                   - objective(hmm.means - eps * d_means, hmm.covariances - eps * d_cov)) / (2 * eps)
        np.testing.assert_allclose(np.sum(g_means * d_means) + np.sum(g_cov * d_cov), central, rtol=1e-6)


def test_bad_input_is_named():
    hmm = random_hmm(STRUCTURES[0], np.random.default_rng(7))  # 3 states x 2..4 steps: 6..12 frames
    good = np.zeros((2, 8, 2))
    with pytest.raises(ValueError, match="shorter than the shortest allowed path"):
        P.log_likelihood(hmm, np.zeros((1, 5, 2)))
    with pytest.raises(ValueError, match="longer than the longest allowed path"):
        P.log_likelihood(hmm, np.zeros((1, 13, 2)))
    with pytest.raises(ValueError, match="X: contains 1 NaN"):
        bad = good.copy()
        bad[1, 3, 0] = np.nan
        P.log_likelihood(hmm, bad)
    with pytest.raises(ValueError, match="X: expected feature dimension D=2"):
        P.log_likelihood(hmm, np.zeros((2, 8, 3)))
    with pytest.raises(ValueError, match="X: the batch is empty"):
        P.log_likelihood(hmm, np.zeros((0, 8, 2)))
    with pytest.raises(ValueError, match="lengths: values must be <= 8"):
        P.log_likelihood(hmm, good, lengths=[8, 9])
    with pytest.raises(ValueError, match="lengths: values must be >= 1"):
        P.log_likelihood(hmm, good, lengths=[8, 0])
    with pytest.raises(ValueError, match="min_duration: must be <= max_duration"):
        P.HMMConfig(n_states=3, min_duration=5, max_duration=4)
    # NaN in the padding is not an error: it is never read.
    padded = good.copy()
    padded[1, 7] = np.nan
    assert np.all(np.isfinite(np.asarray(P.log_likelihood(hmm, padded, lengths=[8, 7]))))
    # A list of unequal sequences is padded for the user.
    out = P.log_likelihood(hmm, [np.zeros((8, 2)), np.zeros((7, 2))])
    np.testing.assert_allclose(out, P.log_likelihood(hmm, padded, lengths=[8, 7]))



@pytest.mark.parametrize("cfg", [P.HMMConfig(n_states=6, min_duration=2, max_duration=4),
                                 P.HMMConfig(n_states=6, min_duration=2)])
def test_emissions_of_unreachable_states_are_skipped_exactly(cfg):
    """`reachable_states` equals the states of the pseudo-states the dense transition graph reaches
    from the start at frame t *and* from which it can end by the last frame. Scoring only those (a
    batch large enough for several blocks of frames, unequal lengths) and running the banded forward
    gives the log-likelihoods and posteriors of the explicit forward-backward over every state's
    densities, and the same Viterbi paths."""
    rng = np.random.default_rng(9)
    hmm = random_hmm(cfg, rng)
    n_frames, batch = 20, 200
    dense = P.expand_to_dense(hmm)
    step = np.isfinite(dense.log_transition)
    from_start = [np.isfinite(dense.log_initial)]
    to_end = [np.isfinite(dense.log_final)]
    for _ in range(n_frames - 1):
        from_start.append(step[from_start[-1]].any(axis=0))
        to_end.append(to_end[-1] | step[:, to_end[-1]].any(axis=1))
    first, last = _model.reachable_states(cfg, n_frames)
    for t in range(n_frames):
        states = np.unique(dense.state_of[from_start[t] & to_end[n_frames - 1 - t]])
        assert (first[t], last[t]) == (states.min(), states.max()) and len(states) == last[t] - first[t] + 1
    start, width = _model.state_band(cfg, n_frames)
    assert np.all((start <= first) & (start + width - 1 >= last)) and set(np.diff(start)) <= {0, 1}
    assert width < cfg.n_states  # the case under test: the band is narrower than the model
    X = jnp.asarray(rng.normal(size=(batch, n_frames, 2)))
    lengths = jnp.asarray(rng.integers(12, n_frames + 1, size=batch))
    chain = inference.chain(hmm)
    banded = _batched.emission_columns(hmm, X)
    full = _batched.emission_columns(hmm, X, all_states=True)
    messages = inference.forward_backward(chain, full, lengths)
    np.testing.assert_allclose(inference.forward_loglik(chain, banded, lengths), messages.loglik, rtol=1e-12)
    pseudo = jnp.transpose(inference.posteriors(chain, banded, lengths).pseudo, (0, 2, 3, 1))
    np.testing.assert_allclose(pseudo, inference.pseudo_posteriors(messages), atol=1e-10)
    np.testing.assert_array_equal(inference.viterbi(chain, banded, lengths)[0], inference.viterbi(chain, full, lengths)[0])
    # One model per sequence (the PHMM search's layout): the reachable states' densities are the full
    # ones, every state left out is one no path visits, so the log-likelihoods agree.
    per_sequence = lambda a: jnp.broadcast_to(a, (batch,) + a.shape)  # noqa: E731
    stacked = np.asarray(stacked_log_density_columns(X, per_sequence(hmm.means), per_sequence(hmm.covariances),
                                                     (first, last)))
    in_band = (np.arange(cfg.n_states)[None] >= first[:, None]) & (np.arange(cfg.n_states)[None] <= last[:, None])
    np.testing.assert_allclose(stacked[in_band], np.asarray(full)[in_band], rtol=1e-12)
    assert np.all(np.isfinite(stacked[in_band])) and np.isneginf(stacked).any()
    np.testing.assert_allclose(inference.forward_loglik(chain, jnp.asarray(stacked), lengths), messages.loglik, rtol=1e-12)


def test_banded_forward_of_frames_too_few_for_the_states_is_minus_infinity():
    """T < N * min_duration: the last state is never in the band, and no path ends in time; the
    dense recursion agrees (-inf), and the gradient stays finite."""
    cfg = P.HMMConfig(n_states=5, min_duration=3, max_duration=4)
    hmm = random_hmm(cfg, np.random.default_rng(3))
    chain = inference.chain(hmm)
    log_b = jnp.asarray(np.random.default_rng(4).normal(size=(14, 5, 3)))
    lengths = jnp.asarray([14, 14, 10])
    assert np.all(np.isneginf(inference.forward_loglik(chain, log_b, lengths)))
    assert np.all(np.isneginf(inference.forward_backward(chain, log_b, lengths).loglik))
    grad = jax.grad(lambda lb: jnp.sum(jnp.where(True, 0.0, inference.forward_loglik(chain, lb, lengths))))(log_b)
    assert np.all(np.isfinite(grad))
