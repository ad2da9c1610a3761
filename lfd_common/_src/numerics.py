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


def float_dtype() -> np.dtype:
    """The floating dtype JAX computes in now: float32, or float64 when `jax_enable_x64` is on."""
    return np.dtype(jnp.result_type(float))


def safe_log(p: jax.Array) -> jax.Array:
    """log p for p >= 0, with log 0 = -inf and a zero (not NaN) gradient there."""
    positive = p != 0
    return jnp.where(positive, jnp.log(jnp.where(positive, p, 1.0)), NEG_INF)


def safe_logsumexp(a: jax.Array, axis: int = -1) -> jax.Array:
    """log Σ exp(a) along `axis`; -inf with a zero gradient for an all -inf slice."""
    peak = jnp.max(a, axis=axis, keepdims=True)
    peak = jax.lax.stop_gradient(jnp.where(jnp.isfinite(peak), peak, 0.0))
    total = jnp.sum(jnp.exp(a - peak), axis=axis, keepdims=True)
    return jnp.squeeze(safe_log(total) + peak, axis=axis)


def safe_logaddexp(a: jax.Array, b: jax.Array) -> jax.Array:
    """Elementwise log(exp(a) + exp(b)); -inf with zero gradients where both are -inf.

    Written elementwise rather than as a reduction over a stacked axis, so XLA fuses it into one loop.
    """
    peak = jax.lax.stop_gradient(jnp.maximum(a, b))
    peak = jnp.where(jnp.isfinite(peak), peak, 0.0)
    return safe_log(jnp.exp(a - peak) + jnp.exp(b - peak)) + peak


def solve_spd(matrix, rhs):
    """x with M x = r for symmetric positive-definite M (..., d, d) and r (..., d), by a Cholesky
    factorisation unrolled over the static, small d (elementwise over the batch): no LAPACK call, so
    none of the batched custom calls that deadlock XLA:CPU (README, Known problems). Used by the PHMM
    search (its Newton steps) and `sim`'s inverse kinematics (the 6 x 6 damped least-squares system)."""
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
