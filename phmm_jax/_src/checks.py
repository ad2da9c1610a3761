"""Boundary checks of the public functions, in numpy outside jitted code: argument types, model
validity, values that fit the compute dtype but would overflow inside a computation, and fitted
models that came out singular.

`lfd_common.pad_sequences` rejects values that overflow the compute dtype themselves. What it cannot
see depends on the model: a log-likelihood is a sum over frames of squared whitened distances
|W(x - μ)|², so data far from the means (X·1e20 under a model of unit-scale data), means extrapolated
far outside the grid (a PHMM at φ = 1e30) or second moments of huge data (an EM fit of X·1e20)
overflow float32 although every input is finite. The bounds here are norm inequalities (the largest
|x| and |μ|, the smallest covariance eigenvalue), loose by design and O(N·D³) on the host per call;
where one fails for an HMM, the exact largest whitened distance of every frame decides (numpy,
float64), so only data that really overflow are rejected, at scales far beyond any sensible one.
"""
from __future__ import annotations

import math
import weakref

import jax
import numpy as np

from lfd_common import check_int, float_dtype
from phmm_jax._src.model import HMM, allowed_transitions

# Continue + exit probabilities of a reachable pseudo-state must sum to 1 within this (float32 round-off).
_NORMALISATION_TOL = 1e-4
# Share of the compute dtype's range a checked quantity may use: forward + backward messages and the
# log-sum-exp intermediates are a few times the log-likelihood, gradients a few times the distances.
HEADROOM = 1e-3
# reg_covar = 0: a variance (correlation eigenvalue) within this many ulps of the data's magnitude
# is round-off, i.e. the maximum-likelihood covariance is singular.
_SINGULAR_ULPS = 10
# Model checks remembered per jax array (see `_memo`).
_MEMO: dict = {}
_MEMO_SIZE = 64


def check_type(value, name: str, cls: type, what: str | None = None):
    """`value` if it is a `cls`, else `ValueError` naming the argument."""
    if not isinstance(value, cls):
        raise ValueError(f"{name}: expected {what or 'a phmm_jax.' + cls.__name__}, got {type(value).__name__}")
    return value


def check_grid_shape(grid_shape, name: str = "grid_shape") -> tuple[int, ...]:
    """(g_1, ..., g_d) as a tuple of ints >= 2 (a list is accepted), else `ValueError` naming it."""
    if not isinstance(grid_shape, (tuple, list)) or len(grid_shape) == 0:
        raise ValueError(f"{name}: expected a non-empty tuple of grid sizes (g_1, ..., g_d), got {grid_shape!r}")
    return tuple(check_int(g, name, min_value=2) for g in grid_shape)


def _limit() -> float:
    return float(np.finfo(float_dtype()).max)


def _memo(kind: str, array, compute):
    """`compute()`, computed once per jax array (immutable; identified by id, held weakly), so that
    repeated calls with one model do not pay the O(N·D³) checks again."""
    if not isinstance(array, jax.Array):
        return compute()
    key = (kind, id(array), np.dtype(float_dtype()).name)
    hit = _MEMO.get(key)
    if hit is not None and hit[0]() is array:
        return hit[1]
    value = compute()
    try:
        ref = weakref.ref(array)
    except TypeError:
        return value
    if len(_MEMO) >= _MEMO_SIZE:
        _MEMO.clear()
    _MEMO[key] = (ref, value)
    return value


def _eigen_range(covariances) -> tuple[str, float, float]:
    cov = np.asarray(covariances)
    if not np.all(np.isfinite(cov)):
        return "nonfinite", math.nan, math.nan
    eig = np.linalg.eigvalsh(cov.astype(np.float64))
    low, high = float(eig.min()), float(eig.max())
    if low <= 0:
        return "indefinite", low, high
    try:
        np.linalg.cholesky(cov.astype(float_dtype()))
    except np.linalg.LinAlgError:
        return "singular", low, high
    return "ok", low, high


