"""Batched inference on padded sequences: the public functions check their input, then call the
jitted batch routines of `phmm_jax.inference` (which work batch-last) and return batch-first arrays.

Shapes: B sequences, T frames (padded), D features, N states, P pseudo-states per state.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from phmm_jax import inference
from phmm_jax.data import check_feasible, pad_sequences, to_device
from phmm_jax.emissions import gaussian_log_density_columns
from phmm_jax.model import HMM, reachable_states


def emission_columns(hmm: HMM, X, all_states: bool = False):
    """(T, N, B) emission log-densities in the column layout of `phmm_jax.inference`; -inf for the
    states no path can be in at that frame (`model.reachable_states`), unless `all_states`."""
    reachable = None if all_states else reachable_states(hmm.config, X.shape[1])
    return gaussian_log_density_columns(X, hmm.means, hmm.covariances, reachable)


@jax.jit
def batch_log_likelihood(hmm: HMM, X, lengths):
    """Jitted core of `log_likelihood` on checked, padded device arrays."""
    return inference.forward_loglik(inference.chain(hmm), emission_columns(hmm, X), lengths)


def _batch_first(a):
    """(T, ..., B) -> (B, T, ...)."""
    return jnp.moveaxis(a, -1, 0)


@jax.jit
def batch_messages(hmm: HMM, X, lengths) -> inference.Messages:
    # All states: log_beta is also defined for states the path cannot have reached.
    log_b = emission_columns(hmm, X, all_states=True)
    log_alpha, log_beta, loglik = inference.forward_backward(inference.chain(hmm), log_b, lengths)
    return inference.Messages(_batch_first(log_alpha), _batch_first(log_beta), loglik)


class Posteriors(NamedTuple):
    """state: (B, T, N) P(state i at t | x). pseudo: (B, T, N, P) the same per pseudo-state (how
    long the path has been in the state). loglik: (B,). Padded frames have zero probability."""

    state: jnp.ndarray
    pseudo: jnp.ndarray
    loglik: jnp.ndarray


@jax.jit
def batch_posteriors(hmm: HMM, X, lengths) -> Posteriors:
    state, pseudo, loglik = inference.posteriors(inference.chain(hmm), emission_columns(hmm, X), lengths)
    return Posteriors(_batch_first(state), jnp.swapaxes(pseudo, 0, 1), loglik)


@jax.jit
def batch_viterbi(hmm: HMM, X, lengths):
    states, pseudo, score = inference.viterbi(inference.chain(hmm), emission_columns(hmm, X), lengths)
    return states.T, pseudo.T, score


def _checked(hmm: HMM, X, lengths):
    X, lengths = pad_sequences(X, lengths, dim=hmm.dim)
    check_feasible(hmm.config, lengths)
    return to_device(X, lengths)


def log_likelihood(hmm: HMM, X, lengths=None):
    """log p(x | hmm) per sequence (B,), the end constraint included.

    X: (B, T, D) padded with `lengths` (B,), a (T, D) sequence, or a list of (T_b, D) arrays.
    Raises `ValueError` for NaN/inf within the lengths, a wrong D, an empty batch, lengths outside
    [1, T], or a sequence shorter (or longer) than any path the model allows.
    """
    return batch_log_likelihood(hmm, *_checked(hmm, X, lengths))


def messages(hmm: HMM, X, lengths=None) -> inference.Messages:
    """Forward and backward log-messages, each (B, T, N, P), and log-likelihoods (B,)."""
    return batch_messages(hmm, *_checked(hmm, X, lengths))


def posteriors(hmm: HMM, X, lengths=None) -> Posteriors:
    """State and pseudo-state posteriors and log-likelihoods (see `Posteriors`)."""
    return batch_posteriors(hmm, *_checked(hmm, X, lengths))


def viterbi(hmm: HMM, X, lengths=None):
    """Most probable path: (states (B, T) int, log-probabilities (B,)); states are -1 on padding."""
    states, _, score = batch_viterbi(hmm, *_checked(hmm, X, lengths))
    return states, score
