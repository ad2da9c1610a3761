"""Baum–Welch EM for left-right (explicit-duration) Gaussian HMMs, batched over unequal lengths.

One EM iteration is one jitted call (`em_step`) over the whole padded batch; the Python loop in
`run_em` only iterates EM and checks convergence on the host, so the stopping rule's tolerance never
enters a trace. The real-valued fit options (`reg_covar`, `duration_pseudocount`) are traced
arguments of the jitted steps: changing them does not recompile. Shapes: B sequences, T frames,
D features, N states, P pseudo-states.
"""
from __future__ import annotations

import warnings
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from jax.sharding import Mesh
from jaxtyping import Array, Float, Int

from lfd_common import pad_sequences
from lfd_common import check_mesh, shard, sharded_call
from phmm_jax._src import inference as inference
from phmm_jax._src.batched import emission_columns
from phmm_jax._src.checks import check_fit_scale, check_fitted, check_hmm, check_type
from phmm_jax._src.data import Lengths, Sequences, check_feasible, to_device
from phmm_jax._src.model import HMM, HMMConfig, transitions_from_counts
from phmm_jax._src.options import FitOptions, check_options

# A state whose total responsibility is below this keeps its previous Gaussian (and is reported).
_MIN_RESPONSIBILITY = 1e-6


def gaussian_m_step(config: HMMConfig, gamma, X, previous: HMM | None, reg_covar, update_means: bool = True,
                    total=lambda a: a):
    """Weighted Gaussian estimates from responsibilities gamma (T, N, B) and frames X (B, T, D).

    Returns (means (N, D), covariances (N, D, D), number of starved states); `reg_covar` is added to
    every covariance diagonal. A starved state (total responsibility below 1e-6) keeps `previous`'s
    Gaussian (identity covariance when None) instead of producing NaN. `update_means=False` keeps
    `previous.means` (synchronised local training, PHMM eq. 2). `total` completes a sum over the
    batch (`jax.lax.psum` over the mesh when the batch is split over devices; identity otherwise).
    """
    dim = X.shape[-1]
    weight = total(jnp.sum(gamma, axis=(0, 2)))  # (N,)
    starved = weight < _MIN_RESPONSIBILITY
    safe_weight = jnp.where(starved, 1.0, weight)
    # full float32 products: a GPU's default (TF32 inputs) left covariances asymmetric and, for a
    # near-singular state, not positive definite (hmmlearn rejected one on an H200)
    highest = jax.lax.Precision.HIGHEST
    new_means = total(jnp.einsum("tnb,btd->nd", gamma, X, precision=highest)) / safe_weight[:, None]
    fallback_means = new_means if previous is None else previous.means
    means = jnp.where(starved[:, None], fallback_means, new_means)
    if not update_means:
        means = previous.means
    centred = X[:, :, None, :] - means  # (B, T, N, D)
    eye = jnp.eye(dim, dtype=X.dtype)
    if config.covariance_type == "full":
        scatter = total(jnp.einsum("tnb,btnd,btne->nde", gamma, centred, centred, precision=highest))
        scatter = 0.5 * (scatter + jnp.swapaxes(scatter, -1, -2))
    else:
        scatter = total(jnp.einsum("tnb,btnd->nd", gamma, centred * centred, precision=highest))[:, :, None] * eye
    covariances = scatter / safe_weight[:, None, None] + reg_covar * eye
    fallback_cov = jnp.broadcast_to(eye, covariances.shape) if previous is None else previous.covariances
    covariances = jnp.where(starved[:, None, None], fallback_cov, covariances)
    return means, covariances, jnp.sum(starved)


def sufficient_statistics(hmm: HMM, X, lengths, weights):
    """E step: weighted state posteriors (T, N, B), continue and exit counts (N, P), log-liks (B,)."""
    stats = inference.expected_statistics(inference.chain(hmm), emission_columns(hmm, X), lengths, weights)
    return stats.state, stats.cont[..., 0], stats.exits[..., 0], stats.loglik


