"""Movement synthesis from a PHMM and the mapping from target points to interpolation parameters.

Synthesis (PHMM §III-B2, BMVC §4.2): the state means of λ^φ, placed at the centres of the states'
expected durations, joined by a C¹ cubic Hermite spline (Catmull-Rom tangents) and resampled.
"""
from __future__ import annotations

import itertools
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from lfd_common import as_array, check_int, float_dtype
from phmm_jax._src.checks import HEADROOM, check_type, extrapolation_factor, mean_norm
from phmm_jax._src.model import expected_durations
from phmm_jax._src.parametric import PHMM, interpolate


def hermite_spline(knot_times: Float[Array, " K"], knots: Float[Array, "K D"],
                   query_times: Float[Array, " M"]) -> Float[Array, "M D"]:
    """C¹ cubic Hermite interpolation with Catmull-Rom (finite-difference) tangents.

    The spline `synthesize` joins the state means with (PHMM §III-B2). Pure jnp, no input checks.

    Args:
        knot_times: (K,) increasing times, K >= 2.
        knots: (K, D) the points at those times.
        query_times: (M,) where to evaluate.

    Returns:
        (M, D) the spline at `query_times`.
    """
    dt = jnp.diff(knot_times)
    slopes = jnp.diff(knots, axis=0) / dt[:, None]
    inner = (slopes[:-1] * dt[1:, None] + slopes[1:] * dt[:-1, None]) / (dt[:-1] + dt[1:])[:, None]
    tangents = jnp.concatenate([slopes[:1], inner, slopes[-1:]], axis=0)
    k = jnp.clip(jnp.searchsorted(knot_times, query_times, side="right") - 1, 0, knots.shape[0] - 2)
    h = dt[k]
    s = ((query_times - knot_times[k]) / h)[:, None]
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    return (h00 * knots[k] + h10 * h[:, None] * tangents[k] + h01 * knots[k + 1]
            + h11 * h[:, None] * tangents[k + 1])


@partial(jax.jit, static_argnames=("length",))
def _synthesize(phmm: PHMM, phi, length: int):
    hmm = interpolate(phmm, phi)
    if hmm.means.shape[0] == 1:  # one state: the mean movement stays at its mean
        return jnp.broadcast_to(hmm.means[0], (length, hmm.means.shape[1]))
    durations = expected_durations(hmm)
    centres = jnp.cumsum(durations) - 0.5 * durations
    query = jnp.linspace(centres[0], centres[-1], length)
    return hermite_spline(centres, hmm.means, query)


def synthesize(phmm: PHMM, phi: Float[ArrayLike, " d"] | Float[ArrayLike, "M d"], length: int = 100
               ) -> Float[Array, "length D"] | Float[Array, "M length D"]:
    """Synthesise the mean movement of parameter φ (PHMM §III-B2, §IV-A; BMVC §4.2).

    The state means of λ^φ are placed at the centres of the expected state durations and joined by
    a C¹ spline sampled at `length` equally spaced times from the first centre to the last (a
    one-state model gives its mean at every sample).

    Args:
        phmm: The PHMM.
        phi: (d,) one parameter, or (M, d) several. φ may leave [0, 1]^d (the means extrapolate).
        length: Samples of the movement, >= 2.

    Returns:
        (length, D) for φ (d,), or (M, length, D) for φ (M, d).

    Raises:
        ValueError: Naming `phmm` (not a PHMM), `length` (< 2) or `phi` (wrong shape, or so far
            outside [0, 1]^d that the means overflow the compute dtype).
    """
    check_type(phmm, "phmm", PHMM)
    length = check_int(length, "length", min_value=2)
    phi = as_array(phi, "phi", ndim=(1, 2))
    if phi.shape[-1] != phmm.n_params:
        raise ValueError(f"phi: expected {phmm.n_params} parameter(s), got shape {phi.shape}")
    extrapolated = extrapolation_factor(phmm.grid_shape, phi) * mean_norm(phmm.local.means, "phmm")
    limit = float(np.finfo(float_dtype()).max)
    if extrapolated > HEADROOM * limit:
        raise ValueError(f"phi: values up to {np.max(np.abs(phi)):.3g} extrapolate the means to |mean| up to "
                         f"{extrapolated:.3g}, beyond {np.dtype(float_dtype()).name} (max {limit:.3g})")
    phi = jnp.asarray(phi, phmm.local.means.dtype)
    if phi.ndim == 1:
        return _synthesize(phmm, phi, length)
    return jax.vmap(lambda p: _synthesize(phmm, p, length))(phi)


