"""Online (streaming) recognition, phmm_jax.online: the streaming forward pass equals the
batch one at every prefix (and a float64 numpy forward), any split of a stream into steps gives the
same state, and the online recogniser finds two movements in a synthetic stream with the right class
and φ. Tiny models (few states, short sequences) so that the module compiles each function once."""
import re

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.special import logsumexp

import phmm_jax as P
from tests.phmm_reference import emission_table
from tests.synthetic_movements import out_and_back

PROPERTY = settings(max_examples=15, deadline=None, database=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
D = 3
CFG = P.HMMConfig(n_states=4, min_duration=2, max_duration=8)  # paths of 8..32 frames
REST = np.array([0.0, -0.3, 0.1])


def raises_named(name, call):
    with pytest.raises(ValueError, match=f"^{re.escape(name)}:"):
        call()


def movement(rng, kind: int, phi: float, noise: float = 0.004):
    """A synthetic hand movement (T, 3) from REST to a target on a line (φ in [0, 1]) and back: kind 0
    straight with a hold at the target ("pointing"), kind 1 over an arc lifted in z ("reaching")."""
    return out_and_back(rng, kind, REST, REST + np.array([0.35, -0.2 + 0.4 * phi, 0.1]), noise)


@pytest.fixture(scope="module")
def phmms():
    rng = np.random.default_rng(0)
    groups = lambda kind: [[movement(rng, kind, phi) for _ in range(5)] for phi in (0.0, 1.0)]  # noqa: E731
    return [P.fit_phmm(groups(kind), (2,), CFG, options=P.FitOptions(max_iter=8)) for kind in (0, 1)]


@pytest.fixture(scope="module")
def hmm(phmms):
    return jax.jit(P.interpolate)(phmms[0], jnp.array([0.4]))  # eager interpolate dispatches op by op


@pytest.fixture(scope="module")
def sequence():
    return movement(np.random.default_rng(1), 0, 0.4)


def numpy_forward(hmm, x):
    """float64 forward pass over the dense pseudo-state HMM: (log alpha (T, N, P), finished log p (T,))."""
    dense = P.expand_to_dense(hmm)
    log_b = emission_table(dense.means, dense.covariances, x)
    alpha = np.zeros_like(log_b)
    alpha[0] = dense.log_initial + log_b[0]
    for t in range(1, len(x)):
        alpha[t] = logsumexp(alpha[t - 1][:, None] + dense.log_transition, axis=0) + log_b[t]
    finished = logsumexp(alpha + dense.log_final, axis=1)
    return alpha.reshape(len(x), *np.shape(hmm.log_cont)), finished


def close_logs(a, b, atol):
    """Equal -inf pattern, finite values within atol."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    np.testing.assert_array_equal(np.isneginf(a), np.isneginf(b))
    finite = np.isfinite(a)
    np.testing.assert_allclose(a[finite], b[finite], rtol=0, atol=atol)


def test_streaming_equals_batch_forward_at_every_prefix(hmm, sequence):
    n_frames = len(sequence)
    states = P.stream_forward(hmm, sequence)  # lax.scan over single-frame steps
    chex.assert_shape(states.log_alpha, (n_frames, CFG.n_states, CFG.n_pseudo))
    chex.assert_shape((states.loglik, states.log_prefix, states.n_frames), (n_frames,))
    np.testing.assert_array_equal(states.n_frames, np.arange(1, n_frames + 1))
    # The forward messages of the whole sequence at frame t are those of the prefix x[:t+1].
    batch_alpha = P.messages(hmm, sequence).log_alpha[0]
    scale = 1e-5 * (1 + np.max(np.abs(np.where(np.isfinite(batch_alpha), batch_alpha, 0))))
    close_logs(states.log_alpha, batch_alpha, scale)
    # Finished log-likelihood of every feasible prefix = the batch log_likelihood of that prefix.
    lengths = np.arange(CFG.min_length, n_frames + 1)
    padded = np.broadcast_to(sequence, (len(lengths),) + sequence.shape)
    batch_loglik = P.log_likelihood(hmm, padded, lengths)
    close_logs(states.loglik[lengths - 1], batch_loglik, scale)
    assert np.all(np.isneginf(states.loglik[: CFG.min_length - 1]))
    flat = np.asarray(states.log_alpha, np.float64).reshape(n_frames, -1)
    np.testing.assert_allclose(states.log_prefix, logsumexp(flat, axis=1), rtol=1e-6)
    # And a float64 numpy forward pass.
    ref_alpha, ref_finished = numpy_forward(hmm, sequence)
    close_logs(states.log_alpha, ref_alpha, 1e-3 * (1 + np.max(np.abs(np.where(np.isfinite(ref_alpha), ref_alpha, 0)))))
    close_logs(states.loglik, ref_finished, 1e-3 * (1 + np.max(np.abs(ref_finished[np.isfinite(ref_finished)]))))
    # One frame at a time through the checked public step, and S streams by vmap.
    state = P.init_stream(hmm)
    for t in range(4):
        state = P.stream_step(hmm, state, sequence[t])
    close_logs(state.log_alpha, states.log_alpha[3], scale)
    batch = P.init_stream(hmm, n_streams=2)
    for t in range(4):
        batch = P.stream_step_batch(hmm, batch, np.stack([sequence[t], sequence[t] + 0.01]))
    chex.assert_shape(batch.log_alpha, (2, CFG.n_states, CFG.n_pseudo))
    close_logs(batch.log_alpha[0], states.log_alpha[3], scale)
    np.testing.assert_array_equal(batch.n_frames, [4, 4])


@given(cuts=st.lists(st.integers(1, 4), min_size=1, max_size=12))
@PROPERTY
def test_any_split_into_steps_gives_the_same_state(hmm, sequence, cuts):
    """Chunks of 1-4 frames fed by stream_forward, each from the last state, end in the state of the
    whole sequence fed at once (same scan step: equal to round-off of the compiled loop)."""
    whole = P.stream_forward(hmm, sequence)
    state, position = None, 0
    for size in cuts:
        if position >= len(sequence):
            break
        chunk = sequence[position:position + size]
        states = P.stream_forward(hmm, chunk, state)
        state = jax.tree_util.tree_map(lambda a: a[-1], states)
        position += len(chunk)
    expected = jax.tree_util.tree_map(lambda a: a[position - 1], whole)
    assert int(state.n_frames) == position
    for got, want in zip(state, expected):
        close_logs(got, want, 1e-4)


def test_stream_input_checks(hmm, sequence):
    state = P.init_stream(hmm)
    raises_named("x_t", lambda: P.stream_step(hmm, state, np.zeros(D + 1)))
    raises_named("x_t", lambda: P.stream_step(hmm, state, np.array([0.0, np.nan, 0.0])))
    raises_named("x_t", lambda: P.stream_step(hmm, state, np.array([0.0, np.inf, 0.0])))
    raises_named("x_t", lambda: P.stream_step(hmm, state, np.full(D, 1e30)))
    raises_named("X", lambda: P.stream_forward(hmm, np.zeros((0, D))))
    raises_named("X", lambda: P.stream_forward(hmm, sequence[:, :2]))
    raises_named("hmm", lambda: P.stream_step("hmm", state, sequence[0]))
    raises_named("state", lambda: P.stream_step(hmm, (1, 2), sequence[0]))
    raises_named("state", lambda: P.stream_step(hmm, P.init_stream(hmm, 3), sequence[0]))
    raises_named("states", lambda: P.stream_step_batch(hmm, P.init_stream(hmm, 3), sequence[:2]))
    raises_named("n_streams", lambda: P.init_stream(hmm, 0))
    # Inside the caller's jit only shapes can be checked; the step stays pure and jit-able.
    jitted = jax.jit(lambda s, x: P.stream_step(hmm, s, x))
    close_logs(jitted(state, sequence[0]).log_alpha, P.stream_step(hmm, state, sequence[0]).log_alpha, 1e-5)


def make_stream(rng):
    """Rest, a kind-0 movement at φ = 0.25, rest, a kind-1 movement at φ = 0.75, rest: (stream, truth)."""
    parts, truth, t = [], [], 0
    for kind, phi in ((0, 0.25), (1, 0.75)):
        rest = REST + 0.004 * rng.normal(size=(12, D))
        parts.append(rest)
        t += len(rest)
        move = movement(rng, kind, phi)
        parts.append(move)
        truth.append((kind, phi, t, t + len(move) - 1))
        t += len(move)
    parts.append(REST + 0.004 * rng.normal(size=(12, D)))
    return np.concatenate(parts), truth


@pytest.fixture(scope="module")
def recognizer(phmms):
    return P.online_recognizer(phmms, threshold=0.05, options=P.OnlineOptions(window=3))


def test_online_recognizer_finds_both_movements(recognizer):
    stream, truth = make_stream(np.random.default_rng(5))
    events = P.run_online(recognizer, stream)
    chex.assert_shape((events.found, events.start, events.end, events.report, events.label), (len(truth),))
    chex.assert_shape(events.phi, (len(truth), 1))
    chex.assert_shape(events.loglik, (len(truth), 2))
    assert np.all(events.found)
    assert not np.any(np.isnan(events.phi)) and not np.any(np.isnan(events.loglik))
    for k, (kind, phi, start, end) in enumerate(truth):
        assert events.label[k] == kind
        assert abs(events.phi[k, 0] - phi) < 0.1
        assert abs(events.start[k] - start) <= 3 and abs(events.end[k] - end) <= 3
        assert events.report[k] == events.end[k] + recognizer.options.window  # bounded latency
    # The live driver, frame by frame, reports the same events at the same frames.
    live = P.OnlineStream(recognizer)
    reported = [(t, e) for t, x in enumerate(stream) for e in [live.push(x)] if len(e.found)]
    assert [t for t, _ in reported] == list(events.report)
    for (_, e), k in zip(reported, range(len(truth))):
        assert e.label[0] == events.label[k] and e.start[0] == events.start[k] and e.end[0] == events.end[k]
        np.testing.assert_allclose(e.phi[0], events.phi[k], atol=1e-4)
    # The per-frame trace: provisional class during the movements, no NaN, and S streams by vmap.
    _, trace = P.online_scan(recognizer, stream)
    assert not np.any(np.isnan(np.asarray(trace.log_exit)))
    states = P.init_online(recognizer, n_streams=2)
    for x in stream[:20]:
        states, frame = P.online_step_batch(recognizer, states, np.stack([x, x]))
    chex.assert_shape(frame.prefix, (2, 2))


def test_online_edge_cases_and_checks(recognizer, phmms):
    # A stream at rest: no events (E = 0), correctly shaped.
    events = P.run_online(recognizer, REST + 0.004 * np.random.default_rng(2).normal(size=(30, D)))
    chex.assert_shape(events.phi, (0, 1))
    # A movement too short for any class: detected, not found, never NaN.
    short = np.concatenate([np.repeat(REST[None], 10, 0), REST + [[0.3, 0, 0]] * 3, np.repeat(REST[None], 10, 0)])
    events = P.run_online(P.online_recognizer(phmms, threshold=0.05, options=P.OnlineOptions(window=3)), short)
    assert not np.any(np.isnan(events.loglik)) and not np.any(np.isnan(events.phi))
    assert np.all(~events.found | (events.end - events.start + 1 >= CFG.min_length))
    state = P.init_online(recognizer)
    raises_named("x_t", lambda: P.online_step(recognizer, state, np.zeros(2)))
    raises_named("x_t", lambda: P.OnlineStream(recognizer).push(np.array([np.nan, 0, 0])))
    raises_named("stream", lambda: P.run_online(recognizer, np.zeros((0, D))))
    raises_named("stream", lambda: P.run_online(recognizer, np.full((5, D), np.inf)))
    raises_named("recognizer", lambda: P.run_online(phmms, np.zeros((5, D))))
    raises_named("threshold", lambda: P.online_recognizer(phmms, threshold=0.0))
    raises_named("window", lambda: P.OnlineOptions(window=0))
    raises_named("exit_threshold", lambda: P.OnlineOptions(exit_threshold=1.5))
    raises_named("max_frames", lambda: P.online_recognizer(phmms, threshold=0.1, options=P.OnlineOptions(max_frames=2)))
    raises_named("options", lambda: P.online_recognizer(phmms, threshold=0.1, options={"window": 3}))
    raises_named("phmms", lambda: P.online_recognizer([], threshold=0.1))
    raises_named("phmms[1]", lambda: P.online_recognizer([phmms[0], "x"], threshold=0.1))
