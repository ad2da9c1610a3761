"""Parametric HMMs (PHMM §III-B, BMVC §4): local HMMs at the corners of a regular grid over the
parameter box [0, 1]^d, synchronised by training, interpolated component-wise and d-linearly.

Shapes: d parameter dimensions, grid (g_1, ..., g_d) with C = Π g_k local HMMs, N states, D features.
A parameter φ in [0, 1]^d lies in the grid cell around it; interpolation uses the 2^d corners of that
cell (eqs. 1, 4–6). Outside [0, 1] (recognition searches [−ε, 1+ε]^d) means extrapolate linearly from
the border cell; covariances and duration distributions use φ clipped to the box, so they stay valid
(a positive-definite mix, a probability distribution).
"""
from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh
from jaxtyping import Array, ArrayLike, Float, Int

from lfd_common import as_array, check_int, check_real, float_dtype, pad_sequences, safe_log, solve_spd
from lfd_common import check_mesh, map_batch
from phmm_jax._src import inference as inference
from phmm_jax._src.batched import emission_columns
from phmm_jax._src.checks import (check_distances, check_fit_scale, check_grid_shape, check_type,
    covariance_range, extrapolation_factor, mean_norm)
from phmm_jax._src.data import Lengths, Sequences, check_feasible, stack_groups, to_device
from phmm_jax._src.em import check_fit_result, em_step, initial_hmm, run_em
from phmm_jax._src.emissions import affine_log_density_columns, affine_whitening, stacked_log_density_columns
from phmm_jax._src.model import (HMM, HMMConfig, duration_log_probs, reachable_states,
    transitions_from_durations)
from phmm_jax._src.options import FitOptions, check_options


@partial(jax.tree_util.register_dataclass, data_fields=["local"], meta_fields=["grid_shape"])
@dataclasses.dataclass(frozen=True)
class PHMM:
    """A parametric HMM (PHMM §III-B, BMVC §4): synchronised local HMMs at the corners of a grid.

    The HMM λ^φ of a parameter φ in [0, 1]^d is their d-linear interpolation (`interpolate`,
    eqs. 1, 4-6). Build one with `fit_phmm`. An immutable pytree; `grid_shape` is static.

    Attributes:
        local: One HMM whose arrays carry a leading axis C = Π g_k over the grid corners in C order
            (the last parameter varies fastest); `grid_points(grid_shape)` gives their φ.
        grid_shape: (g_1, ..., g_d), grid points per parameter.
    """

    local: HMM
    grid_shape: tuple[int, ...]

    @property
    def n_params(self) -> int:
        """d, the number of parameters."""
        return len(self.grid_shape)

    @property
    def config(self) -> HMMConfig:
        """The `HMMConfig` every local HMM shares."""
        return self.local.config

    def corner(self, index: tuple[int, ...]) -> HMM:
        """The local HMM at one grid corner.

        Args:
            index: (k_1, ..., k_d), the corner's grid index along each parameter.

        Returns:
            That corner's `HMM`.
        """
        flat = int(np.ravel_multi_index(index, self.grid_shape))
        return jax.tree_util.tree_map(lambda a: a[flat], self.local)


def grid_points(grid_shape: tuple[int, ...]) -> Float[np.ndarray, "C d"]:
    """Parameter values φ of the corners of a regular grid over [0, 1]^d, in C order.

    The order of `fit_phmm`'s groups and of `PHMM.local`'s leading axis (PHMM §III-B).

    Args:
        grid_shape: (g_1, ..., g_d), a non-empty tuple (or list) of grid sizes >= 2.

    Returns:
        (C, d) numpy array, C = Π g_k, the last parameter varying fastest.

    Raises:
        ValueError: Naming `grid_shape`, when it is empty, not a tuple or list, or has a size < 2.
    """
    grid_shape = check_grid_shape(grid_shape)
    axes = [np.linspace(0.0, 1.0, g) for g in grid_shape]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(grid_shape))


def cell_weights(grid_shape, phi):
    """Corner indices (2^d,) and d-linear weights (2^d,) for φ (d,); weights may be negative outside
    [0, 1]^d (linear extrapolation from the border cell). Differentiable in φ."""
    grid = jnp.asarray(grid_shape)
    scaled = phi * (grid - 1)
    lower = jnp.clip(jnp.floor(jax.lax.stop_gradient(scaled)), 0, grid - 2).astype(jnp.int32)
    frac = scaled - lower  # u, v, w of eqs. 4-6
    offsets = jnp.asarray(list(itertools.product((0, 1), repeat=len(grid_shape))))  # (2^d, d)
    weights = jnp.prod(jnp.where(offsets == 1, frac, 1.0 - frac), axis=1)
    strides = jnp.asarray(np.cumprod((1,) + tuple(grid_shape[::-1]))[-2::-1].copy())
    corners = jnp.sum((lower + offsets) * strides, axis=1)
    return corners, weights


def corner_weights(grid_shape, phi):
    """(C,) the d-linear weight of every grid corner for φ (d,): `cell_weights` scattered onto the
    whole grid (zero outside φ's cell). Interpolating with all C corners is one product with the
    stacked local models, rather than a gather of each φ's 2^d corners that would copy
    (B, 2^d, N, D, D) covariances."""
    corners, weights = cell_weights(grid_shape, phi)
    return jnp.zeros(int(np.prod(grid_shape)), weights.dtype).at[corners].add(weights)


