"""Linear-chain CRF (OAC eqs. 3-4, LfD eqs. 7-8): exact inference in log space.

Two layers:

* Potential-level functions, pure JAX, jit/vmap/grad-friendly, no validation (dynamax style):
  `log_partition`, `forward`, `backward`, `forward_backward`, `marginals`,
  `constant_path_log_prob` take unary (..., T, K) and length (...) with optional leading batch
  axes; `viterbi` and `sequence_score` take one sequence (vmap them). Arguments:
      unary  (T, K)  node log potentials (padding rows may hold anything finite),
      trans  (K, K)  log potentials of y_{t-1} = i -> y_t = j (-inf marks a forbidden transition),
      length ()      int, number of real frames (1 <= length <= T).
  Padding never leaks into values or gradients: padded unary rows are replaced by 0 with a first
  `where` before any arithmetic, and results are read at `length - 1` (second `where`/gather), so
  `jax.grad` of a padded batch equals that of the unpadded one and is NaN-free.
* The model `ChainCRF` (a pytree of weights) with `unary_potentials`, `nll`, `predict`,
  `predict_marginals`, `segment_log_probs` on padded batches X (B, T, D), lengths (B,).
  The public versions (re-exported by `crf_jax`) validate numpy input and raise `ValueError`.

Every quantity is a log potential / log message. The forward recursion's (K, K) contraction
logsumexp_i(alpha_i + trans_ij) is evaluated as m + c_j + log(exp(alpha - m) @ exp(trans - c)), with
m the row max of alpha and c_j the column max of trans: one small matmul per step instead of a
(B, K, K) logsumexp. If that loses precision anywhere (a reachable entry < 1e-30, i.e. potentials
spanning ~70 nats, as in a wild line-search step) the pass is redone with the exact logsumexp
(`lax.cond` on one flag per batch, free otherwise).

Model (connectivity C, window W = 2C + 1): the label y_t sees x_{t-C..t+C} (zeros outside the
sequence), log psi_t(k) = sum_c <x_{t+c-C}, weights[c, :, k]> + bias[k] and
log P(y | x) = sum_t log psi_t(y_t) + sum_{t>=1} trans[y_{t-1}, y_t] - log Z(x).
This is eq. 3 with feature functions that factor into node and edge terms, as in CRFsuite.
"""
from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from crf_jax._checks import check_batch, check_labels

Array = jax.Array


# ----------------------------------------------------------------------------------------------
# log-space helpers
# ----------------------------------------------------------------------------------------------
def safe_logsumexp(x: Array, axis: int = -1) -> Array:
    """logsumexp that returns -inf (value) and 0 (gradient) where every entry is -inf.

    `jax.nn.logsumexp` gives a NaN gradient for an all -inf slice (log 0 -> inf * 0); forbidden
    transitions and unreachable labels produce such slices, so inference uses this version.
    """
    m = jnp.max(x, axis=axis, keepdims=True)
    m = lax.stop_gradient(jnp.where(jnp.isfinite(m), m, 0.0))
    s = jnp.sum(jnp.exp(x - m), axis=axis, keepdims=True)
    pos = s != 0  # NaN stays NaN (never silently turned into -inf)
    out = jnp.where(pos, jnp.log(jnp.where(pos, s, 1.0)) + m, -jnp.inf)
    return jnp.squeeze(out, axis=axis)


def _safe_log(s: Array) -> Array:
    pos = s != 0  # s >= 0 here; NaN stays NaN
    return jnp.where(pos, jnp.log(jnp.where(pos, s, 1.0)), -jnp.inf)


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
    return _safe_log(s) + m + mshift, jnp.any(reach & (s < _TINY))


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
def forward(unary: Array, trans: Array, length: Array) -> Array:
    """Log forward messages alpha (..., T, K): alpha_t(j) = log sum over y_{<t} of exp(score(y_{<=t})), y_t = j.

    Rows t >= length continue over zero potentials and are never read by the functions below.
    """
    u, lens, restore = _as_batch(unary, length)
    return restore(_scan_messages(_mask_rows(u, lens), trans))


def backward(unary: Array, trans: Array, length: Array) -> Array:
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


def log_partition(unary: Array, trans: Array, length: Array, method: str = "scan") -> Array:
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


