"""Independent float64 numpy references for the phmm_jax tests (plain loops, no JAX)."""
from __future__ import annotations

import itertools

import numpy as np
from scipy.special import logsumexp
from scipy.stats import multivariate_normal


def emission_table(means, covariances, x):
    """(T, N) log-densities by scipy."""
    return np.stack([multivariate_normal(m, c).logpdf(x) for m, c in zip(means, covariances)], axis=1).reshape(len(x), -1)


def duration_log_prob(log_cont, log_exit, i, d):
    """log P(state i lasts exactly d steps) from its pseudo-state chain (self-loop at the end)."""
    n_pseudo = log_cont.shape[1]
    total = sum(log_cont[i, min(j, n_pseudo - 1)] for j in range(d - 1))
    return total + log_exit[i, min(d - 1, n_pseudo - 1)]


def segmentations(n_states, length, min_d, max_d):
    """All duration tuples (d_1..d_N) with min_d <= d_i <= max_d summing to length."""
    upper = length if max_d is None else max_d
    for durations in itertools.product(range(min_d, upper + 1), repeat=n_states):
        if sum(durations) == length:
            yield durations


def brute_force(hmm, x):
    """(log-likelihood, best path log-prob, best state path) by enumerating every allowed path."""
    cfg = hmm.config
    means, covs = np.asarray(hmm.means, np.float64), np.asarray(hmm.covariances, np.float64)
    log_cont, log_exit = np.asarray(hmm.log_cont, np.float64), np.asarray(hmm.log_exit, np.float64)
    log_b = emission_table(means, covs, x)
    scores, paths = [], []
    for durations in segmentations(cfg.n_states, len(x), cfg.min_duration, cfg.max_duration):
        states = np.repeat(np.arange(cfg.n_states), durations)
        score = sum(duration_log_prob(log_cont, log_exit, i, d) for i, d in enumerate(durations))
        scores.append(score + log_b[np.arange(len(x)), states].sum())
        paths.append(states)
    scores = np.array(scores)
    best = int(np.argmax(scores))
    return logsumexp(scores), scores[best], paths[best]


def dense_forward_backward(dense, x, with_counts: bool = False):
    """Forward-backward on a DenseHMM with end weights: (loglik, state posteriors (T, S)), and with
    `with_counts` also the expected transition counts (S, S) and end probabilities (S,)."""
    log_b = emission_table(dense.means, dense.covariances, x)
    n_frames, size = log_b.shape
    alpha = np.zeros((n_frames, size))
    beta = np.zeros((n_frames, size))
    alpha[0] = dense.log_initial + log_b[0]
    for t in range(1, n_frames):
        alpha[t] = logsumexp(alpha[t - 1][:, None] + dense.log_transition, axis=0) + log_b[t]
    beta[-1] = dense.log_final
    for t in range(n_frames - 2, -1, -1):
        beta[t] = logsumexp(dense.log_transition + (log_b[t + 1] + beta[t + 1])[None, :], axis=1)
    loglik = logsumexp(alpha[-1] + dense.log_final)
    if not with_counts:
        return loglik, np.exp(alpha + beta - loglik)
    pairs = alpha[:-1, :, None] + dense.log_transition + (log_b[1:] + beta[1:])[:, None, :]  # (T-1, S, S)
    counts = np.exp(logsumexp(pairs, axis=0) - loglik)
    return loglik, np.exp(alpha + beta - loglik), counts, np.exp(alpha[-1] + dense.log_final - loglik)