def interpolate(phmm: PHMM, phi: Float[Array, " d"]) -> HMM:
    """The HMM λ^φ: component-wise d-linear interpolation of the local HMMs (PHMM eqs. 1, 4-6).

    φ lies in the grid cell around it and the 2^d corners of that cell are mixed. Outside [0, 1]^d
    the means extrapolate linearly from the border cell, while covariances and duration
    distributions use φ clipped to the box, so they stay valid. Pure jnp, differentiable in φ, no
    input checks.

    Args:
        phmm: The PHMM.
        phi: (d,) the parameter.

    Returns:
        The interpolated `HMM` (means (N, D), covariances (N, D, D), log_cont / log_exit (N, P)).
    """
    weights = corner_weights(phmm.grid_shape, phi)
    weights_in = corner_weights(phmm.grid_shape, jnp.clip(phi, 0.0, 1.0))
    local = phmm.local
    means = jnp.tensordot(weights, local.means, axes=1)
    covariances = jnp.tensordot(weights_in, local.covariances, axes=1)
    config = local.config
    if config.explicit_duration:
        p = jnp.exp(jax.vmap(duration_log_probs)(local))  # (C, N, P)
        log_cont, log_exit = transitions_from_durations(config, safe_log(jnp.tensordot(weights_in, p, axes=1)))
    else:  # self-loop probabilities interpolate directly
        log_cont = safe_log(jnp.tensordot(weights_in, jnp.exp(local.log_cont), axes=1))
        log_exit = safe_log(jnp.tensordot(weights_in, jnp.exp(local.log_exit), axes=1))
    return HMM(means, covariances, log_cont, log_exit, config)


@jax.jit
def batch_phmm_log_likelihood(phmm: PHMM, X: Float[Array, "B T D"], lengths: Int[Array, " B"],
                              phi: Float[Array, "B d"]) -> Float[Array, " B"]:
    """Log-likelihoods of a checked, padded batch, one parameter per sequence (PHMM eq. 3's objective).

    The jitted kernel of `phmm_log_likelihood`; no input checks. Differentiable in φ.

    Args:
        phmm: The PHMM.
        X: (B, T, D) padded sequences in the compute dtype.
        lengths: (B,) int32 frames per sequence.
        phi: (B, d) each sequence's parameter.

    Returns:
        (B,) log p(x_b | λ^{φ_b}).
    """
    hmms = jax.vmap(interpolate, in_axes=(None, 0))(phmm, phi)  # arrays with a leading B axis
    reachable = reachable_states(phmm.config, X.shape[1])
    log_b = stacked_log_density_columns(X, hmms.means, hmms.covariances, reachable)  # (T, N, B)
    return inference.forward_loglik(inference.stacked_chain(hmms), log_b, lengths)


def check_phmm_distances(phmm: PHMM, X: np.ndarray, lengths: np.ndarray, factor: float, model_name: str,
                         far_name: str) -> None:
    """`checks.check_distances` for every λ^φ with φ in [0, 1]^d (naming `X` or `model_name`), then
    with the means extrapolated by `factor` (`checks.extrapolation_factor`, naming `far_name`).
    The interpolated covariances mix the corners' (φ clipped), so their smallest eigenvalue is at
    least the corners' smallest."""
    mean_bound = mean_norm(phmm.local.means, model_name)
    low, _ = covariance_range(phmm.local.covariances, model_name)
    grid = max(phmm.grid_shape)
    check_distances(X, lengths, mean_bound, low, model_name=model_name, differentiable=True, grid=grid)
    if factor > 1.0:
        check_distances(X, lengths, factor * mean_bound, low, differentiable=True, grid=grid, blame=far_name)


def _check_phi(phmm: PHMM, phi, batch: int):
    phi = as_array(phi, "phi", ndim=(1, 2))
    if phi.shape[-1] != phmm.n_params:
        raise ValueError(f"phi: expected {phmm.n_params} parameter(s) per sequence, got shape {phi.shape}")
    phi = np.broadcast_to(phi, (batch, phmm.n_params)) if phi.ndim == 1 else phi
    if phi.shape[0] != batch:
        raise ValueError(f"phi: expected {batch} rows (one per sequence), got {phi.shape[0]}")
    return phi


def phmm_log_likelihood(phmm: PHMM, X: Sequences, phi: Float[ArrayLike, "B d"] | Float[ArrayLike, " d"],
                        lengths: Lengths = None) -> Float[Array, " B"]:
    """Log-likelihood log p(x | λ^φ) of every sequence under the interpolated HMM (PHMM eq. 3).

    Differentiable in φ through `batch_phmm_log_likelihood`.

    Args:
        phmm: The PHMM.
        X: (B, T, D) padded with `lengths`, a (T, D) sequence or a list of (T_b, D) arrays.
        phi: (d,) for all sequences, or (B, d) one per sequence. φ may leave [0, 1]^d (the means
            extrapolate).
        lengths: (B,) frames per sequence, or None (all T, or the list's lengths).

    Returns:
        (B,) log-likelihoods.

    Raises:
        ValueError: Naming the argument: `phmm` not a PHMM; `phi` of the wrong shape, or so far
            outside [0, 1]^d that the log-likelihood or its gradient overflows the compute dtype
            (φ = 1e30); `X` / `lengths` as in `log_likelihood`.
    """
    check_type(phmm, "phmm", PHMM)
    X, lengths = pad_sequences(X, lengths, dim=phmm.local.dim)
    check_feasible(phmm.config, lengths)
    phi = _check_phi(phmm, phi, X.shape[0])
    check_phmm_distances(phmm, X, lengths, extrapolation_factor(phmm.grid_shape, phi), "phmm", "phi")
    X, lengths = to_device(X, lengths)
    return batch_phmm_log_likelihood(phmm, X, lengths, jnp.asarray(phi, X.dtype))


