"""The jitted batch kernels behind the public API and the fitting code, on checked device arrays.

They take padded batch-first input (X (B, T, D), lengths (B,)), run the column-layout routines of
`inference` (batch axis last, see there), and return batch-first results. `api` wraps them
with input checks; `em`, `gradfit` and `parametric` call them (or `emission_columns`) directly.
Shapes: B sequences, T frames (padded), D features, N states, P pseudo-states per state.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from lfd_common import pad_sequences
from phmm_jax._src import inference as inference
from phmm_jax._src.checks import check_distances, check_type, max_whitened_distances, model_bounds
from phmm_jax._src.data import check_feasible, to_device
from phmm_jax._src.emissions import gaussian_log_density_columns
from phmm_jax._src.model import HMM, reachable_states


class Posteriors(NamedTuple):
    """Posteriors of a batch, batch-first (PHMM §III-A); padded frames have zero probability.

    Attributes:
        state: (B, T, N) P(state i at t | x).
        pseudo: (B, T, N, P) P(pseudo-state (i, j) at t | x), i.e. how long the path has been in
            state i (PHMM Fig. 3).
        loglik: (B,) log p(x).
    """

    state: Float[Array, "B T N"]
    pseudo: Float[Array, "B T N P"]
    loglik: Float[Array, " B"]


class Messages(NamedTuple):
    """Forward and backward log-messages of a batch, batch-first; -inf on padded frames (t >= L).

    Attributes:
        log_alpha: (B, T, N, P) log p(x_{0:t}, z_t).
        log_beta: (B, T, N, P) log p(x_{t+1:L}, end | z_t).
        loglik: (B,) log p(x).
    """

    log_alpha: Float[Array, "B T N P"]
    log_beta: Float[Array, "B T N P"]
    loglik: Float[Array, " B"]


def emission_columns(hmm: HMM, X: Float[Array, "B T D"], all_states: bool = False) -> Float[Array, "T N B"]:
    """(T, N, B) emission log-densities in the column layout of `inference`; -inf for the
    states no path can be in at that frame (`model.reachable_states`), unless `all_states`."""
    reachable = None if all_states else reachable_states(hmm.config, X.shape[1])
    return gaussian_log_density_columns(X, hmm.means, hmm.covariances, reachable)


def checked_batch(hmm: HMM, X, lengths):
    """User sequences (see `api.log_likelihood`) -> checked, padded device arrays (X, lengths).

    Also rejects a model that is not an `HMM` or whose covariances are not positive definite, and
    data whose log-likelihood under it would overflow the compute dtype (`checks.check_distances`).
    """
    check_type(hmm, "hmm", HMM)
    X, lengths = pad_sequences(X, lengths, dim=hmm.dim)
    check_feasible(hmm.config, lengths)
    check_distances(X, lengths, *model_bounds(hmm),
                    exact=lambda: max_whitened_distances(X, hmm.means, hmm.covariances))
    return to_device(X, lengths)


def _batch_first(a):
    """(T, ..., B) -> (B, T, ...)."""
    return jnp.moveaxis(a, -1, 0)


@jax.jit
def batch_log_likelihood(hmm: HMM, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Float[Array, " B"]:
    """Log-likelihoods of a checked, padded batch: the jitted kernel of `log_likelihood`.

    No input checks (use `log_likelihood` for user data); differentiable in the model's arrays.

    Args:
        hmm: The model.
        X: (B, T, D) padded sequences in the compute dtype.
        lengths: (B,) int32 frames per sequence, each a length some path of the model allows.

    Returns:
        (B,) log p(x_b | hmm), the end constraint (exit from the last state) included.
    """
    return inference.forward_loglik(inference.chain(hmm), emission_columns(hmm, X), lengths)


@jax.jit
def batch_messages(hmm: HMM, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Messages:
    # All states: log_beta is also defined for states the path cannot have reached.
    log_b = emission_columns(hmm, X, all_states=True)
    log_alpha, log_beta, loglik = inference.forward_backward(inference.chain(hmm), log_b, lengths)
    return Messages(_batch_first(log_alpha), _batch_first(log_beta), loglik)


@jax.jit
def batch_posteriors(hmm: HMM, X: Float[Array, "B T D"], lengths: Int[Array, " B"]) -> Posteriors:
    """State and pseudo-state posteriors of a checked, padded batch: the jitted kernel of `posteriors`.

    No input checks (use `posteriors` for user data).

    Args:
        hmm: The model.
        X: (B, T, D) padded sequences in the compute dtype.
        lengths: (B,) int32 frames per sequence, each a length some path of the model allows.

    Returns:
        `Posteriors`: state (B, T, N), pseudo (B, T, N, P), loglik (B,).
    """
    state, pseudo, loglik = inference.posteriors(inference.chain(hmm), emission_columns(hmm, X), lengths)
    return Posteriors(_batch_first(state), jnp.swapaxes(pseudo, 0, 1), loglik)


@jax.jit
def batch_viterbi(hmm: HMM, X: Float[Array, "B T D"], lengths: Int[Array, " B"]):
    """(states (B, T), pseudo-states (B, T), log-probabilities (B,)); -1 on padding."""
    states, pseudo, score = inference.viterbi(inference.chain(hmm), emission_columns(hmm, X), lengths)
    return states.T, pseudo.T, score