@partial(jax.jit, static_argnames=("update_means", "axis_name"))
def em_step(hmm: HMM, X: Float[Array, "B T D"], lengths: Int[Array, " B"], weights: Float[Array, " B"],
            reg_covar: float | Array, duration_pseudocount: float | Array, update_means: bool = True,
            axis_name: str | tuple[str, ...] | None = None) -> tuple[HMM, Array, Array]:
    """One Baum–Welch EM iteration on a checked, padded batch (PHMM §III-A; eq. 2 for the means).

    The jitted step behind `fit_hmm`; no input checks. E step by forward-backward over the
    pseudo-state chains, M step in closed form (weighted Gaussians, normalised continue/exit counts,
    so forbidden transitions stay exactly -inf).

    Args:
        hmm: The current model.
        X: (B, T, D) padded sequences in the compute dtype.
        lengths: (B,) int32 frames per sequence.
        weights: (B,) per-sequence weights (0 for padding sequences, 1 otherwise).
        reg_covar: Added to every covariance diagonal (`FitOptions.reg_covar`), traced.
        duration_pseudocount: Dirichlet pseudo-count on allowed transitions
            (`FitOptions.duration_pseudocount`), traced.
        update_means: False keeps `hmm.means` (the synchronised local training, PHMM §III-B1).
        axis_name: None, or the mesh axes the batch is split over inside `jax.shard_map`: every
            sufficient statistic is then summed over them (`jax.lax.psum`), so each device gets the
            same new HMM as one device with the whole batch.

    Returns:
        (new HMM, weighted mean log-likelihood per frame of `hmm` (), number of starved states ()):
        a starved state (total responsibility below 1e-6) keeps its previous Gaussian.
    """
    total = (lambda a: a) if axis_name is None else partial(jax.lax.psum, axis_name=axis_name)
    gamma, cont, exits, loglik = sufficient_statistics(hmm, X, lengths, weights)
    means, covariances, starved = gaussian_m_step(hmm.config, gamma, X, hmm, reg_covar, update_means, total)
    log_cont, log_exit = transitions_from_counts(hmm.config, total(cont), total(exits), duration_pseudocount, hmm)
    n_frames = total(jnp.sum(weights * lengths))
    new = hmm.replace(means=means, covariances=covariances, log_cont=log_cont, log_exit=log_exit)
    return new, total(jnp.sum(weights * loglik)) / n_frames, starved


def _em_shard(hmm: HMM, reg_covar, duration_pseudocount, X, lengths, weights, update_means: bool, axis_name):
    """`em_step` with the replicated arguments first (the order of `lfd_common.sharded_call`)."""
    return em_step(hmm, X, lengths, weights, reg_covar, duration_pseudocount, update_means, axis_name)


def sharded_em_step(mesh):
    """`em_step` (same signature and results) for a batch split over `mesh` (`lfd_common.shard`):
    each device computes its sequences' sufficient statistics, `jax.lax.psum` sums them, and every
    device gets the new HMM (replicated). Padding sequences carry weight 0."""
    axes = tuple(mesh.axis_names)

    def step(hmm, X, lengths, weights, reg_covar, duration_pseudocount, update_means: bool = True):
        return sharded_call(_em_shard, mesh, (hmm, reg_covar, duration_pseudocount), (X, lengths, weights),
                            static=(("update_means", update_means), ("axis_name", axes)), out_batched=False)

    return step


def equal_segmentation(lengths, n_frames: int, n_states: int, dtype=jnp.float32):
    """One-hot responsibilities (T, N, B): frame t of a sequence of length L belongs to state ⌊tN/L⌋."""
    t = jnp.arange(n_frames)[:, None]
    state = jnp.floor(t * n_states / lengths).astype(jnp.int32)  # (T, B)
    one_hot = jax.nn.one_hot(state, n_states, axis=1, dtype=dtype)
    return one_hot * (t < lengths)[:, None]


