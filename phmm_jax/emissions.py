"""Gaussian emission log-densities for all states in one batched triangular whitening."""
from __future__ import annotations

import jax
import jax.numpy as jnp
from jax.scipy.linalg import solve_triangular

# Frames per block of the whitening GEMM. The (block, N·D) product then stays in the CPU cache
# before it is squared and reduced; one unblocked product over B·T = 28,000 frames spilled to
# memory and took 3x longer (30 vs 9.5 ms for N = 20, D = 21 on 2 cores).
_BLOCK = 512


def whitening(means, covariances):
    """Per-state whitening maps: W (N, D, D) with W Σ W^T = I, offsets W μ (N, D), log|Σ| (N,)."""
    chol = jnp.linalg.cholesky(covariances)
    eye = jnp.broadcast_to(jnp.eye(means.shape[-1], dtype=means.dtype), covariances.shape)
    inv_chol = solve_triangular(chol, eye, lower=True)
    log_det = 2.0 * jnp.sum(jnp.log(jnp.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
    return inv_chol, jnp.einsum("nij,nj->ni", inv_chol, means), log_det


def gaussian_log_density(X, means, covariances):
    """log N(x_t | μ_i, Σ_i) for every frame and state: X (..., D) -> (..., N).

    All states are whitened by one matrix product X @ [W_1^T ... W_N^T] (D x N·D), so the cost is
    one GEMM plus a reduction, whatever the batch shape; it runs over blocks of `_BLOCK` frames.
    """
    inv_chol, offsets, log_det = whitening(means, covariances)
    n_states, dim = means.shape
    stacked = jnp.transpose(inv_chol, (2, 0, 1)).reshape(dim, n_states * dim)  # (D, N·D)
    const = dim * jnp.log(2.0 * jnp.pi) + log_det

    def block_density(x):
        z = (x @ stacked).reshape(x.shape[0], n_states, dim) - offsets
        return -0.5 * (const + jnp.sum(z * z, axis=-1))

    rows = X.reshape(-1, dim)
    n_rows = rows.shape[0]
    block = max(1, min(_BLOCK, n_rows))
    n_blocks = -(-n_rows // block)
    padded = jnp.pad(rows, ((0, n_blocks * block - n_rows), (0, 0))).reshape(n_blocks, block, dim)
    out = jax.lax.map(block_density, padded).reshape(n_blocks * block, n_states)[:n_rows]
    return out.reshape(X.shape[:-1] + (n_states,))