def fit_phmm(groups: Sequence[Sequences], grid_shape: tuple[int, ...], config: HMMConfig = HMMConfig(),
             *, options: FitOptions = FitOptions()) -> PHMM:
    """Train a PHMM by the synchronised local training of PHMM §III-B1 (BMVC §4.1).

    1. A global HMM is fitted by EM on all sequences (`options.max_iter`). 2. Every local HMM starts
    from it and runs EM on its own sequences (`options.local_max_iter`, default `max_iter`) with the
    means fixed after the first iteration (eq. 2), so corresponding states of all local HMMs model
    the same part of the movement. The local EMs run as one vmap.

    Args:
        groups: One entry per grid corner in C order (`grid_points(grid_shape)` gives their φ),
            each a list of (T_b, D) sequences or a (B, T, D) array, all of the same action.
        grid_shape: (g_1, ..., g_d), a non-empty tuple (or list) of grid sizes >= 2.
        config: The local HMMs' structure.
        options: `FitOptions` (max_iter, local_max_iter, tol, reg_covar, duration_pseudocount).

    Returns:
        The `PHMM`.

    Raises:
        ValueError: Naming the argument for wrong types (`groups`, `grid_shape`, `config`,
            `options`), a group count other than Π grid_shape, an empty group (`groups[k]`), and,
            as `fit_hmm` does, instead of returning a NaN or singular model.
    """
    options = check_options(options)
    grid_shape = check_grid_shape(grid_shape)
    check_type(config, "config", HMMConfig)
    if isinstance(groups, (str, bytes)) or not hasattr(groups, "__len__"):
        raise ValueError(f"groups: expected a sequence of groups of sequences (one per grid corner), "
                         f"got {type(groups).__name__}")
    n_corners = int(np.prod(grid_shape))
    if len(groups) != n_corners:
        raise ValueError(f"groups: a {'x'.join(map(str, grid_shape))} grid needs {n_corners} groups of "
                         f"sequences (one per corner), got {len(groups)}")
    for k, group in enumerate(groups):
        if isinstance(group, (str, bytes)) or not hasattr(group, "__len__"):
            raise ValueError(f"groups[{k}]: expected a list of sequences or a (B, T, D) array, "
                             f"got {type(group).__name__}")
        if len(group) == 0:
            raise ValueError(f"groups[{k}]: the grid corner {np.unravel_index(k, grid_shape)} has no sequences")
    X, lengths, weights = stack_groups(groups, None, "groups")
    check_feasible(config, lengths.ravel())
    check_fit_scale(X, lengths, "groups")
    X = jnp.asarray(X, float_dtype())
    lengths, weights = jnp.asarray(lengths), jnp.asarray(weights, X.dtype)
    flat = (X.reshape(-1, *X.shape[2:]), lengths.ravel(), weights.ravel())
    global_hmm = initial_hmm(config, *flat, options.reg_covar, options.duration_pseudocount)
    global_hmm, _ = run_em(global_hmm, *flat, options, options.max_iter)
    check_fit_result(global_hmm, flat[0], options, "groups")
    start = jax.tree_util.tree_map(lambda a: jnp.broadcast_to(a, (n_corners,) + a.shape), global_hmm)
    local_max_iter = options.max_iter if options.local_max_iter is None else options.local_max_iter
    local, _ = run_em(start, X, lengths, weights, options, local_max_iter, freeze_means_after=1, step=_local_em_step)
    check_fit_result(local, X, options, "groups")
    return PHMM(local, grid_shape)


@partial(jax.jit, static_argnames=("update_means",))
def _local_em_step(hmm: HMM, X, lengths, weights, reg_covar, duration_pseudocount, update_means: bool = True):
    """`em_step` for all local HMMs at once (leading axis C on the HMM and the data)."""
    return jax.vmap(lambda h, x, n, w: em_step(h, x, n, w, reg_covar, duration_pseudocount, update_means=update_means)
                    )(hmm, X, lengths, weights)


class Recognition(NamedTuple):
    """The result of `recognize` (PHMM eq. 3): class and parameter of every sequence.

    Attributes:
        label: (B,) index of the best PHMM.
        phi: (B, K, d) the best parameter per sequence and PHMM.
        loglik: (B, K) log-likelihood at that parameter.
    """

    label: Int[Array, " B"]
    phi: Float[Array, "B K d"]
    loglik: Float[Array, "B K"]


def start_lattice(n_params: int, points: int | tuple[int, ...]) -> jnp.ndarray:
    """(M, d) the lattice over [0, 1]^d with `points` per parameter (one count for all, or one each)."""
    axes = [np.linspace(0.0, 1.0, n) for n in _lattice_axes(n_params, points)]
    return jnp.asarray(np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, n_params))


def _newton_direction(grad, hess, phi, lower, upper, damping):
    """The damped Newton (Levenberg-Marquardt) ascent step δ (B, d) of every sequence: (A + s I) δ = g
    with A = −H on the free coordinates, s the damping (relative to A's largest diagonal entry) plus
    a Gershgorin shift that makes the matrix positive definite where H is not negative definite.
    Coordinates on a face of the box whose gradient points outwards are held (projected Newton)."""
    d = grad.shape[-1]
    free = ~(((phi <= lower) & (grad < 0)) | ((phi >= upper) & (grad > 0)))  # (B, d)
    eye = jnp.eye(d, dtype=grad.dtype)
    both = free[:, :, None] & free[:, None, :]
    a = jnp.where(both, -0.5 * (hess + jnp.swapaxes(hess, 1, 2)), 0.0)
    a = jnp.where(eye > 0, jnp.where(free[:, :, None], a, 1.0), a)
    diag = jnp.diagonal(a, axis1=1, axis2=2)
    radius = jnp.sum(jnp.abs(a), axis=2) - jnp.abs(diag)
    scale = jnp.max(jnp.abs(diag), axis=1) + jnp.finfo(grad.dtype).tiny
    shift = jnp.maximum(0.0, jnp.max(radius - diag, axis=1)) + damping * scale + 1e-6 * scale
    return solve_spd(a + shift[:, None, None] * eye, jnp.where(free, grad, 0.0))


