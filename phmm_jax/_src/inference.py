"""Structured inference for left-right (explicit-duration) HMMs: forward, backward, posteriors,
expected counts and Viterbi, all in log space, for a whole batch at once.

Layout: the batch axis is *last* ("columns"). Emission log-densities per state are `log_b` (T, N, B),
messages (T, N, P, B), and a `Chain` holds the transition log-probabilities (N, P, B), or (N, P, 1)
when the whole batch shares one HMM. With B on the minor axis every operation of a time step is one
contiguous vector operation over the batch, where `vmap` over single sequences (batch-major) would
reduce over the few (P = 4-6) pseudo-states of a state, which vectorises poorly. The public API
(`api`) returns batch-first arrays; the column-layout results here have their own types
(`ColumnPosteriors`, `ColumnMessages`). Log-space sums use `lfd_common`'s NaN-safe `safe_logsumexp`
/ `safe_logaddexp`: -inf (unreachable pseudo-states, forbidden transitions) keeps finite gradients.

Banded forward: at frame t only the states of `model.state_band` (from the start and to an end by
frame T - 1) can carry posterior mass, so `forward_loglik`, and through its gradient the posteriors
and expected counts, work on those W states only (W = 6 of N = 20 for durations 4-6 over T = 100).
`forward_backward` and `viterbi` run over all N states.

A sequence of `length` L is padded to T frames: messages for t >= L are frozen, so padding changes
neither values nor gradients. Shapes: T frames, N states, P pseudo-states per state, B sequences.
"""
from __future__ import annotations

import dataclasses
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from lfd_common import NEG_INF, safe_logaddexp, safe_logsumexp
from phmm_jax._src.model import HMM, HMMConfig, state_band


@partial(jax.tree_util.register_dataclass, data_fields=["log_cont", "log_exit"], meta_fields=["config"])
@dataclasses.dataclass(frozen=True)
class Chain:
    """The pseudo-state chains of a batch of HMMs in column layout.

    log_cont, log_exit: (N, P, B) continue / exit log-probabilities (see `model`); B = 1
    broadcasts one HMM over the batch. config: the structure they share (`HMMConfig`).
    """

    log_cont: jnp.ndarray
    log_exit: jnp.ndarray
    config: HMMConfig

    @property
    def self_loop(self) -> bool:
        """The last pseudo-state continues to itself (classical HMM); with explicit durations it must exit."""
        return not self.config.explicit_duration

    @property
    def first_exit(self) -> int:
        """Pseudo-states j < first_exit cannot exit (their log_exit is -inf, `model.allowed_transitions`),
        so the exit sums skip them: for durations 4-6 that halves the exponentials of a forward step."""
        return self.config.min_duration - 1


def chain(hmm: HMM) -> Chain:
    """The chain of one HMM, shared by every sequence of the batch."""
    return Chain(hmm.log_cont[..., None], hmm.log_exit[..., None], hmm.config)


def stacked_chain(hmms: HMM) -> Chain:
    """The chains of B HMMs whose arrays carry a leading batch axis (e.g. one per parameter φ_b)."""
    return Chain(jnp.moveaxis(hmms.log_cont, 0, -1), jnp.moveaxis(hmms.log_exit, 0, -1), hmms.config)


def _neg_inf_like(a, axis):
    """A -inf slice of `a` of size 1 along `axis` (to shift a chain by one pseudo-state or state)."""
    return jnp.full_like(jax.lax.slice_in_dim(a, 0, 1, axis=axis), NEG_INF)


def initial_message(c: Chain, log_b0):
    """log P(x_0, pseudo-state) (N, P, B) from log_b0 (N, B): every path starts in (0, 0)."""
    n_states, n_pseudo = c.log_cont.shape[:2]
    start = jnp.full((n_states, n_pseudo, 1), NEG_INF, log_b0.dtype).at[0, 0].set(0.0)
    return start + log_b0[:, None]


