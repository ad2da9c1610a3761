"""Linear-chain inference on log potentials (OAC eqs. 3-4, LfD eqs. 7-8): pure JAX, no validation.

`log_partition`, `forward`, `backward`, `forward_backward`, `marginals` and `constant_path_log_prob`
take unary (..., T, K) and length (...) with optional leading batch axes; `viterbi` and
`sequence_score` take one sequence (vmap them). All are jit/vmap/grad-friendly (dynamax style):
    unary  (T, K)  node log potentials (padding rows may hold anything finite),
    trans  (K, K)  log potentials of y_{t-1} = i -> y_t = j (-inf marks a forbidden transition),
    length ()      int, number of real frames (1 <= length <= T).
With score(y) = sum_t unary[t, y_t] + sum_{t>=1} trans[y_{t-1}, y_t], log P(y | x) = score(y) - log Z(x).

Padding never leaks into values or gradients: padded unary rows are replaced by 0 with a first
`where` before any arithmetic, and results are read at `length - 1` (second `where`/gather), so
`jax.grad` of a padded batch equals that of the unpadded one and is NaN-free.

Every quantity is a log potential / log message. The forward recursion's (K, K) contraction
logsumexp_i(alpha_i + trans_ij) is evaluated as m + c_j + log(exp(alpha - m) @ exp(trans - c)), with
m the row max of alpha and c_j the column max of trans: one small matmul per step instead of a
(B, K, K) logsumexp. If that loses precision anywhere (a reachable entry < 1e-30, i.e. potentials
spanning ~70 nats, as in a wild line-search step) the pass is redone with the exact logsumexp
(`lax.cond` on one flag per batch, free otherwise).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, ArrayLike, Float, Int, ScalarLike

from lfd_common import safe_log, safe_logsumexp


# shape aliases of the signatures below ("*batch": optional leading batch axes)
Unary = Float[Array, "*batch T K"]
Trans = Float[Array, "K K"]
Lengths = Int[ArrayLike, "*batch"]


class ForwardBackward(NamedTuple):
    log_alpha: Unary  # alpha_t(j): paths over y_{<=t} ending in y_t = j
    log_beta: Unary  # beta_t(i): paths over y_{>t} given y_t = i (0 on padding)
    log_z: Float[Array, "*batch"]  # log Z(x)


class Marginals(NamedTuple):
    node: Unary  # P(y_t = k | x), 0 on padding
    pair: Float[Array, "*batch T-1 K K"]  # P(y_t = i, y_{t+1} = j | x), 0 where t + 1 is padding


class ViterbiPath(NamedTuple):
    labels: Int[Array, " T"]  # most probable labelling, -1 on padding
    log_score: Float[Array, ""]  # its unnormalised log score


# ----------------------------------------------------------------------------------------------
# the max-shifted contraction and the message pass
# ----------------------------------------------------------------------------------------------
def _shifted_exp_trans(trans: Array) -> tuple[Array, Array]:
    """exp(trans - colmax) and colmax, so that every column of the matrix has max 1 (or is 0)."""
    cmax = jnp.max(trans, axis=0)
    cmax = lax.stop_gradient(jnp.where(jnp.isfinite(cmax), cmax, 0.0))
    return jnp.exp(trans - cmax[None, :]), cmax


_TINY = 1e-30  # below this the fast product has lost (almost) all precision: use the exact path


def _fast_vecmat(log_v: Array, trans: Array, exp_m: Array, mshift: Array) -> tuple[Array, Array]:
    """log(exp(log_v) @ exp(trans)) for log_v (B, K) by one max-shifted matmul, and a "lost" flag.

    The max of each row of log_v is factored out and trans was column-shifted (`_shifted_exp_trans`),
    so the contraction is one (B, K) x (K, K) product instead of a (B, K, K) logsumexp. `lost` is
    True if a reachable entry fell below 1e-30 (precision gone: extreme ranges of potentials, as in
    a wild line-search step); callers then redo the whole pass with `_exact_vecmat`.
    """
    m = jnp.max(log_v, axis=-1, keepdims=True)
    m = lax.stop_gradient(jnp.where(jnp.isfinite(m), m, 0.0))
    p = jnp.exp(log_v - m)
    s = p @ exp_m
    reach = (jnp.isfinite(log_v).astype(p.dtype) @ jnp.isfinite(trans).astype(p.dtype)) > 0
    return safe_log(s) + m + mshift, jnp.any(reach & (s < _TINY))


def _exact_vecmat(log_v: Array, trans: Array) -> Array:
    """log(exp(log_v) @ exp(trans)) by a (B, K, K) logsumexp."""
    return safe_logsumexp(log_v[..., :, None] + trans, axis=-2)


def _mask_rows(unary: Array, lengths: Array) -> Array:
    """First `where` of the double-where pattern: padded rows (B, T, K) become 0 before any arithmetic."""
    t = jnp.arange(unary.shape[-2])
    return jnp.where((t[None, :] < lengths[:, None])[..., None], unary, 0.0)


def _as_batch(unary: Array, length: Array):
    """(..., T, K), (...) -> (B, T, K), (B,) and a function restoring the leading shape."""
    lead = unary.shape[:-2]
    u = unary.reshape((-1,) + unary.shape[-2:])
    lens = jnp.broadcast_to(jnp.asarray(length, jnp.int32), lead).reshape(-1)

    def restore(x):
        return x.reshape(lead + x.shape[1:])

    return u, lens, restore


def _scan_messages(unary: Array, trans: Array) -> Array:
    """Log forward messages (B, T, K) of already-masked unary (B, T, K): fast pass, exact if needed."""
    xs = jnp.swapaxes(unary, 0, 1)  # (T, B, K)
    exp_m, mshift = _shifted_exp_trans(trans)

    def fast_step(carry, u):
        alpha, lost = carry
        new, l = _fast_vecmat(alpha, trans, exp_m, mshift)
        new = new + u
        return (new, lost | l), new

    (_, lost), rest = lax.scan(fast_step, (xs[0], jnp.bool_(False)), xs[1:])

    def exact(_):
        def step(alpha, u):
            new = _exact_vecmat(alpha, trans) + u
            return new, new

        return lax.scan(step, xs[0], xs[1:])[1]

    rest = lax.cond(lost, exact, lambda r: r, rest)
    return jnp.swapaxes(jnp.concatenate([xs[:1], rest], axis=0), 0, 1)


# ----------------------------------------------------------------------------------------------
# potential-level inference; unary (..., T, K), length (...) (leading batch axes optional)
# ----------------------------------------------------------------------------------------------
def forward(unary: Unary, trans: Trans, length: Lengths) -> Unary:
    """Log forward messages alpha (..., T, K): alpha_t(j) = log sum over y_{<t} of exp(score(y_{<=t})), y_t = j.

    Rows t >= length continue over zero potentials and are never read by the functions below.
    """
    u, lens, restore = _as_batch(unary, length)
    return restore(_scan_messages(_mask_rows(u, lens), trans))


def backward(unary: Unary, trans: Trans, length: Lengths) -> Unary:
    """Log backward messages beta (..., T, K): beta_t(i) = log sum over y_{>t} of exp(score(y_{>t}) | y_t = i).

    beta_{length-1} = 0 and rows t >= length are 0. Computed as the forward pass of the reversed
    real part of each sequence (padded rows moved in front, where they are zero potentials).
    """
    u, lens, restore = _as_batch(unary, length)
    u = _mask_rows(u, lens)
    T = u.shape[1]
    # index map that reverses the first `length` frames and keeps padding in place
    t = jnp.arange(T)[None, :]
    rev = jnp.where(t < lens[:, None], lens[:, None] - 1 - t, t)  # (B, T)
    u_rev = jnp.take_along_axis(u, rev[..., None], axis=1)
    # forward messages of the reversed sequence under trans.T: a_t(i) includes u at t; beta excludes it
    a_rev = _scan_messages(u_rev, trans.T) - u_rev
    beta = jnp.take_along_axis(a_rev, rev[..., None], axis=1)
    return restore(jnp.where((t < lens[:, None])[..., None], beta, 0.0))


def _assoc_log_partition(unary: Array, trans: Array, lengths: Array) -> Array:
    """log Z (B,) by a parallel prefix (associative) scan of (K, K) log-semiring matrices, O(log T) depth."""
    unary = _mask_rows(unary, lengths)
    mats = trans[None, None, :, :] + unary[:, 1:, None, :]  # (B, T-1, K, K): M_t[i, j] = trans[i, j] + u_t[j]

    def combine(a, b):  # log-semiring matrix product, batched over leading axes
        return safe_logsumexp(a[..., :, :, None] + b[..., None, :, :], axis=-2)

    prefix = lax.associative_scan(combine, mats, axis=1)  # (B, T-1, K, K)
    alphas = safe_logsumexp(unary[:, :1, :, None] + prefix, axis=-2)  # (B, T-1, K)
    alphas = jnp.concatenate([unary[:, :1], alphas], axis=1)
    return safe_logsumexp(_at_last(alphas, lengths))


def _at_last(x: Array, lengths: Array) -> Array:
    """x[b, lengths[b] - 1] for x (B, T, ...) (the second half of the double-where pattern)."""
    idx = (lengths - 1).reshape((-1,) + (1,) * (x.ndim - 1))
    return jnp.take_along_axis(x, idx, axis=1)[:, 0]


def log_partition(unary: Unary, trans: Trans, length: Lengths, method: str = "scan") -> Float[Array, "*batch"]:
    """log Z(x) (...) by the forward algorithm.

    method: "scan" (sequential `lax.scan`, O(T K^2) work) or "assoc" (`lax.associative_scan`,
    O(T K^3) work but O(log T) depth: for long sequences on parallel hardware).
    """
    u, lens, restore = _as_batch(unary, length)
    if method == "assoc":
        return restore(_assoc_log_partition(u, trans, lens))
    if method != "scan":
        raise ValueError(f"method: expected 'scan' or 'assoc', got {method!r}")
    alpha = _scan_messages(_mask_rows(u, lens), trans)
    return restore(safe_logsumexp(_at_last(alpha, lens)))


def forward_backward(unary: Unary, trans: Trans, length: Lengths) -> ForwardBackward:
    """ForwardBackward(log_alpha (..., T, K), log_beta (..., T, K), log_z (...))."""
    u, lens, restore = _as_batch(unary, length)
    alpha = _scan_messages(_mask_rows(u, lens), trans)
    beta = backward(u, trans, lens)
    return ForwardBackward(restore(alpha), restore(beta), restore(safe_logsumexp(_at_last(alpha, lens))))


def marginals(unary: Unary, trans: Trans, length: Lengths) -> Marginals:
    """Posterior marginals: node (..., T, K) P(y_t = k | x), pair (..., T-1, K, K) P(y_t = i, y_{t+1} = j | x).

    Rows for padded frames (and pairs reaching into padding) are exactly 0; every real frame's node
    row and pair matrix sums to 1 (normalised per frame in log space, so also for huge potentials).
    """
    u, lens, restore = _as_batch(unary, length)
    alpha, beta, _ = forward_backward(u, trans, lens)
    u = _mask_rows(u, lens)
    t = jnp.arange(u.shape[1])[None, :]
    # Normalised per frame in log space, not by the global log Z: alpha + beta and log Z are each of
    # the order of the summed potentials (T * |x| * |w|), and exp(alpha + beta - log Z) loses their
    # common magnitude to float32 cancellation (rows summing to 1.6 at |x| ~ 1e6). The per-frame
    # logsumexp of alpha + beta is log Z up to that rounding, and it makes every row sum to 1.
    node = jnp.where((t < lens[:, None])[..., None], jnp.exp(_normalise_last(alpha + beta, 1)), 0.0)
    log_pair = alpha[:, :-1, :, None] + trans + (u[:, 1:] + beta[:, 1:])[:, :, None, :]
    pair = jnp.where((t[:, 1:] < lens[:, None])[..., None, None], jnp.exp(_normalise_last(log_pair, 2)), 0.0)
    return Marginals(restore(node), restore(pair))


def _normalise_last(log_p: Array, n_axes: int) -> Array:
    """log_p minus its logsumexp over the last `n_axes` axes; -inf where that slice is all -inf
    (a frame no label sequence reaches: its marginals are 0, not NaN). NaN stays NaN."""
    lead = log_p.shape[: log_p.ndim - n_axes]
    size = math.prod(log_p.shape[log_p.ndim - n_axes:])
    flat = log_p.reshape(lead + (size,))
    # the max first (exact differences of nearby large values), then the small logsumexp of the rest:
    # subtracting logsumexp(log_p) itself would round at the magnitude of log_p
    peak = jnp.max(flat, axis=-1, keepdims=True)
    empty = peak == -jnp.inf
    shifted = flat - jnp.where(empty, 0.0, peak)
    out = jnp.where(empty, -jnp.inf, shifted - safe_logsumexp(shifted, axis=-1)[..., None])
    return out.reshape(log_p.shape)


def sequence_score(unary: Float[Array, "T K"], trans: Trans, labels: Int[Array, " T"],
                   length: ScalarLike) -> Float[Array, ""]:
    """Unnormalised log score () of one label sequence: unary (T, K), labels (T,) (padding ignored). vmap for batches."""
    T = unary.shape[0]
    t = jnp.arange(T)
    valid = t < length
    labels = jnp.where(valid, labels, 0)
    node = jnp.take_along_axis(unary, labels[:, None], axis=1)[:, 0]
    node = jnp.sum(jnp.where(valid, node, 0.0))
    edge = trans[labels[:-1], labels[1:]]
    edge = jnp.sum(jnp.where(valid[1:], edge, 0.0))
    return node + edge


def viterbi(unary: Float[Array, "T K"], trans: Trans, length: ScalarLike) -> ViterbiPath:
    """Most probable labelling of one sequence, unary (T, K): ViterbiPath(labels (T,) int32, -1 on
    padding; log_score ()). vmap for batches."""
    T = unary.shape[0]
    unary = _mask_rows(unary[None], jnp.asarray(length)[None])[0]

    def step(delta, u):
        scores = delta[:, None] + trans  # (K, K)
        new = jnp.max(scores, axis=0) + u
        return new, (new, jnp.argmax(scores, axis=0).astype(jnp.int32))

    _, (deltas, backptr) = lax.scan(step, unary[0], unary[1:])
    deltas = jnp.concatenate([unary[:1], deltas], axis=0)
    last = jnp.argmax(deltas[length - 1]).astype(jnp.int32)
    best = jnp.max(deltas[length - 1])

    def back(y, inp):
        t, bp = inp  # bp = backpointers into time t
        prev = jnp.where(t <= length - 1, bp[y], y).astype(jnp.int32)
        return prev, prev

    _, prevs = lax.scan(back, last, (jnp.arange(1, T), backptr), reverse=True)
    path = jnp.concatenate([prevs, last[None]])
    return ViterbiPath(jnp.where(jnp.arange(T) < length, path, -1), best)


def constant_path_log_prob(unary: Unary, trans: Trans, length: Lengths) -> Float[Array, "*batch K"]:
    """Pre-segmented classifier (OAC §4): log P(y_t = k for all t | x), shape (..., K).

    The K values are probabilities of K label sequences under the chain model, so they sum to at
    most 1; argmax classifies the segment.
    """
    u, lens, restore = _as_batch(unary, length)
    u = _mask_rows(u, lens)
    path = jnp.sum(u, axis=1) + (lens - 1)[:, None] * jnp.diagonal(trans)[None, :]
    # a log probability: at most 0 (float32 rounding of two large, nearly equal terms can exceed it)
    return restore(jnp.minimum(path - log_partition(u, trans, lens)[:, None], 0.0))