def _secant_update(hess, s, y):
    """BFGS update (B, d, d) of the Hessian H of a maximisation from steps s (B, d) and gradient
    changes y (B, d); skipped per sequence where the curvature condition fails."""
    a = -hess
    a_s = jnp.einsum("bij,bj->bi", a, s)
    s_a_s = jnp.sum(s * a_s, axis=1)
    y_s = -jnp.sum(y * s, axis=1)
    ok = (y_s > 1e-12 * jnp.sqrt(jnp.sum(s * s, 1) * jnp.sum(y * y, 1))) & (s_a_s > 0)
    update = y[:, :, None] * y[:, None, :] / jnp.where(ok, y_s, 1.0)[:, None, None] \
        - a_s[:, :, None] * a_s[:, None, :] / jnp.where(ok, s_a_s, 1.0)[:, None, None]
    return -(a + jnp.where(ok[:, None, None], update, 0.0))


_FACE_MARGIN = 0.15  # how near a grid line the probe of `search_parameters` looks
_PROBE_DISTANCES = (0.03, 0.075)  # how far across it the probes lie (at least)
# Sequences searched at once by default (`recognize`'s `chunk_size`): the search's memory is that of
# one chunk, whatever the batch (about 1.4 MB per sequence of 100 x 21 frames, 20 states). Much
# smaller chunks run slower per sequence; from about 100 on, as fast as the whole batch at once
# (2-core CPU, d = 3 PHMM of a 3 x 3 x 3 grid, 540 sequences).
DEFAULT_CHUNK_SIZE = 128
# Lattice points x sequences scored at once: each pair needs a few (T, N) emission and message arrays,
# so the lattice's memory is bounded whatever its size (13^3 = 2197 points for a 3 x 3 x 3 grid).
_LATTICE_PAIRS = 2048
# A (point, sequence) pair scored under its own interpolated model costs about this many pairs under a
# shared one (its own interpolation, Cholesky factors and small products: 190 against 31 us on a 2-core
# CPU, d = 3 PHMM of a 3 x 3 x 3 grid, 128 sequences): the coarse-to-fine start is used only where it
# costs less than the whole lattice.
_OWN_MODEL_COST = 6
# (candidate, sequence) pairs scored at once under their own models: each holds its own interpolated
# covariances and whitening maps (about 70 kB at N = 20, D = 21), so fewer than `_LATTICE_PAIRS`.
_OWN_MODEL_PAIRS = 512
# The refinement of the coarse-to-fine start scores lattice points only: where the lattice has fewer
# points than a chunk has (candidate, sequence) pairs, each point's model is interpolated and whitened
# once (`_lattice_models`) and the pairs gather theirs. The whitening (a Cholesky factor and its
# inverse per state, small LAPACK calls) is about half of a pair's cost; with the table the d = 3
# bench's search takes about 2/3 of the time. The table holds about 38 kB per point (N = 20, D = 21,
# float32): 83 MB for 13^3 points; at most `_TABLE_POINTS` points, own models per pair beyond.
_TABLE_POINTS = 4096
# Lattice points interpolated and whitened at once for the table.
_MODEL_BLOCK = 64
# `recognize`'s coarse-to-fine start, chosen on validation data (200 movements of the d = 3 bench's
# generator, another seed): every second lattice point, the 4 best per sequence refined, leaves no
# sequence in a worse optimum than the whole 13^3 lattice (the 2 best: 1 of 200, 9 nats worse).
DEFAULT_COARSE_STRIDE = 2
DEFAULT_COARSE_TOP = 4


def _default_lattice(grid_shape: tuple[int, ...]) -> tuple[int, ...]:
    """Start-lattice points per parameter, chosen on validation data: 5 for 2 grid points."""
    return tuple(5 if g == 2 else 6 * (g - 1) + 1 for g in grid_shape)  # else 6 intervals per cell