def _transition(c: Chain, log_cont, log_exit, log_alpha):
    """One step of the structured transition from R states' messages log_alpha (R, P, B): log Σ_prev
    alpha(prev) a(prev -> ·) for those R states and the one above them, (R + 1, P, B)."""
    via_cont = log_alpha + log_cont
    leaving = safe_logsumexp(log_alpha[:, c.first_exit:] + log_exit[:, c.first_exit:], axis=1)  # (R, B)
    entering = jnp.concatenate([_neg_inf_like(leaving, 0), leaving], axis=0)
    # Shift, then overwrite column 0: XLA:CPU compiles this into a faster step than concatenating
    # `entering` as column 0.
    shifted = jnp.concatenate([_neg_inf_like(via_cont, 1), via_cont[:, :-1]], axis=1)
    moved = jnp.concatenate([shifted, _neg_inf_like(shifted, 0)], axis=0).at[:, 0].set(entering)
    if c.self_loop:
        moved = moved.at[:-1, -1].set(safe_logaddexp(moved[:-1, -1], via_cont[:, -1]))
    return moved


def predict(c: Chain, log_alpha):
    """One step of the structured transition: log Σ_prev alpha(prev) a(prev -> ·) (N, P, B)."""
    return _transition(c, c.log_cont, c.log_exit, log_alpha)[:-1]


def retro(c: Chain, log_beta_next, log_b_next):
    """One backward step: log Σ_next a(· -> next) b_next(x) beta(next) (N, P, B)."""
    ahead = log_beta_next + log_b_next[:, None]
    cont_target = jnp.concatenate([ahead[:, 1:], ahead[:, -1:]], axis=1)  # last: the self-loop
    enter_next = jnp.concatenate([ahead[1:, :1], _neg_inf_like(ahead[:, :1], 0)], axis=0)
    staying = c.log_cont + cont_target
    fe = c.first_exit
    return staying.at[:, fe:].set(safe_logaddexp(staying[:, fe:], c.log_exit[:, fe:] + enter_next))


def end_message(c: Chain):
    """(N, P, B|1) log-weight of ending on each pseudo-state: exiting the last state."""
    last = jnp.arange(c.log_exit.shape[0])[:, None, None] == c.log_exit.shape[0] - 1
    return jnp.where(last, c.log_exit, NEG_INF)


def _frames(log_b):
    return jnp.arange(1, log_b.shape[0]), log_b[1:]


def forward_loglik(c: Chain, log_b, lengths, offsets=None):
    """log p(x_{0:L}, path ends by exiting the last state) (B,) from log_b (T, N, B). Differentiable.

    Banded: the messages hold only the W states of `model.state_band` at each frame (W = 6 of 20 for
    durations 4-6 over 100 frames), the only ones with non-zero forward *and* backward probability.
    Mass that leaves the band below can no longer end the path in time and is dropped; none can
    leave it above. So the log-likelihood and its gradients are exact, at W/N of the dense cost.
    A sequence that has ended (t >= L) keeps its message, moved along with the band.

    offsets: None, or (T, B, N, P) added to the forward messages (zeros: its gradient is the
    pseudo-state posteriors, see `posteriors`). Batch-major per frame, so that the gradient comes
    out in the layout the public API returns: each step transposes a cache-sized slice, cheaper than
    transposing the whole (T, N, P, B) result afterwards.
    """
    n_frames, n_states = log_b.shape[:2]
    start, width = state_band(c.config, n_frames)
    moves = np.diff(start).astype(bool)

    def band(a, first, axis=0):
        return jax.lax.dynamic_slice_in_dim(a, first, width, axis)

    def message(log_b_t, offset_t, first):
        """Emission (and offset) of frame t on the band's rows, (W, P|1, B)."""
        out = band(log_b_t, first)[:, None]
        return out if offset_t is None else out + jnp.transpose(band(offset_t, first, 1), (1, 2, 0))

    def step(log_alpha, inputs):
        t, first_prev, move, log_b_t, offset_t = inputs
        moved = _transition(c, band(c.log_cont, first_prev), band(c.log_exit, first_prev), log_alpha)
        kept = jnp.concatenate([log_alpha, _neg_inf_like(log_alpha, 0)], axis=0)
        if moves.any():  # the band moves up one state on this frame, or stays
            moved, kept = jnp.where(move, moved[1:], moved[:-1]), jnp.where(move, kept[1:], kept[:-1])
        else:
            moved, kept = moved[:-1], log_alpha
        updated = moved + message(log_b_t, offset_t, first_prev + move)
        return jnp.where(t < lengths, updated, kept), None

    first = initial_message(c, log_b[0])[:width]
    if offsets is not None:
        first = first + jnp.transpose(offsets[0, :, :width], (1, 2, 0))
    rest = None if offsets is None else offsets[1:]
    inputs = (jnp.arange(1, n_frames), jnp.asarray(start[:-1]), jnp.asarray(moves.astype(np.int32)), log_b[1:], rest)
    log_alpha, _ = jax.lax.scan(step, first, inputs)
    last_row = n_states - 1 - int(start[-1])
    if last_row >= width:  # T < N * min_duration: no path reaches the last state in time
        return jnp.full(log_alpha.shape[-1:], NEG_INF, log_alpha.dtype)
    return safe_logsumexp(log_alpha[last_row] + c.log_exit[-1], axis=0)