@partial(jax.jit, static_argnames=("config",))
def initial_hmm(config: HMMConfig, X, lengths, weights, reg_covar, duration_pseudocount) -> HMM:
    """A left-to-right start: Gaussians from an equal segmentation in time; uniform duration
    hazards (explicit durations) or self-loops matching the mean segment length (classical)."""
    gamma = equal_segmentation(lengths, X.shape[1], config.n_states, X.dtype) * weights
    means, covariances, _ = gaussian_m_step(config, gamma, X, None, reg_covar)
    if config.explicit_duration:
        zeros = jnp.zeros((config.n_states, config.n_pseudo), X.dtype)
        log_cont, log_exit = transitions_from_counts(config, zeros, zeros, duration_pseudocount)
    else:
        mean_length = jnp.sum(weights * lengths) / jnp.sum(weights)
        extra = jnp.maximum(mean_length / config.n_states - config.min_duration, 1e-3)  # mean self-loops
        stay = extra / (1.0 + extra)
        p = config.n_pseudo
        chain = jnp.arange(p) < p - 1
        log_cont = jnp.broadcast_to(jnp.where(chain, 0.0, jnp.log(stay)), (config.n_states, p)).astype(X.dtype)
        log_exit = jnp.broadcast_to(jnp.where(chain, -jnp.inf, jnp.log1p(-stay)), (config.n_states, p)).astype(X.dtype)
    return HMM(means, covariances, log_cont, log_exit, config)


def run_em(hmm: HMM, X, lengths, weights, options: FitOptions, max_iter: int,
           freeze_means_after: int | None = None, step=em_step):
    """Iterate `step` at most `max_iter` times, until the mean per-frame log-likelihood improves by
    less than `options.tol`; the M step uses `options.reg_covar` and `options.duration_pseudocount`.

    Returns (HMM, history of mean per-frame log-likelihoods). Warns if a state was starved; stops
    early once the log-likelihood is not finite (the caller's `check_fit_result` then reports it).
    `step` may be a vmapped `em_step` (several models at once): convergence then needs all of them.
    """
    history = []
    starved_total = 0
    for iteration in range(max_iter):
        update_means = freeze_means_after is None or iteration < freeze_means_after
        hmm, mean_ll, starved = step(hmm, X, lengths, weights, options.reg_covar, options.duration_pseudocount,
                                     update_means=update_means)
        mean_ll = np.asarray(mean_ll)
        starved_total += int(np.sum(starved))
        history.append(mean_ll)
        if not np.all(np.isfinite(mean_ll)):
            break
        if len(history) > 1 and np.all(np.abs(history[-1] - history[-2]) < options.tol):
            break
    if starved_total:
        warnings.warn(f"EM: {starved_total} state update(s) had no responsibility; their previous "
                      "Gaussians were kept (too few frames, or more states than the data supports)",
                      RuntimeWarning, stacklevel=3)
    return hmm, np.stack(history) if history else np.zeros((0,))


def check_fit_result(hmm: HMM, X, options: FitOptions, name: str = "X") -> None:
    """`ValueError` instead of a NaN or singular fitted model (`checks.check_fitted`): naming
    `reg_covar` when reg_covar = 0 left a singular covariance, else `name` (the data)."""
    scale = None
    if options.reg_covar == 0:
        scale = np.asarray(jnp.max(jnp.abs(jnp.asarray(X)), axis=tuple(range(np.ndim(X) - 1))))
    check_fitted(hmm, options.reg_covar, scale, name)


