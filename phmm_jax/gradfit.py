"""Fitting the same HMM by gradient descent on the negative log-likelihood with optax.

Unconstrained parameters: means, Cholesky factors with log-diagonals (log-variances for "diag"),
and duration logits (explicit durations: a softmax over d in [min, max]; classical: a self-loop
logit). Forbidden transitions are built from masks, so they stay exactly -inf.
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from phmm_jax import inference
from phmm_jax.api import emission_columns
from phmm_jax.data import check_feasible, pad_sequences, to_device
from phmm_jax.em import initial_hmm
from phmm_jax.model import HMM, HMMConfig, allowed_transitions, duration_log_probs, transitions_from_durations


class Unconstrained(NamedTuple):
    means: jnp.ndarray  # (N, D)
    cov_factor: jnp.ndarray  # (N, D, D) lower triangle with log-diagonal, or (N, D) log-variances
    duration_logits: jnp.ndarray  # (N, P) explicit, (N,) self-loop logit classical


def to_unconstrained(hmm: HMM) -> Unconstrained:
    config = hmm.config
    reg = config.reg_covar * jnp.eye(hmm.dim, dtype=hmm.means.dtype)
    if config.covariance_type == "full":
        chol = jnp.linalg.cholesky(hmm.covariances - reg * 0.999)
        diag = jnp.diagonal(chol, axis1=-2, axis2=-1)
        factor = jnp.tril(chol, -1) + jax.vmap(jnp.diag)(jnp.log(diag))
    else:
        factor = jnp.log(jnp.diagonal(hmm.covariances, axis1=-2, axis2=-1) - config.reg_covar * 0.999)
    if config.explicit_duration:
        _, may_exit = allowed_transitions(config)
        logits = jnp.where(may_exit, duration_log_probs(hmm), 0.0)
    else:
        logits = hmm.log_cont[:, -1] - hmm.log_exit[:, -1]
    return Unconstrained(hmm.means, factor, logits)


def from_unconstrained(config: HMMConfig, params: Unconstrained) -> HMM:
    dim = params.means.shape[-1]
    eye = jnp.eye(dim, dtype=params.means.dtype)
    if config.covariance_type == "full":
        chol = jnp.tril(params.cov_factor, -1) + jax.vmap(jnp.diag)(jnp.exp(jnp.diagonal(params.cov_factor, axis1=-2, axis2=-1)))
        covariances = chol @ jnp.swapaxes(chol, -1, -2)
    else:
        covariances = jnp.exp(params.cov_factor)[:, :, None] * eye
    covariances = covariances + config.reg_covar * eye
    if config.explicit_duration:
        _, may_exit = allowed_transitions(config)
        log_p = jax.nn.log_softmax(jnp.where(may_exit, params.duration_logits, -jnp.inf), axis=1)
        log_cont, log_exit = transitions_from_durations(config, log_p)
    else:
        chain = jnp.arange(config.n_pseudo) < config.n_pseudo - 1
        stay = jax.nn.log_sigmoid(params.duration_logits)[:, None]
        leave = jax.nn.log_sigmoid(-params.duration_logits)[:, None]
        log_cont = jnp.where(chain, 0.0, stay)
        log_exit = jnp.where(chain, -jnp.inf, leave)
    return HMM(params.means, covariances, log_cont, log_exit, config)


def mean_negative_loglik(params: Unconstrained, config: HMMConfig, X, lengths):
    """Negative log-likelihood per frame of the padded batch (the objective)."""
    hmm = from_unconstrained(config, params)
    loglik = inference.forward_loglik(inference.chain(hmm), emission_columns(hmm, X), lengths)
    return -jnp.sum(loglik) / jnp.sum(lengths)


@partial(jax.jit, static_argnames=("config", "n_steps"))
def _lbfgs(params: Unconstrained, config: HMMConfig, X, lengths, n_steps: int):
    objective = partial(mean_negative_loglik, config=config, X=X, lengths=lengths)
    solver = optax.lbfgs()
    value_and_grad = optax.value_and_grad_from_state(objective)

    def step(carry, _):
        params, state = carry
        value, grad = value_and_grad(params, state=state)
        updates, state = solver.update(grad, state, params, value=value, grad=grad, value_fn=objective)
        return (optax.apply_updates(params, updates), state), value

    (params, _), values = jax.lax.scan(step, (params, solver.init(params)), None, length=n_steps)
    return params, values


def fit_hmm_gradient(X, lengths=None, config: HMMConfig = HMMConfig(), init: HMM | None = None,
                     n_steps: int = 200, return_history: bool = False):
    """Fit by L-BFGS (optax) on the mean negative log-likelihood per frame, from `init` or the
    equal-segmentation start that EM uses. Returns the HMM (and the objective per step)."""
    if init is not None:
        config = init.config
    X, lengths = pad_sequences(X, lengths, dim=None if init is None else init.dim)
    check_feasible(config, lengths)
    X, lengths = to_device(X, lengths)
    if init is None:
        init = initial_hmm(config, X, lengths, jnp.ones(X.shape[0], X.dtype))
    params, values = _lbfgs(to_unconstrained(init), config, X, lengths, n_steps)
    hmm = from_unconstrained(config, params)
    return (hmm, np.asarray(values)) if return_history else hmm