# Posteriors and expected counts are gradients of the log-likelihood (e.g. Eisner 2016, "Inside-outside
# and forward-backward algorithms are just backprop"): d log p / d log b_t(i) = P(state i at t | x) and
# d log p / d log a = the expected number of uses of transition a. Reverse-mode differentiation of the
# forward scan computes them in probability space from the forward pass's saved exponentials, at a
# fraction of the cost of the explicit log-space backward recursion (`forward_backward`, kept for the
# messages themselves).


class Statistics(NamedTuple):
    """E-step statistics of a batch with sequence weights w (B,).

    loglik: (B,) unweighted. state: (T, N, B) w_b-weighted state posteriors (zero on padding).
    cont, exits: (N, P, 1) (shared chain: summed over the batch with weights w) or (N, P, B)
    (stacked chains) expected continue / exit counts; exits of the last state count the end.
    """

    loglik: jnp.ndarray
    state: jnp.ndarray
    cont: jnp.ndarray
    exits: jnp.ndarray


def expected_statistics(c: Chain, log_b, lengths, weights) -> Statistics:
    """`Statistics` by reverse-mode differentiation of Σ_b w_b log p(x_b) (see above)."""

    def weighted_total(log_b, log_cont, log_exit):
        loglik = forward_loglik(dataclasses.replace(c, log_cont=log_cont, log_exit=log_exit), log_b, lengths)
        return jnp.sum(weights * loglik), loglik

    grads, loglik = jax.grad(weighted_total, argnums=(0, 1, 2), has_aux=True)(log_b, c.log_cont, c.log_exit)
    return Statistics(loglik, *grads)


class ColumnPosteriors(NamedTuple):
    """Posteriors in column layout (the public, batch-first type is `phmm_jax.Posteriors`).

    state: (T, N, B) P(state i at t | x). pseudo: (T, B, N, P) P(pseudo-state (i, j) at t | x).
    loglik: (B,). Zero on padded frames."""

    state: jnp.ndarray
    pseudo: jnp.ndarray
    loglik: jnp.ndarray


def posteriors(c: Chain, log_b, lengths) -> ColumnPosteriors:
    """State and pseudo-state posteriors by differentiating the forward pass: with respect to log_b
    (states) and to zero offsets on its messages (pseudo-states)."""

    def total(log_b, offsets):
        loglik = forward_loglik(c, log_b, lengths, offsets)
        return jnp.sum(loglik), loglik

    n_frames, n_states, batch = log_b.shape
    offsets = jnp.zeros((n_frames, batch, n_states, c.log_cont.shape[1]), log_b.dtype)
    (state, pseudo), loglik = jax.grad(total, argnums=(0, 1), has_aux=True)(log_b, offsets)
    return ColumnPosteriors(state, pseudo, loglik)


class ColumnMessages(NamedTuple):
    """Forward/backward messages of a batch in column layout (public, batch-first: `phmm_jax.Messages`).

    log_alpha: (T, N, P, B) log p(x_{0:t}, z_t). log_beta: (T, N, P, B) log p(x_{t+1:L}, end | z_t).
    loglik: (B,). Padded frames (t >= L) hold -inf in both.
    """

    log_alpha: jnp.ndarray
    log_beta: jnp.ndarray
    loglik: jnp.ndarray


