"""Baum–Welch EM for left-right (explicit-duration) Gaussian HMMs, batched over unequal lengths.

One EM iteration is one jitted call (`em_step`) over the whole padded batch; the Python loop in
`fit_hmm` only iterates EM and checks convergence. Shapes: B sequences, T frames, D features,
N states, P pseudo-states.
"""
from __future__ import annotations

import warnings
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from phmm_jax import inference
from phmm_jax.api import emission_columns
from phmm_jax.data import check_feasible, pad_sequences, to_device
from phmm_jax.model import HMM, HMMConfig, transitions_from_counts

# A state whose total responsibility is below this keeps its previous Gaussian (and is reported).
_MIN_RESPONSIBILITY = 1e-6


def gaussian_m_step(config: HMMConfig, gamma, X, previous: HMM | None, update_means: bool = True):
    """Weighted Gaussian estimates from responsibilities gamma (T, N, B) and frames X (B, T, D).

    Returns (means (N, D), covariances (N, D, D), number of starved states). A starved state (total
    responsibility below 1e-6) keeps `previous`'s Gaussian (identity covariance when None) instead of
    producing NaN. `update_means=False` keeps `previous.means` (synchronised local training).
    """
    dim = X.shape[-1]
    weight = jnp.sum(gamma, axis=(0, 2))  # (N,)
    starved = weight < _MIN_RESPONSIBILITY
    safe_weight = jnp.where(starved, 1.0, weight)
    new_means = jnp.einsum("tnb,btd->nd", gamma, X) / safe_weight[:, None]
    fallback_means = new_means if previous is None else previous.means
    means = jnp.where(starved[:, None], fallback_means, new_means)
    if not update_means:
        means = previous.means
    centred = X[:, :, None, :] - means  # (B, T, N, D)
    eye = jnp.eye(dim, dtype=X.dtype)
    if config.covariance_type == "full":
        scatter = jnp.einsum("tnb,btnd,btne->nde", gamma, centred, centred)
    else:
        scatter = jnp.einsum("tnb,btnd->nd", gamma, centred * centred)[:, :, None] * eye
    covariances = scatter / safe_weight[:, None, None] + config.reg_covar * eye
    fallback_cov = jnp.broadcast_to(eye, covariances.shape) if previous is None else previous.covariances
    covariances = jnp.where(starved[:, None, None], fallback_cov, covariances)
    return means, covariances, jnp.sum(starved)


def sufficient_statistics(hmm: HMM, X, lengths, weights):
    """E step: weighted state posteriors (T, N, B), continue and exit counts (N, P), log-liks (B,)."""
    stats = inference.expected_statistics(inference.chain(hmm), emission_columns(hmm, X), lengths, weights)
    return stats.state, stats.cont[..., 0], stats.exits[..., 0], stats.loglik


@partial(jax.jit, static_argnames=("update_means",))
def em_step(hmm: HMM, X, lengths, weights, update_means: bool = True):
    """One EM iteration. Returns (new HMM, weighted mean log-likelihood per frame of `hmm`, starved).

    weights: (B,) per-sequence weights (0 for padding sequences, 1 otherwise).
    """
    gamma, cont, exits, loglik = sufficient_statistics(hmm, X, lengths, weights)
    means, covariances, starved = gaussian_m_step(hmm.config, gamma, X, hmm, update_means)
    log_cont, log_exit = transitions_from_counts(hmm.config, cont, exits, hmm)
    n_frames = jnp.sum(weights * lengths)
    new = hmm.replace(means=means, covariances=covariances, log_cont=log_cont, log_exit=log_exit)
    return new, jnp.sum(weights * loglik) / n_frames, starved


def equal_segmentation(lengths, n_frames: int, n_states: int, dtype=jnp.float32):
    """One-hot responsibilities (T, N, B): frame t of a sequence of length L belongs to state ⌊tN/L⌋."""
    t = jnp.arange(n_frames)[:, None]
    state = jnp.floor(t * n_states / lengths).astype(jnp.int32)  # (T, B)
    one_hot = jax.nn.one_hot(state, n_states, axis=1, dtype=dtype)
    return one_hot * (t < lengths)[:, None]


