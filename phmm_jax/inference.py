"""Structured inference for left-right (explicit-duration) HMMs: forward, backward, posteriors,
expected counts and Viterbi, all in log space.

The functions here work on one sequence and are `vmap`-ed over a padded batch by the public API
(`phmm_jax.api`). A sequence of `length` L is padded to T frames: messages for t >= L are frozen, so
padding changes neither values nor gradients. Shapes: T frames, N states, P pseudo-states per state,
D feature dimension. `log_b` (T, N) are emission log-densities per *state*.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from phmm_jax.model import HMM, NEG_INF, log_final


def logsumexp(a, axis):
    """log Σ exp(a) along `axis`, -inf for an all--inf slice, with finite gradients everywhere.

    `jax.nn.logsumexp` has NaN gradients on all--inf slices (unreachable pseudo-states are common
    early in a left-right model); the double `where` keeps them out (dynamax issue #99).
    """
    peak = jax.lax.stop_gradient(jnp.max(a, axis=axis, keepdims=True))
    peak = jnp.where(jnp.isfinite(peak), peak, 0.0)
    total = jnp.sum(jnp.exp(a - peak), axis=axis)
    positive = total > 0
    safe_total = jnp.where(positive, total, 1.0)
    return jnp.where(positive, jnp.log(safe_total) + jnp.squeeze(peak, axis), NEG_INF)


def logaddexp(a, b):
    """Elementwise log(exp(a) + exp(b)), -inf for two -inf, with finite gradients (as `logsumexp`).

    Written elementwise rather than as a reduction over a stacked axis: XLA fuses it into one loop,
    which makes the backward step about 3.5x faster on CPU.
    """
    peak = jax.lax.stop_gradient(jnp.maximum(a, b))
    peak = jnp.where(jnp.isfinite(peak), peak, 0.0)
    total = jnp.exp(a - peak) + jnp.exp(b - peak)
    positive = total > 0
    return jnp.where(positive, jnp.log(jnp.where(positive, total, 1.0)) + peak, NEG_INF)


def initial_message(hmm: HMM, log_b0):
    """log P(x_0, pseudo-state) (N, P): the path starts in (0, 0)."""
    start = jnp.full(hmm.log_cont.shape, NEG_INF, log_b0.dtype).at[0, 0].set(0.0)
    return start + log_b0[:, None]


def predict(hmm: HMM, log_alpha):
    """One step of the structured transition: log Σ_prev alpha(prev) a(prev -> ·) (N, P)."""
    via_cont = log_alpha + hmm.log_cont
    shifted = jnp.concatenate([jnp.full_like(via_cont[:, :1], NEG_INF), via_cont[:, :-1]], axis=1)
    # The last pseudo-state's "continue" is a self-loop (always -inf with explicit durations).
    shifted = shifted.at[:, -1].set(logaddexp(shifted[:, -1], via_cont[:, -1]))
    leaving = logsumexp(log_alpha + hmm.log_exit, axis=1)  # (N,)
    entering = jnp.concatenate([jnp.full_like(leaving[:1], NEG_INF), leaving[:-1]])
    return shifted.at[:, 0].set(logaddexp(shifted[:, 0], entering))


def retro(hmm: HMM, log_beta_next, log_b_next):
    """One backward step: log Σ_next a(· -> next) b_next(x) beta(next) (N, P)."""
    ahead = log_beta_next + log_b_next[:, None]
    cont_target = jnp.concatenate([ahead[:, 1:], ahead[:, -1:]], axis=1)
    enter_next = jnp.concatenate([ahead[1:, 0], jnp.full_like(ahead[:1, 0], NEG_INF)])
    return logaddexp(hmm.log_cont + cont_target, hmm.log_exit + enter_next[:, None])


def forward_loglik(hmm: HMM, log_b, length):
    """log p(x_{0:L}, path ends by exiting the last state): a scalar. Differentiable."""

    def step(log_alpha, inputs):
        t, log_b_t = inputs
        updated = predict(hmm, log_alpha) + log_b_t[:, None]
        return jnp.where(t < length, updated, log_alpha), None

    times = jnp.arange(1, log_b.shape[0])
    log_alpha, _ = jax.lax.scan(step, initial_message(hmm, log_b[0]), (times, log_b[1:]))
    return logsumexp((log_alpha + log_final(hmm)).ravel(), axis=0)


class Messages(NamedTuple):
    """Forward/backward messages of one sequence.

    log_alpha: (T, N, P) log p(x_{0:t}, z_t). log_beta: (T, N, P) log p(x_{t+1:L}, end | z_t).
    loglik: scalar. Padded frames (t >= L) hold -inf in both.
    """

    log_alpha: jnp.ndarray
    log_beta: jnp.ndarray
    loglik: jnp.ndarray


def forward_backward(hmm: HMM, log_b, length) -> Messages:
    n_frames = log_b.shape[0]
    valid = jnp.arange(n_frames) < length

    def forward_step(log_alpha, inputs):
        t, log_b_t = inputs
        updated = predict(hmm, log_alpha) + log_b_t[:, None]
        carry = jnp.where(t < length, updated, log_alpha)
        return carry, carry

    first = initial_message(hmm, log_b[0])
    _, rest = jax.lax.scan(forward_step, first, (jnp.arange(1, n_frames), log_b[1:]))
    log_alpha = jnp.concatenate([first[None], rest])

    end = log_final(hmm)

    def backward_step(log_beta_next, inputs):
        t, log_b_next = inputs
        updated = retro(hmm, log_beta_next, log_b_next)
        carry = jnp.where(t >= length - 1, end, updated)
        return carry, carry

    _, log_beta = jax.lax.scan(
        backward_step, end, (jnp.arange(n_frames - 1), log_b[1:]), reverse=True)
    log_beta = jnp.concatenate([log_beta, end[None]])
    loglik = logsumexp((log_alpha[-1] + end).ravel(), axis=0)
    mask = valid[:, None, None]
    return Messages(jnp.where(mask, log_alpha, NEG_INF), jnp.where(mask, log_beta, NEG_INF), loglik)


def pseudo_posteriors(messages: Messages):
    """P(z_t = (i, j) | x) (T, N, P); zero on padded frames."""
    return jnp.exp(messages.log_alpha + messages.log_beta - messages.loglik)


def expected_transitions(hmm: HMM, log_b, length, messages: Messages):
    """Expected numbers of continue and exit transitions from each pseudo-state: two (N, P) arrays.

    Exits of the last state count the end of the sequence, so each explicit-duration state is
    exited exactly once per sequence and exit counts are duration counts.
    """
    log_alpha, log_beta, loglik = messages
    ahead = log_beta[1:] + log_b[1:, :, None]  # (T-1, N, P); -inf on padded frames
    cont_target = jnp.concatenate([ahead[:, :, 1:], ahead[:, :, -1:]], axis=2)
    enter_next = jnp.concatenate([ahead[:, 1:, :1], jnp.full_like(ahead[:, :1, :1], NEG_INF)], axis=1)
    log_cont_t = log_alpha[:-1] + hmm.log_cont + cont_target
    log_exit_t = log_alpha[:-1] + hmm.log_exit + enter_next
    cont = jnp.exp(logsumexp(log_cont_t, axis=0) - loglik)
    exits = jnp.exp(logsumexp(log_exit_t, axis=0) - loglik)
    # At the final frame L-1 the path ends by exiting the last state (log_beta there is log_final).
    end_exits = jnp.exp(log_alpha[length - 1, -1] + hmm.log_exit[-1] - loglik)
    return cont, exits.at[-1].add(end_exits)


def viterbi(hmm: HMM, log_b, length):
    """Most probable pseudo-state path: (states (T,), pseudo (T,), log-probability); -1 on padding."""
    n_states, n_pseudo = hmm.log_cont.shape
    n_frames = log_b.shape[0]
    flat = jnp.arange(n_states * n_pseudo).reshape(n_states, n_pseudo)

    def step(delta, inputs):
        t, log_b_t = inputs
        via_cont = delta + hmm.log_cont
        from_prev = jnp.concatenate([jnp.full_like(via_cont[:, :1], NEG_INF), via_cont[:, :-1]], axis=1)
        prev_src = jnp.concatenate([flat[:, :1], flat[:, :-1]], axis=1)
        self_loop = jnp.full_like(via_cont, NEG_INF).at[:, -1].set(via_cont[:, -1])
        via_exit = delta + hmm.log_exit
        best_j = jnp.argmax(via_exit, axis=1)
        leave = jnp.max(via_exit, axis=1)
        enter = jnp.full_like(via_cont, NEG_INF).at[1:, 0].set(leave[:-1])
        enter_src = jnp.zeros_like(flat).at[1:, 0].set(flat[jnp.arange(n_states - 1), best_j[:-1]])
        candidates = jnp.stack([from_prev, self_loop, enter])
        sources = jnp.stack([prev_src, flat, enter_src])
        choice = jnp.argmax(candidates, axis=0)
        best = jnp.max(candidates, axis=0) + log_b_t[:, None]
        pointer = jnp.take_along_axis(sources, choice[None], axis=0)[0]
        running = t < length
        return jnp.where(running, best, delta), jnp.where(running, pointer, flat)

    first = initial_message(hmm, log_b[0])
    delta, pointers = jax.lax.scan(step, first, (jnp.arange(1, n_frames), log_b[1:]))
    scores = (delta + log_final(hmm)).ravel()
    last = jnp.argmax(scores)

    def back(current, pointer):
        previous = pointer.ravel()[current]
        return previous, current

    first, path = jax.lax.scan(back, last, pointers, reverse=True)
    path = jnp.concatenate([first[None], path])
    valid = jnp.arange(n_frames) < length
    return (jnp.where(valid, path // n_pseudo, -1), jnp.where(valid, path % n_pseudo, -1), scores[last])