def covariance_range(covariances, name: str) -> tuple[float, float]:
    """(smallest, largest) eigenvalue of all covariances (any leading axes), or `ValueError` naming
    `name` unless every one is finite and positive definite, also in the compute dtype (where the
    kernels factor it)."""
    status, low, high = _memo("covariances", covariances, lambda: _eigen_range(covariances))
    if status == "nonfinite":
        raise ValueError(f"{name}: covariances contain NaN or infinite values")
    if status == "indefinite":
        raise ValueError(f"{name}: covariances are not positive definite (smallest eigenvalue {low:.3g})")
    if status == "singular":
        raise ValueError(f"{name}: covariances are numerically singular in {np.dtype(float_dtype()).name} "
                         f"(eigenvalues {low:.3g} to {high:.3g})")
    return low, high


def mean_norm(means, name: str) -> float:
    """The largest |μ| over all states (any leading axes); `ValueError` naming `name` if not finite."""
    norm = _memo("means", means, lambda: float(np.max(np.linalg.norm(np.asarray(means, np.float64), axis=-1))))
    if not math.isfinite(norm):
        raise ValueError(f"{name}: means contain NaN or infinite values")
    return norm


def model_bounds(hmm: HMM, name: str = "hmm") -> tuple[float, float]:
    """(largest |μ|, smallest covariance eigenvalue) of a model the kernels can evaluate."""
    return mean_norm(hmm.means, name), covariance_range(hmm.covariances, name)[0]


def extrapolation_factor(grid_shape: tuple[int, ...], phi: np.ndarray) -> float:
    """max over rows of Σ_c |w_c(φ)|: the d-linear weights of `parametric.cell_weights` (1 inside
    [0, 1]^d), so that |μ(φ)| <= factor · max_c |μ_c| for means extrapolated from the border cell."""
    grid = np.asarray(grid_shape, np.float64)
    scaled = np.asarray(phi, np.float64) * (grid - 1)
    frac = scaled - np.clip(np.floor(scaled), 0, grid - 2)
    return float(np.max(np.prod(np.abs(frac) + np.abs(1.0 - frac), axis=-1)))


def check_distances(X: np.ndarray, lengths: np.ndarray, mean_bound: float, min_eig: float, *, name: str = "X",
                    model_name: str = "hmm", differentiable: bool = False, grid: int = 1,
                    blame: str | None = None, exact=None) -> None:
    """`ValueError` if the log-likelihood of padded X (B, T, D) could overflow the compute dtype.

    Per frame |W(x - μ)|² <= (√D max|x| + mean_bound)² / min_eig; the sum over a sequence must fit
    the dtype with `HEADROOM` to spare. `differentiable` (gradients in φ, squared by Adam) also
    requires the per-frame distance times the grid size to fit the square root of the range. When
    this loose bound fails and `exact` is given (a function returning the exact largest squared
    whitened distance of every frame (B, T) over the states, `max_whitened_distances`), the same
    test is made on the exact values, so only data that really overflow are rejected. The message
    names `blame` if given, else `name` when the data dominate the bound, `model_name` when the
    means do.
    """
    limit = _limit()
    x_max = float(np.max(np.abs(X))) if X.size else 0.0
    x_norm = math.sqrt(X.shape[-1]) * x_max
    per_frame = (x_norm + mean_bound) ** 2 / min_eig
    total = 0.5 * float(np.max(lengths)) * per_frame

    def fits(total, per_frame):
        return total <= HEADROOM * limit and (not differentiable or per_frame * grid <= HEADROOM * math.sqrt(limit))

    if fits(total, per_frame):
        return
    # The kernels compute W x - W μ: the terms themselves must fit, whatever their difference.
    if exact is not None and (x_norm + mean_bound) / math.sqrt(min_eig) <= HEADROOM * limit:
        distances = np.where(np.arange(X.shape[1])[None] < np.asarray(lengths)[:, None], exact(), 0.0)
        per_frame = float(np.max(distances))
        if fits(0.5 * float(np.max(np.sum(distances, axis=1))), per_frame):
            return
    culprit = blame or (name if x_norm >= mean_bound else model_name)
    raise ValueError(
        f"{culprit}: the data lie too far from the model's means for {np.dtype(float_dtype()).name}: squared "
        f"whitened distances up to {per_frame:.3g} per frame (|x| up to {x_max:.3g}, |mean| up to "
        f"{mean_bound:.3g}, smallest covariance eigenvalue {min_eig:.3g}) overflow the log-likelihood; "
        "rescale the data")


