"""Batched inference on user sequences: check the input, pad it, run the jitted kernel of
`batched`, return batch-first jax arrays.

X is a (B, T, D) array padded with `lengths` (B,), one (T, D) sequence, or a list of (T_b, D)
arrays. Every function raises `ValueError` naming the argument for NaN/inf within the lengths, a
wrong D, an empty batch, lengths outside [1, T], or a sequence shorter (or longer) than any path the
model allows. Shapes: B sequences, T frames (padded), D features, N states, P pseudo-states per state.

mesh: a `jax.sharding.Mesh` (or None: one device). The sequences are split over its devices
(`lfd_common.map_batch`: padded to a multiple of the mesh size outside jit, the padding cut off the
result), each device runs the same kernel on its rows, and the result equals the one-device result.
With several processes, each passes its own sequences and gets its own rows back.
"""
from __future__ import annotations

from jax.sharding import Mesh
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


def log_likelihood(hmm: HMM, X: Sequences, lengths: Lengths = None, *, mesh: Mesh | None = None) -> Float[Array, " B"]:
    """Log-likelihood log p(x | hmm) of every sequence (the forward algorithm, PHMM §III-A).

    The end constraint (the path exits the last state at the last frame) is included.

    Args:
        hmm: The model.
        X: (B, T, D) padded with `lengths`, one (T, D) sequence, or a list of (T_b, D) arrays.
        lengths: (B,) frames per sequence, in [1, T]; None: every sequence has T frames (or the
            lengths of the list).
        mesh: A `jax.sharding.Mesh` to split the sequences over (the result equals the one-device
            result), or None for one device.

    Returns:
        (B,) log-likelihoods.

    Raises:
        ValueError: Naming the argument: `hmm` not an HMM or with covariances that are not
            positive definite; NaN/inf within the lengths, a wrong D, an empty batch, lengths
            outside [1, T] or shorter (longer) than any path the model allows; data whose
            log-likelihood would overflow the compute dtype; `mesh` not a Mesh.
    """
    return _run(batch_log_likelihood, hmm, X, lengths, mesh)


def messages(hmm: HMM, X: Sequences, lengths: Lengths = None, *, mesh: Mesh | None = None) -> Messages:
    """Forward and backward log-messages over the pseudo-states (PHMM §III-A).

    Args:
        hmm: The model.
        X: (B, T, D) padded with `lengths`, one (T, D) sequence, or a list of (T_b, D) arrays.
        lengths: (B,) frames per sequence, in [1, T]; None: every sequence has T frames (or the
            lengths of the list).
        mesh: A `jax.sharding.Mesh` to split the sequences over (the result equals the one-device
            result), or None for one device.

    Returns:
        `Messages`: log_alpha and log_beta, each (B, T, N, P) (-inf on padded frames), and the
        log-likelihoods (B,).

    Raises:
        ValueError: Naming the argument: `hmm` not an HMM or with covariances that are not
            positive definite; NaN/inf within the lengths, a wrong D, an empty batch, lengths
            outside [1, T] or shorter (longer) than any path the model allows; data whose
            log-likelihood would overflow the compute dtype; `mesh` not a Mesh.
    """
    return _run(batch_messages, hmm, X, lengths, mesh)


def posteriors(hmm: HMM, X: Sequences, lengths: Lengths = None, *, mesh: Mesh | None = None) -> Posteriors:
    """State and pseudo-state posteriors by forward-backward (PHMM §III-A).

    Args:
        hmm: The model.
        X: (B, T, D) padded with `lengths`, one (T, D) sequence, or a list of (T_b, D) arrays.
        lengths: (B,) frames per sequence, in [1, T]; None: every sequence has T frames (or the
            lengths of the list).
        mesh: A `jax.sharding.Mesh` to split the sequences over (the result equals the one-device
            result), or None for one device.

    Returns:
        `Posteriors`: state (B, T, N), pseudo-state (B, T, N, P) (zero on padded frames) and the
        log-likelihoods (B,).

    Raises:
        ValueError: Naming the argument: `hmm` not an HMM or with covariances that are not
            positive definite; NaN/inf within the lengths, a wrong D, an empty batch, lengths
            outside [1, T] or shorter (longer) than any path the model allows; data whose
            log-likelihood would overflow the compute dtype; `mesh` not a Mesh.
    """
    return _run(batch_posteriors, hmm, X, lengths, mesh)


def viterbi(hmm: HMM, X: Sequences, lengths: Lengths = None, *, mesh: Mesh | None = None
            ) -> tuple[Int[Array, "B T"], Float[Array, " B"]]:
    """Most probable state path of every sequence (the Viterbi algorithm).

    Args:
        hmm: The model.
        X: (B, T, D) padded with `lengths`, one (T, D) sequence, or a list of (T_b, D) arrays.
        lengths: (B,) frames per sequence, in [1, T]; None: every sequence has T frames (or the
            lengths of the list).
        mesh: A `jax.sharding.Mesh` to split the sequences over (the result equals the one-device
            result), or None for one device.

    Returns:
        (states, log-probabilities): states (B, T) int, -1 on padding; the log-probability (B,) of
        each path.

    Raises:
        ValueError: Naming the argument: `hmm` not an HMM or with covariances that are not
            positive definite; NaN/inf within the lengths, a wrong D, an empty batch, lengths
            outside [1, T] or shorter (longer) than any path the model allows; data whose
            log-likelihood would overflow the compute dtype; `mesh` not a Mesh.
    """
    states, _, score = _run(batch_viterbi, hmm, X, lengths, mesh)
    return states, score
