"""Streaming forward pass of one explicit-duration HMM: frames arrive one at a time (e.g. the 3-D hand
position relative to the face from a tracker) and the forward state is updated per frame (BMVC 2008
§5.4 "Online Recognition and Synthesis", Humanoids 2008 §V). The online recogniser of
`online` runs these steps for every class and φ candidate.

Shapes: D features, N states, P pseudo-states per state, S streams, T frames.

The pseudo-state chains are those of `inference` (its `initial_message` and `predict`, and
the end weight of its `end_message`: exit from the last state); emissions use the affine whitening of
`emissions`, factored once per model rather than per frame.
    StreamState(log_alpha (N, P), n_frames (), log_prefix (), loglik ())
    init_stream(hmm, n_streams=None)        the state before any frame ((S, ...) with n_streams)
    stream_step(hmm, state, x_t (D,))       one frame: O(N·P); pure, jit-able
    stream_step_batch(hmm, states, X_t (S, D))   S streams (vmap of the same step)
    stream_forward(hmm, X (T, D), state=None)    a recorded sequence by lax.scan: the state after every frame
After t frames, log_alpha and loglik equal (to round-off) `messages(hmm, X[:t]).log_alpha[:, -1]` and
`log_likelihood(hmm, X[:t])`: loglik is the *finished* log-likelihood ("the sequence ends here",
exit from the last state, included); log_prefix = log p(x_{0:t}) over the paths still running.
Unnormalised, like the batch pass, so that both agree to round-off; a live stream restarts per
movement (`online`), so the messages stay in range.

Input is checked at the boundary (`ValueError` naming the argument: wrong feature dimension, NaN/inf
frames, empty sequences, a state of another model); inside the caller's jit (tracers) only shapes are.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from lfd_common import NEG_INF, as_array, check_int, float_dtype, safe_logsumexp
from phmm_jax._src.checks import check_distances, check_type, model_bounds
from phmm_jax._src.emissions import affine_whitening, with_ones
from phmm_jax._src.inference import Chain, chain, initial_message, predict
from phmm_jax._src.model import HMM

__all__ = ["StreamState", "init_stream", "stream_forward", "stream_step", "stream_step_batch"]

# Column layout of `inference` inside: the batch axis B (candidates, or 1) last.

class _Emitter(NamedTuple):
    """Gaussian emissions of B models factored once: affine whitening [W | -Wμ] (B, N, D, D+1) and
    normalising constants D log 2π + log|Σ| (B, N) (`emissions.affine_whitening`)."""

    affine: jnp.ndarray
    const: jnp.ndarray


def emitter(means, covariances) -> _Emitter:
    """From means (B, N, D) and covariances (B, N, D, D)."""
    return _Emitter(*affine_whitening(means, covariances))


def _frame_log_density(em: _Emitter, x):
    """log N(x | μ_bi, Σ_bi) (N, B) of one frame x (D,): one product with [x; 1]."""
    z = em.affine @ with_ones(x, 0)  # (B, N, D)
    return (-0.5 * (em.const + jnp.sum(z * z, axis=-1))).T


def advance(c: Chain, em: _Emitter, log_alpha, n_frames, x):
    """Forward message after frame x (N, P, B) from the message after n_frames frames (ignored when
    n_frames = 0): the same `initial_message` / `predict` as the batch forward pass."""
    log_b = _frame_log_density(em, x)
    first = initial_message(c, log_b)
    later = predict(c, log_alpha) + log_b[:, None]
    return jnp.where(n_frames == 0, first, later)


def summaries(c: Chain, log_alpha):
    """(log p(x_{0:t}, running) (B,), log p(x_{0:t}, ends at t) (B,)): all pseudo-states, and exits of
    the last state (`inference.end_message`, whose other rows are -inf)."""
    prefix = safe_logsumexp(log_alpha.reshape(-1, log_alpha.shape[-1]), axis=0)
    return prefix, safe_logsumexp(log_alpha[-1] + c.log_exit[-1], axis=0)


class StreamState(NamedTuple):
    """The forward state of one stream after t = n_frames frames (leading S axis for S streams).

    BMVC §5.4. After t frames, log_alpha and loglik equal (to round-off) the batch forward pass of
    the first t frames (`messages`, `log_likelihood`).

    Attributes:
        log_alpha: (N, P) log p(x_{0:t-1}, z_{t-1} = (i, j)); -inf before the first frame.
        n_frames: () int32, t.
        log_prefix: () log p(x_{0:t-1}) over the paths still running (0 before the first frame).
        loglik: () log p(x_{0:t-1}, the sequence ends here): the batch `log_likelihood` of the t
            frames (-inf while no path can have reached the end).
    """

    log_alpha: Float[Array, "N P"]
    n_frames: Int[Array, ""]
    log_prefix: Float[Array, ""]
    loglik: Float[Array, ""]


def _hmm_parts(hmm: HMM):
    return chain(hmm), emitter(hmm.means[None], hmm.covariances[None])


def _prepared_step(c: Chain, em: _Emitter, state: StreamState, x) -> StreamState:
    log_alpha = advance(c, em, state.log_alpha[..., None], state.n_frames, x)
    prefix, loglik = summaries(c, log_alpha)
    return StreamState(log_alpha[..., 0], state.n_frames + 1, prefix[0], loglik[0])


def _empty_state(config, dtype) -> StreamState:
    return StreamState(jnp.full((config.n_states, config.n_pseudo), NEG_INF, dtype), jnp.zeros((), jnp.int32),
                       jnp.zeros((), dtype), jnp.full((), NEG_INF, dtype))


@jax.jit
def _stream_step(hmm: HMM, state: StreamState, x) -> StreamState:
    return _prepared_step(*_hmm_parts(hmm), state, x)


@jax.jit
def _stream_step_batch(hmm: HMM, states: StreamState, X) -> StreamState:
    c, em = _hmm_parts(hmm)
    return jax.vmap(_prepared_step, in_axes=(None, None, 0, 0))(c, em, states, X)


@jax.jit
def _stream_scan(hmm: HMM, state: StreamState, X) -> StreamState:
    c, em = _hmm_parts(hmm)  # factored once, outside the loop

    def body(s, x):
        s = _prepared_step(c, em, s, x)
        return s, s

    return jax.lax.scan(body, state, X)[1]


def is_traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)


def _check_hmm(hmm) -> HMM:
    check_type(hmm, "hmm", HMM)
    if np.ndim(hmm.log_cont) != 2:
        raise ValueError(f"hmm: expected one HMM (log_cont (N, P)), got log_cont of shape {np.shape(hmm.log_cont)}")
    return hmm


def check_frames(x, shape: tuple, name: str, hmm: HMM | None = None, bounds=None, sequence: bool = False):
    """x as an array of the compute dtype, checked: `shape` (None entries: any size), finite, not empty,
    and (with `bounds` = (max |μ|, smallest covariance eigenvalue)) not so far from the model's means
    that a log-density overflows. Tracers (inside the caller's jit) get the shape check only."""
    if is_traced(x):
        if x.ndim != len(shape) or any(s is not None and s != g for s, g in zip(shape, x.shape)):
            raise ValueError(f"{name}: expected shape {shape}, got {x.shape}")
        return x
    arr = as_array(x, name, shape=shape)
    if bounds is not None:  # a (T, D) sequence sums its frames' log-densities; rows of (S, D) do not
        rows = arr[None] if sequence else arr.reshape(-1, 1, arr.shape[-1])
        check_distances(rows, np.full(len(rows), rows.shape[1], np.int32), *bounds, name=name,
                        model_name="hmm" if hmm is not None else "recognizer")
    return jnp.asarray(arr, float_dtype())


def check_state(state, name: str, template: NamedTuple, cls: type, batch: int | None):
    """`ValueError` naming `name` unless `state` is a `cls` whose arrays have the template's shapes
    (with a leading axis of `batch`, when given)."""
    check_type(state, name, cls, f"a phmm_jax.{cls.__name__} (from its init function)")
    lead = () if batch is None else (batch,)
    for got, want in zip(jax.tree_util.tree_leaves(state), jax.tree_util.tree_leaves(template)):
        if tuple(np.shape(got)) != lead + tuple(np.shape(want)):
            raise ValueError(f"{name}: arrays of shape {np.shape(got)} where {lead + tuple(np.shape(want))} "
                             f"was expected (a state of another model, or of {'one' if batch else 'several'} streams?)")
    return state


def init_stream(hmm: HMM, n_streams: int | None = None) -> StreamState:
    """The forward state of a stream before its first frame (BMVC §5.4).

    Args:
        hmm: One model (log_cont (N, P)).
        n_streams: None for one stream, or S >= 1 for S streams.

    Returns:
        `StreamState`, with a leading axis S when `n_streams` is given.

    Raises:
        ValueError: Naming `hmm` (not one HMM) or `n_streams` (not an integer >= 1).
    """
    hmm = _check_hmm(hmm)
    state = _empty_state(hmm.config, float_dtype())
    if n_streams is None:
        return state
    n_streams = check_int(n_streams, "n_streams", min_value=1)
    return jax.tree_util.tree_map(lambda a: jnp.broadcast_to(a, (n_streams,) + a.shape), state)


def stream_step(hmm: HMM, state: StreamState, x_t: Float[ArrayLike, " D"]) -> StreamState:
    """Advance one stream's forward state by one frame (BMVC §5.4, Humanoids §V).

    O(N·P) per frame (the banded pseudo-state chain); pure and jit-able (inside the caller's jit
    only shapes are checked).

    Args:
        hmm: One model (log_cont (N, P)).
        state: The `StreamState` after the previous frames (from `init_stream` or a previous step).
        x_t: (D,) the new frame.

    Returns:
        The `StreamState` after x_t.

    Raises:
        ValueError: Naming `hmm` (not one HMM), `state` (of another model or of several streams)
            or `x_t` (wrong shape, NaN/inf, so far from the means that a log-density overflows).
    """
    hmm = _check_hmm(hmm)
    check_state(state, "state", _empty_state(hmm.config, float_dtype()), StreamState, None)
    x_t = check_frames(x_t, (hmm.dim,), "x_t", hmm, None if is_traced(x_t) else model_bounds(hmm))
    return _stream_step(hmm, state, x_t)


def stream_step_batch(hmm: HMM, states: StreamState, X_t: Float[ArrayLike, "S D"]) -> StreamState:
    """Advance S streams under one HMM by one frame each (a vmap of `stream_step`).

    Args:
        hmm: One model (log_cont (N, P)).
        states: The S streams' `StreamState`, each field with a leading axis S.
        X_t: (S, D) one new frame per stream.

    Returns:
        The S streams' `StreamState` after X_t.

    Raises:
        ValueError: Naming `hmm`, `states` or `X_t`, as `stream_step` does.
    """
    hmm = _check_hmm(hmm)
    X_t = check_frames(X_t, (None, hmm.dim), "X_t", hmm, None if is_traced(X_t) else model_bounds(hmm))
    check_state(states, "states", _empty_state(hmm.config, float_dtype()), StreamState, X_t.shape[0])
    return _stream_step_batch(hmm, states, X_t)


def stream_forward(hmm: HMM, X: Float[ArrayLike, "T D"], state: StreamState | None = None) -> StreamState:
    """Feed a recorded sequence one frame at a time (lax.scan) and keep the state after every frame.

    Equals the batch forward pass at every prefix (loglik: the sequence ends there, the
    `log_likelihood` of the prefix).

    Args:
        hmm: One model (log_cont (N, P)).
        X: (T, D) the frames.
        state: The `StreamState` to continue from; None: the start.

    Returns:
        `StreamState` after every frame, each field with a leading axis T (the last row is the
        final state, from which a later call may continue).

    Raises:
        ValueError: Naming `hmm`, `X` (empty, wrong D, NaN/inf, too far from the means) or `state`.
    """
    hmm = _check_hmm(hmm)
    X = check_frames(X, (None, hmm.dim), "X", hmm, model_bounds(hmm), sequence=True)
    if state is None:
        state = _empty_state(hmm.config, float_dtype())
    check_state(state, "state", _empty_state(hmm.config, float_dtype()), StreamState, None)
    return _stream_scan(hmm, state, X)