def max_whitened_distances(X: np.ndarray, means, covariances) -> np.ndarray:
    """(B, T) max over states i of |L_i^{-1}(x_bt - μ_i)|², in float64 (one state at a time, so the
    memory is that of X)."""
    X = np.asarray(X, np.float64)
    means = np.asarray(means, np.float64)
    inv_chol = np.linalg.inv(np.linalg.cholesky(np.asarray(covariances, np.float64)))
    out = np.zeros(X.shape[:-1])
    for mean, w in zip(means, inv_chol):
        z = (X - mean) @ w.T
        out = np.maximum(out, np.sum(z * z, axis=-1))
    return out


def check_fit_scale(X: np.ndarray, lengths: np.ndarray, name: str = "X") -> None:
    """`ValueError` if the covariance estimates of padded X (…, T, D) could overflow: the second
    moments sum (2 √D max|x|)² over every frame."""
    x_max = float(np.max(np.abs(X))) if X.size else 0.0
    moments = float(np.sum(lengths)) * (2.0 * math.sqrt(X.shape[-1]) * x_max) ** 2
    if moments > HEADROOM * _limit():
        raise ValueError(
            f"{name}: values up to {x_max:.3g} overflow {np.dtype(float_dtype()).name} in the covariance "
            f"estimates (second moments up to {moments:.3g}); rescale the data")


def _round_off_singular(covariances: np.ndarray, feature_scale: np.ndarray) -> bool:
    """Whether a covariance is singular up to round-off: a variance within `_SINGULAR_ULPS` ulps of
    its feature's magnitude (a constant feature; a state of one frame), or a correlation matrix with
    an eigenvalue that small (collinear features)."""
    cov = np.asarray(covariances, np.float64)
    dim = cov.shape[-1]
    tol = _SINGULAR_ULPS * dim * float(np.finfo(float_dtype()).eps)
    var = np.diagonal(cov, axis1=-2, axis2=-1)
    if np.any(var <= (tol * np.asarray(feature_scale, np.float64)) ** 2):
        return True
    std = np.sqrt(var)
    corr = cov / (std[..., :, None] * std[..., None, :])
    return bool(np.min(np.linalg.eigvalsh(corr)) <= tol)


def check_fitted(hmm: HMM, reg_covar: float, feature_scale, name: str = "X") -> None:
    """After a fit: `ValueError` unless the model (any leading axes) is finite and its covariances
    positive definite in the compute dtype; with `reg_covar = 0` also unless no covariance is
    singular up to round-off (`feature_scale` (D,): max |x| per feature of the training data).

    reg_covar = 0 is pure maximum likelihood: a constant feature, collinear features or a state of
    at most D frames then has a singular covariance (an unbounded likelihood); that is reported
    naming `reg_covar`, never returned as a NaN model. Otherwise the message names `name`.
    """
    bad = not all(np.all(~np.isnan(np.asarray(a))) for a in (hmm.log_cont, hmm.log_exit))
    if not bad:
        try:
            mean_norm(hmm.means, name)
            covariance_range(hmm.covariances, name)
        except ValueError:
            bad = True
    if not bad and reg_covar == 0:
        bad = _round_off_singular(hmm.covariances, feature_scale)
    if bad and reg_covar == 0:
        raise ValueError("reg_covar: with reg_covar=0 a state's covariance is singular (a constant feature, "
                         "collinear features or a state of at most D frames); use reg_covar > 0 "
                         "(the default 1e-4 floors every variance)")
    if bad:
        raise ValueError(f"{name}: the fit gave a non-finite or singular model: a covariance is singular in "
                         f"{np.dtype(float_dtype()).name} despite reg_covar={reg_covar:g} (features collinear or "
                         "constant at the data's scale); raise reg_covar or rescale the data")


