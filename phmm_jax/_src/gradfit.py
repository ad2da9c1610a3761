"""Fitting the same HMM by gradient descent on the negative log-likelihood with optax.

Unconstrained parameters: means, Cholesky factors with log-diagonals (log-variances for "diag"),
and duration logits (explicit durations: a softmax over d in [min, max]; classical: a self-loop
logit). Forbidden transitions are built from masks, so they stay exactly -inf. The covariance floor
`reg_covar` is part of the parametrisation (Σ = L Lᵀ + reg_covar I) and a traced argument; the
optimiser (any `optax.GradientTransformation`, default L-BFGS) and the number of steps are static.
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax
from jaxtyping import Array, Float

from phmm_jax._src import inference as inference
from phmm_jax._src.batched import emission_columns
from phmm_jax._src.data import Lengths, Sequences
from phmm_jax._src.em import check_fit_result, prepare_fit
from phmm_jax._src.model import (HMM, HMMConfig, allowed_transitions, duration_log_probs,
    transitions_from_durations)
from phmm_jax._src.options import FitOptions

# `to_unconstrained` factors Σ - 0.999·reg_covar·I: an initial covariance must exceed this share of the floor.
_INIT_FLOOR = 0.9995


class Unconstrained(NamedTuple):
    means: jnp.ndarray  # (N, D)
    cov_factor: jnp.ndarray  # (N, D, D) lower triangle with log-diagonal, or (N, D) log-variances
    duration_logits: jnp.ndarray  # (N, P) explicit, (N,) self-loop logit classical


def to_unconstrained(hmm: HMM, reg_covar) -> Unconstrained:
    """The parameters of `hmm` whose `from_unconstrained` is `hmm` (up to 0.1% of the floor)."""
    config = hmm.config
    reg = reg_covar * jnp.eye(hmm.dim, dtype=hmm.means.dtype)
    if config.covariance_type == "full":
        chol = jnp.linalg.cholesky(hmm.covariances - reg * 0.999)
        diag = jnp.diagonal(chol, axis1=-2, axis2=-1)
        factor = jnp.tril(chol, -1) + jax.vmap(jnp.diag)(jnp.log(diag))
    else:
        factor = jnp.log(jnp.diagonal(hmm.covariances, axis1=-2, axis2=-1) - reg_covar * 0.999)
    if config.explicit_duration:
        _, may_exit = allowed_transitions(config)
        logits = jnp.where(may_exit, duration_log_probs(hmm), 0.0)
    else:
        logits = hmm.log_cont[:, -1] - hmm.log_exit[:, -1]
    return Unconstrained(hmm.means, factor, logits)


def from_unconstrained(config: HMMConfig, params: Unconstrained, reg_covar) -> HMM:
    dim = params.means.shape[-1]
    eye = jnp.eye(dim, dtype=params.means.dtype)
    if config.covariance_type == "full":
        chol = jnp.tril(params.cov_factor, -1) + jax.vmap(jnp.diag)(jnp.exp(jnp.diagonal(params.cov_factor, axis1=-2, axis2=-1)))
        covariances = chol @ jnp.swapaxes(chol, -1, -2)
    else:
        covariances = jnp.exp(params.cov_factor)[:, :, None] * eye
    covariances = covariances + reg_covar * eye
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


# One jitted program each for the conversions at the ends of a fit (op-by-op they are ~50 small
# compilations on a process's first fit).
_to_unconstrained = jax.jit(to_unconstrained)
_from_unconstrained = jax.jit(from_unconstrained, static_argnums=0)


def mean_negative_loglik(params: Unconstrained, config: HMMConfig, X, lengths, reg_covar):
    """Negative log-likelihood per frame of the padded batch (the objective)."""
    hmm = from_unconstrained(config, params, reg_covar)
    loglik = inference.forward_loglik(inference.chain(hmm), emission_columns(hmm, X), lengths)
    return -jnp.sum(loglik) / jnp.sum(lengths)


def _value_and_grad(objective, state):
    """`optax.value_and_grad_from_state` for optimisers whose state carries the objective's value
    and gradient (L-BFGS's line search computes them at the accepted point), else `jax.value_and_grad`."""
    if optax.tree.get(state, "value") is not None and optax.tree.get(state, "grad") is not None:
        return optax.value_and_grad_from_state(objective)
    return lambda params, state: jax.value_and_grad(objective)(params)


@partial(jax.jit, static_argnames=("config", "n_steps", "optimizer"))
def _minimise(params: Unconstrained, config: HMMConfig, X, lengths, reg_covar, n_steps: int,
              optimizer: optax.GradientTransformation):
    objective = partial(mean_negative_loglik, config=config, X=X, lengths=lengths, reg_covar=reg_covar)
    solver = optax.with_extra_args_support(optimizer)
    state = solver.init(params)
    value_and_grad = _value_and_grad(objective, state)

    def step(carry, _):
        params, state = carry
        value, grad = value_and_grad(params, state=state)
        updates, state = solver.update(grad, state, params, value=value, grad=grad, value_fn=objective)
        return (optax.apply_updates(params, updates), state), value

    (params, _), values = jax.lax.scan(step, (params, state), None, length=n_steps)
    return params, values


def fit_hmm_gradient(X: Sequences, lengths: Lengths = None, config: HMMConfig = HMMConfig(),
                     init: HMM | None = None, *, options: FitOptions = FitOptions(),
                     return_history: bool = False) -> HMM | tuple[HMM, Float[Array, " S"]]:
    """Fit an HMM by gradient descent (optax) on the mean negative log-likelihood per frame.

    The same model and objective as `fit_hmm` (PHMM §III-A), searched over unconstrained parameters
    (means, Cholesky factors with log-diagonals, duration logits) from `init` or the
    equal-segmentation start that EM uses; forbidden transitions stay exactly -inf.

    Args:
        X: (B, T, D) padded with `lengths`, a (T, D) sequence or a list of (T_b, D) arrays.
        lengths: (B,) frames per sequence, or None (all T, or the list's lengths).
        config: The structure (states, durations, covariance type); ignored when `init` is given.
        init: Start from this HMM (its config is used) instead of the equal segmentation.
        options: `FitOptions` (optimizer, default optax L-BFGS; gradient_steps; reg_covar, and
            duration_pseudocount for the start).
        return_history: Also return the objective at each of the S steps.

    Returns:
        The fitted `HMM`, or (HMM, (S,) objective values) with `return_history`.

    Raises:
        ValueError: As `fit_hmm` does, and naming `init` when its covariances do not exceed
            `reg_covar` (the parametrisation Σ = L Lᵀ + reg_covar·I cannot represent them).
    """
    X, lengths, _, start = prepare_fit(X, lengths, config, init, options)
    if init is not None:
        low = float(np.min(np.linalg.eigvalsh(np.asarray(init.covariances, np.float64))))
        if low <= _INIT_FLOOR * options.reg_covar:
            raise ValueError(f"init: covariance eigenvalues must exceed reg_covar={options.reg_covar:g} "
                             f"(Σ = L Lᵀ + reg_covar·I), got {low:.3g}")
    config = start.config
    params, values = _minimise(_to_unconstrained(start, options.reg_covar), config, X, lengths, options.reg_covar,
                               options.gradient_steps, options.optimizer)
    hmm = _from_unconstrained(config, params, options.reg_covar)
    check_fit_result(hmm, X, options)
    return (hmm, values) if return_history else hmm
