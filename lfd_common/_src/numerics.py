"""Log-space numerics shared by the model libraries, and the compute dtype.

Every probability is kept in log space, and -inf (log 0) is a legitimate value: forbidden transitions,
unreachable states, padded frames. `jax.nn.logsumexp` and `jnp.log` give NaN *gradients* at those
points (log 0 -> inf * 0; dynamax issue #99), so these versions use the double-`where` pattern: the
unsafe operation only ever sees a safe stand-in value, and the result is selected afterwards. NaN in
the input stays NaN in the output (it is never silently turned into -inf).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

NEG_INF = -jnp.inf
"""log 0: forbidden transitions, unreachable states and padded frames in log space."""


def float_dtype() -> np.dtype:
    """The floating dtype JAX computes in now.

    Returns:
        float32, or float64 when `jax_enable_x64` is on.
    """
    return np.dtype(jnp.result_type(float))


def safe_log(p: jax.Array) -> jax.Array:
    """log p for p >= 0, with log 0 = -inf and a zero (not NaN) gradient there.

    Args:
        p: Non-negative values, any shape.

    Returns:
        log p, the same shape.
    """
    positive = p != 0
    return jnp.where(positive, jnp.log(jnp.where(positive, p, 1.0)), NEG_INF)


def safe_logsumexp(a: jax.Array, axis: int = -1) -> jax.Array:
    """log Σ exp(a) along `axis`; -inf with a zero gradient for an all -inf slice.

    Args:
        a: Log-values, any shape; -inf allowed.
        axis: The axis to reduce.

    Returns:
        `a`'s shape without `axis`.
    """
    peak = jnp.max(a, axis=axis, keepdims=True)
    peak = jax.lax.stop_gradient(jnp.where(jnp.isfinite(peak), peak, 0.0))
    total = jnp.sum(jnp.exp(a - peak), axis=axis, keepdims=True)
    return jnp.squeeze(safe_log(total) + peak, axis=axis)


def safe_logaddexp(a: jax.Array, b: jax.Array) -> jax.Array:
    """Elementwise log(exp(a) + exp(b)); -inf with zero gradients where both are -inf.

    Written elementwise rather than as a reduction over a stacked axis, so XLA fuses it into one loop.

    Args:
        a: Log-values.
        b: Log-values, broadcastable with `a`.

    Returns:
        The broadcast shape of `a` and `b`.
    """
    peak = jax.lax.stop_gradient(jnp.maximum(a, b))
    peak = jnp.where(jnp.isfinite(peak), peak, 0.0)
    return safe_log(jnp.exp(a - peak) + jnp.exp(b - peak)) + peak


def solve_spd(matrix: jax.Array, rhs: jax.Array) -> jax.Array:
    """Solve M x = r for symmetric positive-definite M by an unrolled Cholesky factorisation.

    The factorisation is unrolled over the static, small d (elementwise over the batch): no LAPACK
    call, so none of the batched custom calls that deadlock XLA:CPU (see Known problems in the
    docs). Used by the PHMM search (its Newton steps, PHMM eq. 3) and `sim`'s inverse kinematics
    (the 6 x 6 damped least-squares system). No checks: M must be positive definite.

    Args:
        matrix: (..., d, d) M.
        rhs: (..., d) r.

    Returns:
        (..., d) x.
    """
    d = matrix.shape[-1]
    low = [[None] * d for _ in range(d)]
    for j in range(d):
        low[j][j] = jnp.sqrt(matrix[..., j, j] - sum(low[j][k] ** 2 for k in range(j)))
        for i in range(j + 1, d):
            low[i][j] = (matrix[..., i, j] - sum(low[i][k] * low[j][k] for k in range(j))) / low[j][j]
    y = []
    for i in range(d):
        y.append((rhs[..., i] - sum(low[i][k] * y[k] for k in range(i))) / low[i][i])
    x = [None] * d
    for i in reversed(range(d)):
        x[i] = (y[i] - sum(low[k][i] * x[k] for k in range(i + 1, d))) / low[i][i]
    return jnp.stack(x, axis=-1)
