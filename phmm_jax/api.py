"""Batched inference on user sequences: check the input, pad it, run the jitted kernel of
`phmm_jax._batched`, return batch-first jax arrays.

X is a (B, T, D) array padded with `lengths` (B,), one (T, D) sequence, or a list of (T_b, D)
arrays. Every function raises `ValueError` naming the argument for NaN/inf within the lengths, a
wrong D, an empty batch, lengths outside [1, T], or a sequence shorter (or longer) than any path the
model allows. Shapes: B sequences, T frames (padded), D features, N states, P pseudo-states per state.
"""
from __future__ import annotations

from jaxtyping import Array, Float, Int

from phmm_jax._batched import (
    Messages,
    Posteriors,
    batch_log_likelihood,
    batch_messages,
    batch_posteriors,
    batch_viterbi,
    checked_batch,
)
from phmm_jax.data import Lengths, Sequences
from phmm_jax.model import HMM

__all__ = ["Messages", "Posteriors", "batch_log_likelihood", "batch_messages", "batch_posteriors",
           "batch_viterbi", "log_likelihood", "messages", "posteriors", "viterbi"]


def log_likelihood(hmm: HMM, X: Sequences, lengths: Lengths = None) -> Float[Array, " B"]:
    """log p(x | hmm) per sequence (B,), the end constraint (exit from the last state) included."""
    return batch_log_likelihood(hmm, *checked_batch(hmm, X, lengths))


def messages(hmm: HMM, X: Sequences, lengths: Lengths = None) -> Messages:
    """Forward and backward log-messages, each (B, T, N, P), and log-likelihoods (B,) (see `Messages`)."""
    return batch_messages(hmm, *checked_batch(hmm, X, lengths))


def posteriors(hmm: HMM, X: Sequences, lengths: Lengths = None) -> Posteriors:
    """State (B, T, N) and pseudo-state (B, T, N, P) posteriors and log-likelihoods (B,) (see `Posteriors`)."""
    return batch_posteriors(hmm, *checked_batch(hmm, X, lengths))


def viterbi(hmm: HMM, X: Sequences, lengths: Lengths = None) -> tuple[Int[Array, "B T"], Float[Array, " B"]]:
    """Most probable path: (states (B, T) int, log-probabilities (B,)); states are -1 on padding."""
    states, _, score = batch_viterbi(hmm, *checked_batch(hmm, X, lengths))
    return states, score