@partial(jax.jit, static_argnames=("config",))
def initial_hmm(config: HMMConfig, X, lengths, weights) -> HMM:
    """A left-to-right start: Gaussians from an equal segmentation in time; uniform duration
    hazards (explicit durations) or self-loops matching the mean segment length (classical)."""
    gamma = equal_segmentation(lengths, X.shape[1], config.n_states, X.dtype) * weights
    means, covariances, _ = gaussian_m_step(config, gamma, X, None)
    if config.explicit_duration:
        log_cont, log_exit = transitions_from_counts(
            config, jnp.zeros((config.n_states, config.n_pseudo), X.dtype),
            jnp.zeros((config.n_states, config.n_pseudo), X.dtype))
    else:
        mean_length = jnp.sum(weights * lengths) / jnp.sum(weights)
        extra = jnp.maximum(mean_length / config.n_states - config.min_duration, 1e-3)  # mean self-loops
        stay = extra / (1.0 + extra)
        p = config.n_pseudo
        chain = jnp.arange(p) < p - 1
        log_cont = jnp.broadcast_to(jnp.where(chain, 0.0, jnp.log(stay)), (config.n_states, p)).astype(X.dtype)
        log_exit = jnp.broadcast_to(jnp.where(chain, -jnp.inf, jnp.log1p(-stay)), (config.n_states, p)).astype(X.dtype)
    return HMM(means, covariances, log_cont, log_exit, config)


def run_em(hmm: HMM, X, lengths, weights, n_iter: int, tol: float, freeze_means_after: int | None = None,
           step=em_step):
    """Iterate `step` until the mean per-frame log-likelihood improves by less than `tol`.

    Returns (HMM, history of mean per-frame log-likelihoods). Warns if a state was starved.
    `step` may be a vmapped `em_step` (several models at once): convergence then needs all of them.
    """
    history = []
    starved_total = 0
    for iteration in range(n_iter):
        update_means = freeze_means_after is None or iteration < freeze_means_after
        hmm, mean_ll, starved = step(hmm, X, lengths, weights, update_means=update_means)
        mean_ll = np.asarray(mean_ll)
        starved_total += int(np.sum(starved))
        history.append(mean_ll)
        if len(history) > 1 and np.all(np.abs(history[-1] - history[-2]) < tol):
            break
    if starved_total:
        warnings.warn(f"EM: {starved_total} state update(s) had no responsibility; their previous "
                      "Gaussians were kept (too few frames, or more states than the data supports)",
                      RuntimeWarning, stacklevel=3)
    return hmm, np.stack(history) if history else np.zeros((0,))


def fit_hmm(X, lengths=None, config: HMMConfig = HMMConfig(), init: HMM | None = None,
            freeze_means_after: int | None = None, return_history: bool = False):
    """Fit an HMM by Baum–Welch EM.

    X: (B, T, D) padded with `lengths` (B,), a (T, D) sequence or a list of (T_b, D) arrays.
    config: the structure (states, durations, covariance type) and EM settings.
    init: start from this HMM (its config is used) instead of an equal segmentation in time.
    freeze_means_after: keep the means fixed after this many iterations (1 = the synchronised local
        training of PHMM §III-B1, eq. 2).
    Returns the fitted `HMM` (and the per-iteration mean log-likelihood per frame if asked).
    """
    if init is not None:
        config = init.config
    X, lengths = pad_sequences(X, lengths, dim=None if init is None else init.dim)
    check_feasible(config, lengths)
    X, lengths = to_device(X, lengths)
    weights = jnp.ones(X.shape[0], X.dtype)
    hmm = initial_hmm(config, X, lengths, weights) if init is None else init
    hmm, history = run_em(hmm, X, lengths, weights, config.n_iter, config.tol, freeze_means_after)
    return (hmm, history) if return_history else hmm