def forward_backward(unary: Array, trans: Array, length: Array) -> tuple[Array, Array, Array]:
    """(log_alpha (..., T, K), log_beta (..., T, K), log Z (...))."""
    u, lens, restore = _as_batch(unary, length)
    alpha = _scan_messages(_mask_rows(u, lens), trans)
    beta = backward(u, trans, lens)
    return restore(alpha), restore(beta), restore(safe_logsumexp(_at_last(alpha, lens)))


def marginals(unary: Array, trans: Array, length: Array) -> tuple[Array, Array]:
    """Posterior marginals: node (..., T, K) P(y_t = k | x), pair (..., T-1, K, K) P(y_t = i, y_{t+1} = j | x).

    Rows for padded frames (and pairs reaching into padding) are exactly 0.
    """
    u, lens, restore = _as_batch(unary, length)
    alpha, beta, log_z = forward_backward(u, trans, lens)
    u = _mask_rows(u, lens)
    t = jnp.arange(u.shape[1])[None, :]
    log_z = log_z[:, None, None]
    node = jnp.where((t < lens[:, None])[..., None], jnp.exp(alpha + beta - log_z), 0.0)
    log_pair = alpha[:, :-1, :, None] + trans + (u[:, 1:] + beta[:, 1:])[:, :, None, :] - log_z[..., None]
    pair = jnp.where((t[:, 1:] < lens[:, None])[..., None, None], jnp.exp(log_pair), 0.0)
    return restore(node), restore(pair)


def sequence_score(unary: Array, trans: Array, labels: Array, length: Array) -> Array:
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


def viterbi(unary: Array, trans: Array, length: Array) -> tuple[Array, Array]:
    """Most probable labelling of one sequence, unary (T, K): (labels (T,) int32, -1 on padding; log score ()).

    vmap for batches."""
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
    return jnp.where(jnp.arange(T) < length, path, -1), best


def constant_path_log_prob(unary: Array, trans: Array, length: Array) -> Array:
    """Pre-segmented classifier (OAC §4): log P(y_t = k for all t | x), shape (..., K).

    The K values are probabilities of K label sequences under the chain model, so they sum to at
    most 1; argmax classifies the segment.
    """
    u, lens, restore = _as_batch(unary, length)
    u = _mask_rows(u, lens)
    path = jnp.sum(u, axis=1) + (lens - 1)[:, None] * jnp.diagonal(trans)[None, :]
    return restore(path - log_partition(u, trans, lens)[:, None])


# ----------------------------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------------------------
class ChainCRF(NamedTuple):
    """Linear-chain CRF parameters (a pytree).

    weights (W, D, K): node weights for window offset c - C, W = 2C + 1 (C = connectivity).
    bias    (K,):      per-label bias.
    trans   (K, K):    transition log potentials, trans[i, j] for y_{t-1} = i -> y_t = j.
    """

    weights: Array
    bias: Array
    trans: Array

    @property
    def connectivity(self) -> int:
        return (self.weights.shape[0] - 1) // 2

    @property
    def n_features(self) -> int:
        return self.weights.shape[1]

    @property
    def n_labels(self) -> int:
        return self.weights.shape[2]


def init_chain(n_features: int, n_labels: int, connectivity: int = 0, key: Array | None = None,
               scale: float = 0.0, dtype=jnp.float32) -> ChainCRF:
    """All-zero parameters (the convex CRF objective needs no random start), or N(0, scale^2) with `key`."""
    W = 2 * connectivity + 1
    shape = (W, n_features, n_labels)
    if key is None or scale == 0.0:
        weights = jnp.zeros(shape, dtype)
    else:
        weights = scale * jax.random.normal(key, shape, dtype)
    return ChainCRF(weights, jnp.zeros((n_labels,), dtype), jnp.zeros((n_labels, n_labels), dtype))