def multilinear_map(corner_targets: Float[Array, "*grid P"], phi: Float[Array, " d"]) -> Float[Array, " P"]:
    """The target point of parameter φ: d-linear interpolation of the corners' targets (PHMM eqs. 4–6).

    Pure jnp, differentiable in φ (linear extrapolation from the border cell outside [0, 1]^d), no
    input checks.

    Args:
        corner_targets: (g_1, ..., g_d, P) the target point of every grid corner.
        phi: (d,) the parameter.

    Returns:
        (P,) the interpolated target point.
    """
    grid_shape = corner_targets.shape[:-1]
    grid = jnp.asarray(grid_shape)
    scaled = phi * (grid - 1)
    lower = jnp.clip(jnp.floor(jax.lax.stop_gradient(scaled)), 0, grid - 2).astype(jnp.int32)
    frac = scaled - lower
    total = 0.0
    for offset in itertools.product((0, 1), repeat=len(grid_shape)):
        off = jnp.asarray(offset)
        weight = jnp.prod(jnp.where(off == 1, frac, 1.0 - frac))
        total = total + weight * corner_targets[tuple(lower + off)]
    return total


@partial(jax.jit, static_argnames=("n_iter",))
def _invert_multilinear(corner_targets, targets, phi0, n_iter: int):
    def solve(target, phi):
        def gauss_newton(phi, _):
            residual = multilinear_map(corner_targets, phi) - target
            jac = jax.jacfwd(multilinear_map, argnums=1)(corner_targets, phi)  # (P, d)
            step = jnp.linalg.lstsq(jac, residual)[0]
            return phi - step, None

        return jax.lax.scan(gauss_newton, phi, None, length=n_iter)[0]

    return jax.vmap(solve)(targets, phi0)


def target_to_phi(corner_targets: Float[ArrayLike, "*grid P"], targets: Float[ArrayLike, "M P"] | Float[ArrayLike, " P"],
                  n_iter: int = 10) -> Float[Array, "M d"] | Float[Array, " d"]:
    """Interpolation parameters φ whose interpolated target is closest to each target (PHMM §IV-A).

    For a rectangular, axis-aligned box this is eqs. 7–9 (the projection on each edge of the box,
    divided by its length: eqs. 7–9 as printed omit that division). For a warped grid, a
    least-squares inverse of the d-linear map (Gauss–Newton from the projection). φ may leave
    [0, 1] for targets outside the grid.

    Args:
        corner_targets: (g_1, ..., g_d, P) the target point of every grid corner (e.g. the
            table-top positions the local HMMs were trained on), 1 <= d <= 6.
        targets: (M, P) target points, or one (P,).
        n_iter: Gauss–Newton iterations, >= 0 (0: the projection alone).

    Returns:
        (M, d), or (d,) for one target.

    Raises:
        ValueError: Naming `corner_targets` (wrong rank, a grid axis with fewer than 2 corners, a
            degenerate grid whose outer corners coincide), `targets` (wrong shape, NaN/inf) or
            `n_iter`.
    """
    corner_targets = as_array(corner_targets, "corner_targets", ndim=range(2, 8))
    d = corner_targets.ndim - 1
    if any(g < 2 for g in corner_targets.shape[:-1]):
        raise ValueError(f"corner_targets: every grid axis needs at least 2 corners, got {corner_targets.shape[:-1]}")
    targets = as_array(targets, "targets", ndim=(1, 2))
    single = targets.ndim == 1
    targets = np.atleast_2d(targets)
    if targets.shape[-1] != corner_targets.shape[-1]:
        raise ValueError(f"targets: expected points of dimension {corner_targets.shape[-1]}, got {targets.shape[-1]}")
    origin = corner_targets[(0,) * d]
    edges = np.stack([corner_targets[tuple(-1 if k == a else 0 for k in range(d))] - origin for a in range(d)])
    lengths_sq = np.sum(edges**2, axis=1)
    if np.any(lengths_sq == 0):
        raise ValueError("corner_targets: the grid is degenerate (two outer corners coincide)")
    phi0 = (targets - origin) @ edges.T / lengths_sq  # eqs. 7-9 with the division by the edge length
    dtype = float_dtype()
    phi = _invert_multilinear(jnp.asarray(corner_targets, dtype), jnp.asarray(targets, dtype),
                              jnp.asarray(phi0, dtype), check_int(n_iter, "n_iter", min_value=0))
    return phi[0] if single else phi