def prepare_fit(X, lengths, config: HMMConfig, init: HMM | None, options: FitOptions, mesh=None):
    """The common start of every HMM fit: check `options`, `config` / `init` and the sequences, pad
    them to device arrays, and return (X, lengths, weights (B,) of ones, the starting HMM: `init`,
    or the equal segmentation in time of `config` when None).

    mesh: None, or a `jax.sharding.Mesh` to split the batch over (`lfd_common.shard`): X, lengths
    and weights then come back as global (B', ...) arrays padded to the mesh, weights 0 on padding.

    Raises `ValueError` naming the argument for a wrong type, an invalid `init` (`checks.check_hmm`),
    or data whose covariance estimates would overflow the compute dtype (`checks.check_fit_scale`).
    """
    check_options(options)
    mesh = check_mesh(mesh)
    if init is not None:
        check_type(init, "init", HMM, "a phmm_jax.HMM or None")
        if np.ndim(init.means) != 2:
            raise ValueError(f"init: expected one HMM (means (N, D)), got means of shape {np.shape(init.means)}")
        try:
            check_hmm(init)
        except ValueError as err:
            raise ValueError(f"init: {err}") from err
        config = init.config
    else:
        check_type(config, "config", HMMConfig)
    X, lengths = pad_sequences(X, lengths, dim=None if init is None else init.dim)
    check_feasible(config, lengths)
    check_fit_scale(X, lengths)
    X, lengths = to_device(X, lengths)
    weights = jnp.ones(X.shape[0], X.dtype)
    if mesh is not None:
        batch = shard(mesh, X, lengths)
        (X, lengths), weights = batch.arrays, batch.mask.astype(X.dtype)
    if init is None:
        init = initial_hmm(config, X, lengths, weights, options.reg_covar, options.duration_pseudocount)
    return X, lengths, weights, init


def fit_hmm(X: Sequences, lengths: Lengths = None, config: HMMConfig = HMMConfig(), init: HMM | None = None,
            *, options: FitOptions = FitOptions(), return_history: bool = False, mesh: Mesh | None = None
            ) -> HMM | tuple[HMM, Float[Array, " I"]]:
    """Fit an HMM by Baum–Welch EM on the pseudo-state chains (PHMM §III-A, §III-B1; BMVC §3).

    E step by forward-backward over the pseudo-states, M step in closed form (weighted Gaussians,
    normalised continue/exit counts, so forbidden transitions stay exactly -inf). EM stops after
    `options.max_iter` iterations or once the mean log-likelihood per frame improves by less than
    `options.tol`.

    Args:
        X: (B, T, D) padded with `lengths`, a (T, D) sequence or a list of (T_b, D) arrays.
        lengths: (B,) frames per sequence, or None (all T, or the list's lengths).
        config: The structure (states, durations, covariance type); ignored when `init` is given.
        init: Start from this HMM (its config is used) instead of an equal segmentation in time.
        options: `FitOptions` (max_iter, tol, reg_covar, duration_pseudocount, freeze_means_after).
        return_history: Also return the per-iteration mean log-likelihoods per frame.
        mesh: A `jax.sharding.Mesh` (or None: one device). The sequences are split over its
            devices, each device computes its part of the E step and the sufficient statistics are
            summed over the mesh; the fit equals the one-device fit to round-off. With several
            processes each passes its own sequences (they must share D) and every process gets the
            same HMM.

    Returns:
        The fitted `HMM`, or (HMM, (I,) mean log-likelihoods per frame of the I iterations) with
        `return_history`.

    Raises:
        ValueError: Never a NaN model instead: naming `reg_covar` when reg_covar=0 (pure maximum
            likelihood) leaves a covariance singular (a constant feature, collinear features, a
            state of at most D frames); naming `X` for data whose second moments overflow the
            compute dtype (e.g. values of 1e20 in float32), checked before fitting; naming `X`,
            `lengths`, `config`, `init`, `options` or `mesh` for a wrong type, shape or value
            (NaN/inf, lengths no path fits, an invalid `init`).

    Warns:
        RuntimeWarning: A state had no responsibility; its previous Gaussian was kept.
    """
    X, lengths, weights, hmm = prepare_fit(X, lengths, config, init, options, mesh)
    hmm, history = run_em(hmm, X, lengths, weights, options, options.max_iter, options.freeze_means_after,
                          step=em_step if mesh is None else sharded_em_step(mesh))
    check_fit_result(hmm, X, options)
    return (hmm, jnp.asarray(history)) if return_history else hmm