def _reachable(config, cont: np.ndarray, exits: np.ndarray) -> np.ndarray:
    """(..., N, P) bool: pseudo-states some path from the start (0, 0) can be on."""
    reach = np.zeros(cont.shape, bool)
    entered = np.ones(cont.shape[:-2], bool)
    for i in range(config.n_states):
        reach[..., i, 0] = entered
        for j in range(1, config.n_pseudo):
            reach[..., i, j] = reach[..., i, j - 1] & (cont[..., i, j - 1] > 0)
        entered = np.any(reach[..., i, :] & (exits[..., i, :] > 0), axis=-1)
    return reach


def check_hmm(hmm: HMM) -> None:
    """Raise `ValueError` unless `hmm`'s arrays (any leading axes) are a valid model of its structure.

    Covariances symmetric positive definite (diagonal for covariance_type "diag"); transitions the
    structure forbids exactly -inf (`model.allowed_transitions`); on every pseudo-state a path can
    reach, continue + exit probabilities sum to 1; and some path can end (exit the last state).
    """
    config = hmm.config
    means = np.asarray(hmm.means, np.float64)
    if means.ndim < 2 or means.shape[-2] != config.n_states:
        raise ValueError(f"means: expected shape (..., {config.n_states}, D), got {means.shape}")
    if not np.all(np.isfinite(means)):
        raise ValueError("means: contain NaN or infinite values")
    cov = np.asarray(hmm.covariances, np.float64)
    if cov.shape != means.shape + means.shape[-1:]:
        raise ValueError(f"covariances: expected shape {means.shape + means.shape[-1:]}, got {cov.shape}")
    if not np.all(np.isfinite(cov)):
        raise ValueError("covariances: contain NaN or infinite values")
    if not np.allclose(cov, np.swapaxes(cov, -1, -2), rtol=1e-5, atol=1e-8):
        raise ValueError("covariances: not symmetric")
    if config.covariance_type == "diag" and np.any(cov * (1 - np.eye(cov.shape[-1])) != 0):
        raise ValueError('covariances: covariance_type "diag" but off-diagonal entries are not zero')
    if cov.size and np.min(np.linalg.eigvalsh(cov)) <= 0:
        raise ValueError("covariances: not positive definite (an eigenvalue <= 0)")
    try:  # what the kernels factor: the covariances in the compute dtype
        np.linalg.cholesky(np.asarray(hmm.covariances).astype(float_dtype()))
    except np.linalg.LinAlgError:
        raise ValueError(f"covariances: numerically singular in {np.dtype(float_dtype()).name}") from None
    log_cont, log_exit = np.asarray(hmm.log_cont, np.float64), np.asarray(hmm.log_exit, np.float64)
    may_continue, may_exit = allowed_transitions(config)
    for name, values, allowed in (("log_cont", log_cont, may_continue), ("log_exit", log_exit, may_exit)):
        if values.shape[-2:] != (config.n_states, config.n_pseudo):
            raise ValueError(f"{name}: expected shape (..., {config.n_states}, {config.n_pseudo}), got {values.shape}")
        bad = np.any(np.isnan(values)) or np.any(values > _NORMALISATION_TOL)
        if bad or np.any(np.isfinite(values[..., ~allowed])):
            raise ValueError(f"{name}: log-probabilities must be <= 0 and -inf where the structure forbids them")
    cont, exits = np.exp(log_cont), np.exp(log_exit)
    reach = _reachable(config, cont, exits)
    total = cont + exits
    if np.any(reach & (np.abs(total - 1.0) > _NORMALISATION_TOL)):
        raise ValueError("log_cont, log_exit: continue and exit probabilities of a pseudo-state do not sum to 1")
    if not np.all(np.any(reach[..., -1, :] & (exits[..., -1, :] > 0), axis=-1)):
        raise ValueError("log_exit: no path can leave the last state, so every sequence has probability 0")