def _blocks(a: Array, size: int) -> Array:
    """(n, ...) -> (k, m, ...): k = ceil(n / size) blocks of m <= size rows, as even as possible, the
    last row repeated to fill them (a valid row, cut off afterwards)."""
    count = -(-a.shape[0] // size)
    rows = -(-a.shape[0] // count)
    padded = jnp.pad(a, [(0, count * rows - a.shape[0])] + [(0, 0)] * (a.ndim - 1), mode="edge")
    return padded.reshape(count, rows, *a.shape[1:])


def _lattice_scores(phmm: PHMM, X, lengths, lattice) -> Float[Array, "M B"]:
    """Log-likelihood of every sequence at every lattice point (M, d), block by block of the lattice
    (`lax.map`) so that a block holds about `_LATTICE_PAIRS` (point, sequence) pairs."""

    def at_point(phi):  # every sequence scored under one interpolated model (no per-sequence models)
        hmm = interpolate(phmm, phi)
        return inference.forward_loglik(inference.chain(hmm), emission_columns(hmm, X), lengths)

    blocks = _blocks(lattice, max(1, _LATTICE_PAIRS // X.shape[0]))
    return jax.lax.map(jax.vmap(at_point), blocks).reshape(-1, X.shape[0])[:lattice.shape[0]]


def _candidate_scores(phmm: PHMM, X, lengths, candidates: Float[Array, "P B d"]) -> Float[Array, "P B"]:
    """Log-likelihood of every sequence b at each of its own P candidates φ (P, B, d), -inf where not
    finite: one interpolated model per (candidate, sequence) pair, about `_OWN_MODEL_PAIRS` pairs at
    a time (`lax.map` over blocks of candidates)."""
    n_params = candidates.shape[-1]

    def at_block(phi):  # (p, B, d): the batch tiled p times, one model per row
        tiled = lambda a: jnp.tile(a, (phi.shape[0],) + (1,) * (a.ndim - 1))  # noqa: E731
        values = batch_phmm_log_likelihood(phmm, tiled(X), tiled(lengths), phi.reshape(-1, n_params))
        return values.reshape(phi.shape[:2])

    values = jax.lax.map(at_block, _blocks(candidates, max(1, _OWN_MODEL_PAIRS // X.shape[0])))
    values = values.reshape(-1, X.shape[0])[:candidates.shape[0]]
    return jnp.where(jnp.isfinite(values), values, -jnp.inf)


def _lattice_axes(n_params: int, points: int | tuple[int, ...]) -> tuple[int, ...]:
    """Start-lattice points per parameter (d,) from one count for all or one each."""
    return (points,) * n_params if isinstance(points, int) else tuple(points)


def _coarse_indices(points: int, stride: int) -> np.ndarray:
    """Indices along one axis of the start lattice (`points` of them) that the coarse lattice keeps:
    every `stride`-th and the last, so that every index is within stride - 1 of a kept one."""
    return np.unique(np.append(np.arange(0, points, stride), points - 1))


class _StartPlan(NamedTuple):
    """How `_start_points` finds the starts of a batch (static: shapes only)."""

    points: np.ndarray  # (d,) start-lattice points per parameter
    coarse: np.ndarray  # (Mc, d) lattice indices of the coarse lattice
    width: np.ndarray  # (d,) the refinement box around a coarse point
    top: int  # coarse points refined per sequence
    method: str  # "lattice": the whole lattice; "table" or "pairs": coarse to fine, the refinement's models
    #              gathered from `_lattice_models` or interpolated per (candidate, sequence) pair


def _start_plan(n_params: int, lattice_points, coarse_stride: int, coarse_top: int, batch: int) -> _StartPlan:
    """The coarse-to-fine geometry of `_start_points` and whether it pays: stride 1, or a coarse lattice
    and boxes that cost more than the whole lattice (`_OWN_MODEL_COST`), score the whole lattice; the
    refinement reads a table of every lattice point's model where that has fewer models than the
    batch has (candidate, sequence) pairs (and at most `_TABLE_POINTS`)."""
    points = np.asarray(_lattice_axes(n_params, lattice_points))
    coarse = np.stack(np.meshgrid(*[_coarse_indices(n, coarse_stride) for n in points], indexing="ij"),
                      -1).reshape(-1, n_params)
    width = np.minimum(2 * coarse_stride - 1, points)
    top = min(coarse_top, coarse.shape[0])
    pairs = batch * top * int(np.prod(width))
    if coarse_stride == 1 or coarse.shape[0] + _OWN_MODEL_COST * top * np.prod(width) >= np.prod(points):
        method = "lattice"
    elif np.prod(points) <= min(pairs, _TABLE_POINTS):
        method = "table"
    else:
        method = "pairs"
    return _StartPlan(points, coarse, width, top, method)


def _start_points(phmm: PHMM, X, lengths, lattice_points, coarse_stride: int, coarse_top: int,
                  table=None) -> Float[Array, "B d"]:
    """The best start-lattice point of every sequence (B, T, D), coarse to fine.

    The lattice points (i_1, ..., i_d) / (n_k - 1) whose indices are all kept by `_coarse_indices`
    are scored for every sequence under shared models (`_lattice_scores`); around each sequence's
    `coarse_top` best of them, the lattice points within stride - 1 indices along every parameter
    (a box of (2 stride - 1)^d, shifted inside the lattice at its faces) are scored under one model
    per sequence, gathered from `table` (`_lattice_models` of the whole lattice; built here where
    `_start_plan` asks for one and none is given) or interpolated per pair (`_candidate_scores`);
    the best of these is the start. Where `_start_plan` says the coarse-to-fine start does not pay,
    the whole lattice is scored instead.
    """
    plan = _start_plan(phmm.n_params, lattice_points, coarse_stride, coarse_top, X.shape[0])
    if plan.method == "lattice":
        lattice = start_lattice(phmm.n_params, lattice_points)
        return lattice[jnp.argmax(_lattice_scores(phmm, X, lengths, lattice), axis=0)]
    scale = np.maximum(plan.points - 1, 1)
    scores = _lattice_scores(phmm, X, lengths, jnp.asarray(plan.coarse / scale))  # (Mc, B)
    best = jax.lax.top_k(scores.T, plan.top)[1]  # (B, k)
    box = np.stack(np.meshgrid(*[np.arange(w) for w in plan.width], indexing="ij"), -1).reshape(-1, phmm.n_params)
    first = jnp.clip(jnp.asarray(plan.coarse)[best] - (coarse_stride - 1), 0, plan.points - plan.width)  # (B, k, d)
    index = (first[:, :, None] + box).reshape(X.shape[0], -1, phmm.n_params)  # (B, P, d) lattice indices
    candidates = index / scale
    if plan.method == "table":
        table = _start_table(phmm, lattice_points, plan) if table is None else table
        strides = np.cumprod((1,) + tuple(plan.points[::-1]))[-2::-1]  # C order, as `start_lattice`
        values = _table_scores(phmm, X, lengths, table, jnp.sum(index * strides, axis=-1).T)  # (P, B)
    else:
        values = _candidate_scores(phmm, X, lengths, jnp.swapaxes(candidates, 0, 1))  # (P, B)
    return candidates[jnp.arange(X.shape[0]), jnp.argmax(values, axis=0)]


def _start_table(phmm: PHMM, lattice_points, plan: _StartPlan):
    """The whole start lattice's `_lattice_models` where `plan` reads a table, else None."""
    return _lattice_models(phmm, start_lattice(phmm.n_params, lattice_points)) if plan.method == "table" else None


def _lattice_models(phmm: PHMM, lattice: Float[Array, "M d"]):
    """The interpolated model of every lattice point, as `_table_scores` reads it: affine whitening
    maps (M, N, D, D+1) and normalising constants (M, N) (`affine_whitening`), log_cont and log_exit
    (M, N, P); `_MODEL_BLOCK` points at a time (`lax.map`)."""
    def block(phi):
        hmms = jax.vmap(interpolate, in_axes=(None, 0))(phmm, phi)
        return (*affine_whitening(hmms.means, hmms.covariances), hmms.log_cont, hmms.log_exit)

    out = jax.lax.map(block, _blocks(lattice, _MODEL_BLOCK))
    return tuple(a.reshape(-1, *a.shape[2:])[:lattice.shape[0]] for a in out)


def _table_scores(phmm: PHMM, X, lengths, table, index: Int[Array, "P B"]) -> Float[Array, "P B"]:
    """`_candidate_scores` of lattice points given by their flat indices (P, B) into `table`
    (`_lattice_models`): the models are gathered, not interpolated and whitened again per pair."""
    reachable = reachable_states(phmm.config, X.shape[1])

    def at_block(ix):  # (p, B): the batch tiled p times, one model per row
        tiled = lambda a: jnp.tile(a, (ix.shape[0],) + (1,) * (a.ndim - 1))  # noqa: E731
        affine, const, log_cont, log_exit = (a[ix.reshape(-1)] for a in table)
        log_b = affine_log_density_columns(tiled(X), affine, const, reachable)
        chain = inference.Chain(jnp.moveaxis(log_cont, 0, -1), jnp.moveaxis(log_exit, 0, -1), phmm.config)
        return inference.forward_loglik(chain, log_b, tiled(lengths)).reshape(ix.shape)

    values = jax.lax.map(at_block, _blocks(index, max(1, _OWN_MODEL_PAIRS // X.shape[0])))
    values = values.reshape(-1, X.shape[0])[:index.shape[0]]
    return jnp.where(jnp.isfinite(values), values, -jnp.inf)


@partial(jax.jit, static_argnames=("lattice_points", "chunk_size", "coarse_stride", "coarse_top"))
def search_parameters(phmm: PHMM, X: Float[Array, "B T D"], lengths: Int[Array, " B"], epsilon: float | Array,
                      n_steps: int | Array, lattice_points: int | tuple[int, ...], face_steps: int | Array,
                      chunk_size: int = DEFAULT_CHUNK_SIZE, coarse_stride: int = 1,
                      coarse_top: int = 1) -> tuple[Float[Array, "B d"], Float[Array, " B"]]:
    """The parameter search of one PHMM on a checked, padded batch: the jitted kernel of `recognize`.

    φ* = argmax over [−ε, 1+ε]^d of log p(x | λ^φ) for every sequence (PHMM eq. 3): the best point
    of a lattice over [0, 1]^d under the full model (the whole lattice, or coarse to fine: see
    `coarse_stride`), `n_steps` damped, projected quasi-Newton steps
    from there (exact Hessian at the start, BFGS updates after, a step kept only where it raises
    the likelihood), then probes across the nearest grid lines and `face_steps` more steps. No
    input checks.

    The batch is searched in chunks of at most `chunk_size` sequences (`lax.map`) and the lattice in
    blocks, so memory grows with neither the batch nor the lattice; every sequence's search is
    independent, so the chunks change the results only by float round-off (products blocked
    differently).

    Args:
        phmm: The PHMM.
        X: (B, T, D) padded sequences in the compute dtype.
        lengths: (B,) int32 frames per sequence.
        epsilon: ε >= 0, how far the search may leave [0, 1]^d (traced).
        n_steps: Quasi-Newton steps from the lattice, >= 1 (traced).
        lattice_points: Lattice points per parameter, one count for all or one each (static).
        face_steps: Steps after the probes across the grid lines (traced; 0: no probes).
        chunk_size: Sequences searched at once, >= 1 (static).
        coarse_stride: >= 1 (static). 1: every lattice point is scored for every sequence. s >= 2:
            coarse to fine: every s-th lattice point along each parameter (and the last) is scored,
            then, for each sequence, the lattice points within s - 1 steps of its `coarse_top` best
            coarse points; the whole lattice where that would cost more.
        coarse_top: Coarse points refined per sequence, >= 1 (static).

    Returns:
        (φ (B, d), log-likelihood at φ (B,)).
    """
    chunks = (_blocks(X, chunk_size), _blocks(lengths, chunk_size))
    # The lattice's model table (if the start reads one) depends on the PHMM only: built once for all chunks.
    plan = _start_plan(phmm.n_params, lattice_points, coarse_stride, coarse_top, chunks[0].shape[1])
    table = _start_table(phmm, lattice_points, plan)
    search = lambda chunk: _search_chunk(phmm, *chunk, epsilon, n_steps, lattice_points, face_steps,  # noqa: E731
                                         coarse_stride, coarse_top, table)
    phi, loglik = jax.lax.map(search, chunks)
    return phi.reshape(-1, phmm.n_params)[:X.shape[0]], loglik.reshape(-1)[:X.shape[0]]


def _search_chunk(phmm: PHMM, X, lengths, epsilon, n_steps: int, lattice_points, face_steps: int, coarse_stride: int,
                  coarse_top: int, table):
    """`search_parameters` on one chunk of sequences (B, T, D).

    Sequence b's log-likelihood depends on φ_b only, so the gradient of the batch sum is every
    sequence's gradient, and one reverse pass of that gradient along coordinate k gives row k of
    every sequence's d x d Hessian at once. The climb from the lattice and the climb from the probes
    are two rounds of one loop, with the step counts traced, so the Hessian and the step are
    compiled once, not once per climb (their reverse passes through the forward scan are most of
    the compile time), and other step counts compile nothing new.
    """
    d = phmm.n_params
    lower, upper = -epsilon, 1.0 + epsilon

    def gradient(phi):
        loglik, pullback = jax.vjp(lambda p: batch_phmm_log_likelihood(phmm, X, lengths, p), phi)
        return pullback(jnp.ones_like(loglik))[0], loglik

    def with_hessian(phi):  # log-likelihood (B,), gradient (B, d), Hessian (B, d, d)
        grad, pullback, loglik = jax.vjp(gradient, phi, has_aux=True)
        basis = jnp.broadcast_to(jnp.eye(d, dtype=phi.dtype)[:, None, :], (d,) + phi.shape)
        rows = jax.vmap(lambda e: pullback(e)[0])(basis)  # (d, B, d): rows[k, b] = ∂g_bk/∂φ_b
        return loglik, grad, jnp.swapaxes(rows, 0, 1)

    def step(_, carry):
        phi, loglik, grad, hess, damping = carry
        candidate = jnp.clip(phi + _newton_direction(grad, hess, phi, lower, upper, damping), lower, upper)
        c_grad, c_loglik = gradient(candidate)
        c_hess = _secant_update(hess, candidate - phi, c_grad - grad)
        better = jnp.isfinite(c_loglik) & (c_loglik > loglik) & jnp.all(jnp.isfinite(c_grad), axis=1)
        pick = lambda new, old: jnp.where(better.reshape((-1,) + (1,) * (new.ndim - 1)), new, old)  # noqa: E731
        # A rejected step still tells the secant model about the curvature along it.
        hess = jnp.where(jnp.all(jnp.isfinite(c_hess), axis=(1, 2))[:, None, None], c_hess, hess)
        damping = jnp.where(better, jnp.maximum(damping * 0.1, 1e-8), damping * 10.0)
        return pick(candidate, phi), pick(c_loglik, loglik), pick(c_grad, grad), hess, damping

    def probe_restart(phi, loglik):
        # Covariances and durations stop changing at the faces of [0, 1]^d while the means go on, and
        # the d-linear interpolation changes cell at the grid lines between, so the likelihood has
        # kinks there and often a second maximum just across. Probe the mirror image across the
        # nearest grid line of every coordinate near one (one at a time and all together, at two
        # distances at least) and restart from the best of these where it beats φ.
        cells = jnp.asarray(phmm.grid_shape, phi.dtype) - 1.0
        face = jnp.clip(jnp.round(phi * cells), 0.0, cells) / cells  # the nearest grid line of each coordinate
        offset = phi - face
        near = jnp.abs(offset) < _FACE_MARGIN
        distances = jnp.asarray(_PROBE_DISTANCES, phi.dtype)[:, None, None]  # (R, 1, 1)
        mirror = face - jnp.where(offset >= 0, 1.0, -1.0) * jnp.maximum(jnp.abs(offset), distances)  # (R, B, d)
        masks = jnp.concatenate([jnp.eye(d, dtype=bool), jnp.ones((1, d), bool)])  # (d + 1, d)
        probes = jnp.where(masks[None, :, None, :] & near[None, None], mirror[:, None], phi[None, None])
        n_probes = len(_PROBE_DISTANCES) * (d + 1)
        probes = jnp.clip(probes.reshape(n_probes, -1, d), lower, upper)
        values = _candidate_scores(phmm, X, lengths, probes)
        take = jnp.max(values, axis=0) > loglik
        return jnp.where(take[:, None], probes[jnp.argmax(values, axis=0), jnp.arange(phi.shape[0])], phi)

    n_rounds = jnp.where(face_steps > 0, 2, 1)

    def climb(index, carry):
        """Round `index`: its steps from `start`, kept (after the first round) where they beat the
        best so far; then the next round's start from the probes (none after the last round)."""
        start, best_phi, best_loglik = carry
        damping = jnp.full(start.shape[0], 1e-3, start.dtype)
        steps = jnp.where(index == 0, n_steps, face_steps)
        phi, loglik, *_ = jax.lax.fori_loop(0, steps, step, (start, *with_hessian(start), damping))
        keep = (index == 0) | (loglik > best_loglik)
        phi, loglik = jnp.where(keep[:, None], phi, best_phi), jnp.where(keep, loglik, best_loglik)
        restart = jax.lax.cond(index + 1 < n_rounds, probe_restart, lambda p, _: p, phi, loglik)
        return restart, phi, loglik

    start = _start_points(phmm, X, lengths, lattice_points, coarse_stride, coarse_top, table)
    init = (start, start, jnp.full(start.shape[0], -jnp.inf, start.dtype))
    _, phi, loglik = jax.lax.fori_loop(0, n_rounds, climb, init)
    return phi, loglik


def _search_shard(phmm: PHMM, epsilon, n_steps, face_steps, X, lengths, *, lattice_points: int, chunk_size: int,
                  coarse_stride: int, coarse_top: int):
    """`search_parameters` on one shard's sequences of a batch split over a mesh."""
    return search_parameters(phmm, X, lengths, epsilon, n_steps, lattice_points, face_steps, chunk_size, coarse_stride,
                             coarse_top)


def recognize(phmms: PHMM | Sequence[PHMM], X: Sequences, lengths: Lengths = None, epsilon: float = 0.1,
              n_steps: int = 6, lattice_points: int | None = None, face_steps: int = 3, *,
              chunk_size: int = DEFAULT_CHUNK_SIZE, mesh: Mesh | None = None,
              coarse_stride: int = DEFAULT_COARSE_STRIDE, coarse_top: int = DEFAULT_COARSE_TOP) -> Recognition:
    """Classify sequences and estimate their parameters (PHMM eq. 3, §III-B2; BMVC §4.2).

    For each PHMM k, φ_k = argmax over [−ε, 1+ε]^d of log p(x | λ_k^φ); the label is the k with the
    highest log-likelihood at its φ_k. Batched over sequences.

    Args:
        phmms: A PHMM or a sequence of K PHMMs (same D and number of parameters d).
        X: (B, T, D) padded with `lengths`, a (T, D) sequence or a list of (T_b, D) arrays.
        lengths: (B,) frames per sequence, or None (all T, or the list's lengths).
        epsilon: ε >= 0, how far the search may leave [0, 1]^d.
        n_steps: Damped, projected quasi-Newton steps from the best lattice point, >= 1.
        lattice_points: Start-lattice points per parameter, >= 1; None: 5 for a grid of 2 points,
            6 intervals per grid cell for more.
        face_steps: Steps after the probes across the nearest grid lines, >= 0 (0: no probe).
        chunk_size: Sequences searched at once, >= 1: a larger batch is searched chunk after chunk
            (`lax.map`), so memory is bounded by one chunk and grows with neither the batch nor
            the lattice; the results do not depend on it.
        mesh: A `jax.sharding.Mesh` (or None: one device). The sequences are split over its
            devices (padded to the mesh, the padding cut off), each device searches φ for its own
            (every sequence's search is independent); the result equals the one-device result.
            With several processes each passes its own sequences and gets its own rows.
        coarse_stride: >= 1. 1: the whole start lattice is scored for every sequence. s >= 2 (default
            2): coarse to fine, every s-th lattice point along each parameter first, then around
            each sequence's `coarse_top` best of them the lattice points within s - 1 steps; used
            where it is cheaper than the whole lattice (a 13^3 lattice, not a 5^d one).
        coarse_top: Coarse points refined per sequence, >= 1 (default 4).

    Returns:
        `Recognition`: label (B,), phi (B, K, d), loglik (B, K).

    Raises:
        ValueError: Naming the argument: n_steps < 1, face_steps < 0, lattice_points < 1,
            chunk_size < 1, coarse_stride < 1, coarse_top < 1, a negative epsilon, models that are
            not PHMMs or differ in D or d (`phmms[k]`), `X` / `lengths` as in `log_likelihood`, and
            data (or an epsilon) so far from a model's means that the search would overflow the
            compute dtype.

    Notes:
        The search starts from the best point of a lattice over [0, 1]^d (found coarse to fine
        where that is cheaper: see `coarse_stride`) and takes `n_steps` damped, projected
        quasi-Newton steps (exact d x d Hessian by automatic differentiation at the start, BFGS
        updates after; a step is kept only where it raises the likelihood, so the result is never
        worse than its start). It then probes across the nearest grid lines (the
        faces of [0, 1]^d, where interpolated covariances and durations stop and the means go on,
        and the lines between grid cells, where the d-linear interpolation changes cell: kinks,
        often with a second maximum just across) and takes `face_steps` more steps. A lattice
        point scores all sequences under one model (cheap), a step needs one model per sequence
        (dear); how close the defaults come to a dense scan plus a long refinement is measured by
        `experiments.bench.bench_hmm` (`recognition_at_max_rate`).
    """
    mesh = check_mesh(mesh)
    if isinstance(phmms, PHMM):
        phmms = [phmms]
    elif isinstance(phmms, (list, tuple)):
        phmms = list(phmms)
    else:
        raise ValueError(f"phmms: expected a PHMM or a sequence of PHMMs, got {type(phmms).__name__}")
    if not phmms:
        raise ValueError("phmms: need at least one PHMM")
    for k, phmm in enumerate(phmms):
        check_type(phmm, f"phmms[{k}]", PHMM)
    epsilon = check_real(epsilon, "epsilon", min_value=0.0)
    n_steps = check_int(n_steps, "n_steps", min_value=1)
    face_steps = check_int(face_steps, "face_steps", min_value=0)
    chunk_size = check_int(chunk_size, "chunk_size", min_value=1)
    coarse_stride = check_int(coarse_stride, "coarse_stride", min_value=1)
    coarse_top = check_int(coarse_top, "coarse_top", min_value=1)
    if lattice_points is not None:
        lattice_points = check_int(lattice_points, "lattice_points", min_value=1)
    X, lengths = pad_sequences(X, lengths, dim=phmms[0].local.dim)
    for k, phmm in enumerate(phmms):
        if phmm.local.dim != X.shape[-1] or phmm.n_params != phmms[0].n_params:
            raise ValueError(f"phmms[{k}]: differs in feature dimension or parameter count from phmms[0]")
        check_feasible(phmm.config, lengths)
        reach = extrapolation_factor(phmm.grid_shape, np.full((1, phmm.n_params), -epsilon))
        check_phmm_distances(phmm, X, lengths, reach, f"phmms[{k}]", "epsilon")
    X, lengths = to_device(X, lengths)
    lattice = lambda p: lattice_points or _default_lattice(p.grid_shape)  # noqa: E731
    if mesh is None:
        results = [search_parameters(p, X, lengths, epsilon, n_steps, lattice(p), face_steps, chunk_size, coarse_stride,
                                     coarse_top) for p in phmms]
    else:
        results = [map_batch(_search_shard, mesh, (p, epsilon, n_steps, face_steps), (X, lengths),
                             static=(("lattice_points", lattice(p)), ("chunk_size", chunk_size),
                                     ("coarse_stride", coarse_stride), ("coarse_top", coarse_top))) for p in phmms]
    phi = jnp.stack([r[0] for r in results], axis=1)
    loglik = jnp.stack([r[1] for r in results], axis=1)
    return Recognition(jnp.argmax(loglik, axis=1), phi, loglik)
