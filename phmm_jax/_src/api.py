"""Batched inference on user sequences: check the input, pad it, run the jitted kernel of
`phmm_jax._batched`, return batch-first jax arrays.

X is a (B, T, D) array padded with `lengths` (B,), one (T, D) sequence, or a list of (T_b, D)
arrays. Every function raises `ValueError` naming the argument for NaN/inf within the lengths, a
wrong D, an empty batch, lengths outside [1, T], or a sequence shorter (or longer) than any path the
model allows. Shapes: B sequences, T frames (padded), D features, N states, P pseudo-states per state.

mesh: a `jax.sharding.Mesh` (or None: one device). The sequences are split over its devices
(`lfd_common.sharding`: padded to a multiple of the mesh size outside jit, the padding cut off the
result), each device runs the same kernel on its rows, and the result equals the one-device result.
With several processes, each passes its own sequences and gets its own rows back.
"""
from __future__ import annotations

from jaxtyping import Array, Float, Int

from phmm_jax._src.batched import (Messages, Posteriors, batch_log_likelihood, batch_messages,
    batch_posteriors, batch_viterbi, checked_batch)
from lfd_common import check_mesh, map_batch
from phmm_jax._src.data import Lengths, Sequences
from phmm_jax._src.model import HMM

__all__ = ["Messages", "Posteriors", "batch_log_likelihood", "batch_messages", "batch_posteriors",
           "batch_viterbi", "log_likelihood", "messages", "posteriors", "viterbi"]


def _run(kernel, hmm: HMM, X, lengths, mesh):
    """`kernel(hmm, X, lengths)` on the checked batch, on one device or split over `mesh`."""
    mesh = check_mesh(mesh)
    X, lengths = checked_batch(hmm, X, lengths)
    return kernel(hmm, X, lengths) if mesh is None else map_batch(kernel, mesh, (hmm,), (X, lengths))


def log_likelihood(hmm: HMM, X: Sequences, lengths: Lengths = None, *, mesh=None) -> Float[Array, " B"]:
    """log p(x | hmm) per sequence (B,), the end constraint (exit from the last state) included."""
    return _run(batch_log_likelihood, hmm, X, lengths, mesh)


def messages(hmm: HMM, X: Sequences, lengths: Lengths = None, *, mesh=None) -> Messages:
    """Forward and backward log-messages, each (B, T, N, P), and log-likelihoods (B,) (see `Messages`)."""
    return _run(batch_messages, hmm, X, lengths, mesh)


def posteriors(hmm: HMM, X: Sequences, lengths: Lengths = None, *, mesh=None) -> Posteriors:
    """State (B, T, N) and pseudo-state (B, T, N, P) posteriors and log-likelihoods (B,) (see `Posteriors`)."""
    return _run(batch_posteriors, hmm, X, lengths, mesh)


def viterbi(hmm: HMM, X: Sequences, lengths: Lengths = None, *, mesh=None
            ) -> tuple[Int[Array, "B T"], Float[Array, " B"]]:
    """Most probable path: (states (B, T) int, log-probabilities (B,)); states are -1 on padding."""
    states, _, score = _run(batch_viterbi, hmm, X, lengths, mesh)
    return states, score