def forward_backward(c: Chain, log_b, lengths) -> ColumnMessages:
    """The explicit forward and backward recursions in log space over the pseudo-state chains, for the
    messages themselves (posteriors and counts come cheaper as gradients: `posteriors`,
    `expected_statistics`)."""
    def forward_step(log_alpha, inputs):
        t, log_b_t = inputs
        updated = predict(c, log_alpha) + log_b_t[:, None]
        carry = jnp.where(t < lengths, updated, log_alpha)
        return carry, carry

    first = initial_message(c, log_b[0])
    _, rest = jax.lax.scan(forward_step, first, _frames(log_b))
    log_alpha = jnp.concatenate([first[None], rest])

    end = jnp.broadcast_to(end_message(c), first.shape)

    def backward_step(log_beta_next, inputs):
        t, log_b_next = inputs
        updated = retro(c, log_beta_next, log_b_next)
        carry = jnp.where(t >= lengths - 1, end, updated)
        return carry, carry

    times = jnp.arange(log_b.shape[0] - 1)
    _, log_beta = jax.lax.scan(backward_step, end, (times, log_b[1:]), reverse=True)
    log_beta = jnp.concatenate([log_beta, end[None]])
    loglik = safe_logsumexp((log_alpha[-1] + end).reshape(-1, end.shape[-1]), axis=0)
    valid = (jnp.arange(log_b.shape[0])[:, None] < lengths)[:, None, None]  # (T, 1, 1, B)
    return ColumnMessages(jnp.where(valid, log_alpha, NEG_INF), jnp.where(valid, log_beta, NEG_INF), loglik)


def pseudo_posteriors(messages: ColumnMessages):
    """P(z_t = (i, j) | x) (T, N, P, B); zero on padded frames."""
    return jnp.exp(messages.log_alpha + messages.log_beta - messages.loglik)


def viterbi(c: Chain, log_b, lengths):
    """Most probable pseudo-state paths: (states (T, B), pseudo (T, B), log-probability (B,));
    -1 on padding."""
    n_states, n_pseudo = c.log_cont.shape[:2]
    n_frames, batch = log_b.shape[0], log_b.shape[-1]
    flat = jnp.arange(n_states * n_pseudo).reshape(n_states, n_pseudo, 1)
    prev_src = jnp.concatenate([flat[:, :1], flat[:, :-1]], axis=1)

    def step(delta, inputs):
        t, log_b_t = inputs
        via_cont = delta + c.log_cont
        from_prev = jnp.concatenate([_neg_inf_like(via_cont, 1), via_cont[:, :-1]], axis=1)
        self_loop = jnp.full_like(via_cont, NEG_INF).at[:, -1].set(via_cont[:, -1])
        via_exit = delta + c.log_exit
        best_j = jnp.argmax(via_exit, axis=1)  # (N, B)
        leave = jnp.max(via_exit, axis=1)
        enter = jnp.full_like(via_cont, NEG_INF).at[1:, 0].set(leave[:-1])
        enter_src = jnp.zeros(via_cont.shape, flat.dtype).at[1:, 0].set(
            jnp.arange(n_states - 1)[:, None] * n_pseudo + best_j[:-1])
        candidates = jnp.stack([from_prev, self_loop, enter])
        sources = jnp.stack(jnp.broadcast_arrays(prev_src, flat, enter_src))
        choice = jnp.argmax(candidates, axis=0)
        best = jnp.max(candidates, axis=0) + log_b_t[:, None]
        pointer = jnp.take_along_axis(sources, choice[None], axis=0)[0]
        running = t < lengths
        return jnp.where(running, best, delta), jnp.where(running, pointer, flat)

    delta, pointers = jax.lax.scan(step, initial_message(c, log_b[0]), _frames(log_b))
    scores = (delta + end_message(c)).reshape(-1, batch)
    last = jnp.argmax(scores, axis=0)  # (B,)
    columns = jnp.arange(batch)

    def back(current, pointer):
        previous = pointer.reshape(-1, batch)[current, columns]
        return previous, current

    first, path = jax.lax.scan(back, last, pointers, reverse=True)
    path = jnp.concatenate([first[None], path])
    valid = jnp.arange(n_frames)[:, None] < lengths
    best = scores[last, columns]
    return jnp.where(valid, path // n_pseudo, -1), jnp.where(valid, path % n_pseudo, -1), best