def window_project(X: Array, weights: Array, lengths: Array) -> Array:
    """sum_c x_{t+c-C} @ weights[c] for a padded batch: X (B, T, D), weights (W, D, ...) -> (B, T, ...).

    One matmul over all offsets, then shifted sums; frames outside [0, length) contribute zero.
    Padded frames of X must be finite (the public API zeroes them).
    """
    B, T, D = X.shape
    W = weights.shape[0]
    C = (W - 1) // 2
    out_shape = weights.shape[2:]
    valid = jnp.arange(T)[None, :] < lengths[:, None]
    flat = weights.reshape(W, D, -1).transpose(1, 0, 2).reshape(D, -1)  # (D, W * M)
    proj = (X.reshape(B * T, D) @ flat).reshape(B, T, W, -1)
    # Mask the (W * M)-wide projection rather than X (D-wide): same values, far less memory
    # traffic. Finite padding then has no effect on values or gradients; the public API zeroes
    # padded frames of X at the boundary so NaN padding cannot reach here either.
    proj = jnp.where(valid[:, :, None, None], proj, 0.0)
    if C == 0:
        out = proj[:, :, 0]
    else:
        padded = jnp.pad(proj, ((0, 0), (C, C), (0, 0), (0, 0)))
        out = sum(padded[:, c : c + T, c] for c in range(W))
    return out.reshape(B, T, *out_shape)


def unary_potentials(model: ChainCRF, X: Array, lengths: Array) -> Array:
    """Node log potentials (B, T, K) for a padded batch X (B, T, D)."""
    return window_project(X, model.weights, lengths) + model.bias


@partial(jax.jit, static_argnames=("method",))
def nll(model: ChainCRF, X: Array, y: Array, lengths: Array, method: str = "scan") -> Array:
    """Per-sequence negative log-likelihood (B,): log Z(x_b) - score(y_b)."""
    unary = unary_potentials(model, X, lengths)
    log_z = log_partition(unary, model.trans, lengths, method=method)
    score = jax.vmap(sequence_score, (0, None, 0, 0))(unary, model.trans, y, lengths)
    return log_z - score


@jax.jit
def predict_jit(model: ChainCRF, X: Array, lengths: Array) -> Array:
    """Viterbi labels (B, T), -1 on padding."""
    unary = unary_potentials(model, X, lengths)
    return jax.vmap(viterbi, (0, None, 0))(unary, model.trans, lengths)[0]


@jax.jit
def marginals_jit(model: ChainCRF, X: Array, lengths: Array) -> Array:
    """Node marginals (B, T, K), 0 on padding."""
    unary = unary_potentials(model, X, lengths)
    return marginals(unary, model.trans, lengths)[0]


@jax.jit
def segment_log_probs_jit(model: ChainCRF, X: Array, lengths: Array) -> Array:
    """log P(y_t = k for all t | x) (B, K)."""
    unary = unary_potentials(model, X, lengths)
    return constant_path_log_prob(unary, model.trans, lengths)


# ----------------------------------------------------------------------------------------------
# public, validated (numpy in; ValueError naming the argument)
# ----------------------------------------------------------------------------------------------
def _prepare(model: ChainCRF, X, lengths):
    Xc, lens = check_batch(X, lengths, n_features=model.n_features)
    return jnp.asarray(Xc), jnp.asarray(lens)


def predict(model: ChainCRF, X, lengths=None) -> Array:
    """Viterbi labelling: X (B, T, D), lengths (B,) or None -> labels (B, T) int32, -1 on padding."""
    Xj, lj = _prepare(model, X, lengths)
    return predict_jit(model, Xj, lj)


def predict_marginals(model: ChainCRF, X, lengths=None) -> Array:
    """Posterior node marginals P(y_t = k | x): (B, T, K), 0 on padding."""
    Xj, lj = _prepare(model, X, lengths)
    return marginals_jit(model, Xj, lj)


def segment_log_probs(model: ChainCRF, X, lengths=None) -> Array:
    """Pre-segmented classification (OAC §4): log P(y_t = k for all t | x), (B, K)."""
    Xj, lj = _prepare(model, X, lengths)
    return segment_log_probs_jit(model, Xj, lj)


def log_likelihood(model: ChainCRF, X, y, lengths=None) -> Array:
    """log P(y_b | x_b) per sequence (B,) for labels y (B, T)."""
    Xj, lj = _prepare(model, X, lengths)
    yc = check_labels(y, np.asarray(lj), model.n_labels)
    return -nll(model, Xj, jnp.asarray(yc[:, : Xj.shape[1]]), lj)
