"""Gaussian emission log-densities for all states, by one batched whitening product."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.linalg import solve_triangular
from jaxtyping import Array, Float

# Frames per block of the whitening GEMM. The (block, N·D) product then stays in the CPU cache
# before it is squared and reduced; one unblocked product over all B·T frames spills to memory.
_BLOCK = 512
# Columns (frames x sequences) per product in the column layout: the (N·D, k·B) product then stays in
# the CPU cache, as above.
_COLUMNS = 1024


@jax.custom_vjp
def whitening(means, covariances):
    """Per-state whitening maps: W (N, D, D) with W Σ W^T = I, offsets W μ (N, D), log|Σ| (N,).

    Any leading batch axes are allowed. W = L^{-1} for the Cholesky factor L of Σ. The gradient is
    closed-form and uses W only (`_whitening_bwd`), instead of autodiff through LAPACK's batched
    Cholesky and triangular solve, one small matrix at a time (dear in PHMM recognition, which
    differentiates through per-sequence covariances).
    """
    chol = jnp.linalg.cholesky(covariances)
    eye = jnp.broadcast_to(jnp.eye(means.shape[-1], dtype=means.dtype), covariances.shape)
    inv_chol = solve_triangular(chol, eye, lower=True)
    log_det = 2.0 * jnp.sum(jnp.log(jnp.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
    return inv_chol, jnp.einsum("...ij,...j->...i", inv_chol, means), log_det


def _whitening_fwd(means, covariances):
    out = whitening(means, covariances)
    return out, (out[0], means)


def _whitening_bwd(residuals, cotangents):
    """Cotangents of (W, Wμ, log|Σ|) -> of (μ, Σ). With dL = L Φ(W dΣ W^T) (Φ: lower triangle, half
    diagonal) and dW = -W dL W: Σ̄ = W^T Φ(-W̄ W^T) W + ḡ_logdet Σ^{-1}, symmetrised; μ̄ = W^T ō."""
    inv_chol, means = residuals
    g_inv_chol, g_offsets, g_log_det = cotangents
    g_inv_chol = g_inv_chol + g_offsets[..., :, None] * means[..., None, :]
    transposed = jnp.swapaxes(inv_chol, -1, -2)
    eye = jnp.eye(inv_chol.shape[-1], dtype=inv_chol.dtype)
    inner = -g_inv_chol @ transposed
    inner = jnp.tril(inner) - 0.5 * eye * inner + g_log_det[..., None, None] * eye
    g_cov = transposed @ inner @ inv_chol
    g_cov = 0.5 * (g_cov + jnp.swapaxes(g_cov, -1, -2))
    return jnp.einsum("...ji,...j->...i", inv_chol, g_offsets), g_cov


whitening.defvjp(_whitening_fwd, _whitening_bwd)


def affine_whitening(means, covariances):
    """[W | -W μ] (N, D, D+1), so that z = W (x - μ) is one product with [x; 1], and the
    normalising constants D log 2π + log|Σ| (N,).

    Subtracting the offsets after the product instead would make the gradient with respect to them a
    reduction over frames, which XLA:CPU computes far slower than this product's own gradient (PHMM
    recognition differentiates through per-sequence means and covariances)."""
    inv_chol, offsets, log_det = whitening(means, covariances)
    dim = means.shape[-1]
    return jnp.concatenate([inv_chol, -offsets[..., None]], axis=-1), dim * jnp.log(2.0 * jnp.pi) + log_det


def with_ones(x, axis):
    """x with a row (axis=0) or column (axis=-1) of ones appended: the affine coordinate."""
    return jnp.concatenate([x, jnp.ones_like(jax.lax.slice_in_dim(x, 0, 1, axis=axis))], axis=axis)


def gaussian_log_density(X: Float[Array, "*batch D"], means: Float[Array, "N D"],
                         covariances: Float[Array, "N D D"]) -> Float[Array, "*batch N"]:
    """Gaussian emission log-densities log N(x | μ_i, Σ_i) of every frame under every state.

    The output densities b_i(x) of PHMM §III-A. All states are whitened by one matrix product
    [x 1] @ [A_1^T ... A_N^T] ((D+1) x N·D, A_i the affine whitening of state i), so the cost is one
    GEMM plus a reduction, whatever the batch shape; it runs over blocks of 512 frames. Pure jnp, no
    input checks.

    Args:
        X: (..., D) frames, any leading axes.
        means: (N, D) state means.
        covariances: (N, D, D) positive-definite state covariances.

    Returns:
        (..., N) log-densities.
    """
    affine, const = affine_whitening(means, covariances)
    n_states, dim = means.shape
    stacked = jnp.transpose(affine, (2, 0, 1)).reshape(dim + 1, n_states * dim)  # (D+1, N·D)

    def block_density(x):
        z = (with_ones(x, -1) @ stacked).reshape(x.shape[0], n_states, dim)
        return -0.5 * (const + jnp.sum(z * z, axis=-1))

    rows = X.reshape(-1, dim)
    n_rows = rows.shape[0]
    block = max(1, min(_BLOCK, n_rows))
    n_blocks = -(-n_rows // block)
    padded = jnp.pad(rows, ((0, n_blocks * block - n_rows), (0, 0))).reshape(n_blocks, block, dim)
    out = jax.lax.map(block_density, padded).reshape(n_blocks * block, n_states)[:n_rows]
    return out.reshape(X.shape[:-1] + (n_states,))


def gaussian_log_density_columns(X: Float[Array, "B T D"], means: Float[Array, "N D"],
                                 covariances: Float[Array, "N D D"],
                                 reachable: tuple[np.ndarray, np.ndarray] | None = None) -> Float[Array, "T N B"]:
    """`gaussian_log_density` of a padded batch in the column layout (T, N, B) of the forward pass.

    Frames are taken k at a time (k·B about 1024 columns): one product [A_1; ...; A_N]
    (N·D x D+1) @ [x; 1] (D+1 x k·B) per block, and the sum of squares runs over rows, so every
    operation is a contiguous vector operation over the batch. Several frames per product amortise
    the loop's per-iteration cost over more work than one frame per product (k = 1) would. Pure
    jnp, no input checks.

    Args:
        X: (B, T, D) padded sequences.
        means: (N, D) state means.
        covariances: (N, D, D) positive-definite state covariances.
        reachable: None, or (first, last), each (T,) numpy int: the only states whose densities
            are needed at each frame (the states a path can be in then); a block then multiplies
            only the rows of its states, and every other state gets -inf. With durations 4-6 a
            block of frames needs at most 10 of 20 states.

    Returns:
        (T, N, B) log-densities (-inf outside `reachable`).
    """
    affine, const = affine_whitening(means, covariances)
    n_states, dim = means.shape
    stacked = affine.reshape(n_states * dim, dim + 1)
    batch, n_frames = X.shape[:2]
    per_block = max(1, min(n_frames, -(-_COLUMNS // batch)))
    n_blocks = -(-n_frames // per_block)
    X = jnp.pad(X, ((0, 0), (0, n_blocks * per_block - n_frames), (0, 0)))
    columns = jnp.transpose(X.reshape(batch, n_blocks, per_block, dim), (1, 3, 2, 0))  # (blocks, D, k, B)
    starts, width = _state_windows(reachable, n_states, n_blocks, per_block)

    def block_density(inputs):  # (D, k, B) -> (k, N, B)
        x, start = inputs
        rows = jax.lax.dynamic_slice_in_dim(stacked, start * dim, width * dim)
        z = (rows @ with_ones(x.reshape(dim, -1), 0)).reshape(width, dim, -1)
        out = -0.5 * (jax.lax.dynamic_slice_in_dim(const, start, width)[:, None] + jnp.sum(z * z, axis=1))
        if width < n_states:
            out = jax.lax.dynamic_update_slice_in_dim(jnp.full((n_states, out.shape[-1]), -jnp.inf, out.dtype),
                                                      out, start, axis=0)
        return jnp.transpose(out.reshape(n_states, per_block, batch), (1, 0, 2))

    out = jax.lax.map(block_density, (columns, jnp.asarray(starts)))
    return out.reshape(n_blocks * per_block, n_states, batch)[:n_frames]


def _state_windows(reachable, n_states: int, n_blocks: int, per_block: int):
    """(first state (blocks,) numpy int, static width) of the states each block of frames needs."""
    if reachable is None:
        return np.zeros(n_blocks, np.int32), n_states
    padding = n_blocks * per_block - len(reachable[0])
    first, last = (np.pad(np.asarray(a), (0, padding), mode="edge").reshape(n_blocks, per_block) for a in reachable)
    low, high = first.min(axis=1), last.max(axis=1)
    width = int(np.max(high - low + 1))
    return np.minimum(low, n_states - width).astype(np.int32), width


def stacked_log_density_columns(X: Float[Array, "B T D"], means: Float[Array, "B N D"],
                                covariances: Float[Array, "B N D D"],
                                reachable: tuple[np.ndarray, np.ndarray] | None = None) -> Float[Array, "T N B"]:
    """Gaussian log-densities log N(x_bt | μ_bi, Σ_bi) with one model per sequence, column layout.

    Per sequence one product [A_b1; ...; A_bN] (N·D x D+1) @ [X_b^T; 1] (D+1 x T): the batched GEMM
    needs no transposes of the (B, N, D, D+1) maps, forwards or backwards (PHMM recognition, eq. 3,
    where every sequence has its own interpolated model). Pure jnp, no input checks.

    Args:
        X: (B, T, D) padded sequences.
        means: (B, N, D) each sequence's state means.
        covariances: (B, N, D, D) each sequence's positive-definite state covariances.
        reachable: None, or (first, last), each (T,) numpy int (the states a path can be in at each
            frame): the frames then go in 4 blocks, each multiplying only the rows of the states its
            frames can be in, and every other state gets -inf (as in
            `gaussian_log_density_columns`).

    Returns:
        (T, N, B) log-densities.
    """
    return affine_log_density_columns(X, *affine_whitening(means, covariances), reachable)


def affine_log_density_columns(X: Float[Array, "B T D"], affine: Float[Array, "B N D D+1"], const: Float[Array, "B N"],
                               reachable: tuple[np.ndarray, np.ndarray] | None = None) -> Float[Array, "T N B"]:
    """`stacked_log_density_columns` from each sequence's affine whitening maps and normalising
    constants, computed beforehand (`affine_whitening`; PHMM recognition whitens each lattice
    point's model once and gathers it for every sequence that scores that point). Pure jnp, no
    input checks.

    Args:
        X: (B, T, D) padded sequences.
        affine: (B, N, D, D+1) each sequence's [W | -W μ] per state.
        const: (B, N) each sequence's D log 2π + log|Σ| per state.
        reachable: None, or (first, last) as in `stacked_log_density_columns`.

    Returns:
        (T, N, B) log-densities.
    """
    batch, n_states, dim = affine.shape[:3]
    stacked = affine.reshape(batch, n_states * dim, dim + 1)
    augmented = with_ones(jnp.swapaxes(X, 1, 2), 1)  # (B, D+1, T)
    blocks = []
    for (t0, t1), (s0, s1) in _stacked_blocks(reachable, n_states, X.shape[1]):
        z = stacked[:, s0 * dim:s1 * dim] @ augmented[:, :, t0:t1]  # (B, W·D, k)
        squares = jnp.sum(jnp.square(z.reshape(batch, s1 - s0, dim, -1)), axis=2)  # (B, W, k)
        block = jnp.transpose(-0.5 * (const[:, s0:s1, None] + squares), (2, 1, 0))  # (k, W, B)
        blocks.append(jnp.pad(block, ((0, 0), (s0, n_states - s1), (0, 0)), constant_values=-jnp.inf))
    return blocks[0] if len(blocks) == 1 else jnp.concatenate(blocks, axis=0)


# Blocks of frames in `stacked_log_density_columns`: fewer blocks multiply more unreachable rows, more
# blocks cost more small products. 4 was fastest for the PHMM search's gradient on the `bench_hmm`
# workload (T = 100, N = 20, durations 4-6; 2-core CPU); 3-6 were within 5 %.
_STACKED_BLOCKS = 4


def _stacked_blocks(reachable, n_states: int, n_frames: int) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Static ((first frame, end frame), (first state, end state)) of each block of frames."""
    if reachable is None:
        return [((0, n_frames), (0, n_states))]
    first, last = (np.asarray(a) for a in reachable)
    size = -(-n_frames // _STACKED_BLOCKS)
    return [((t0, min(n_frames, t0 + size)), (int(first[t0:t0 + size].min()), int(last[t0:t0 + size].max()) + 1))
            for t0 in range(0, n_frames, size)]
