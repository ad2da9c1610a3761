"""The Stauffer–Grimson kernel of `background` (LEVELSET TR §3.5, eqs. 9-10): one frame's match,
update and decision with the pixels on the last axis, eq. 9's density, the scan over frames, and
the state's two layouts. The algorithm and its choices are described in `background`,
which checks input and options at the boundary; `hog_jax.video` composes these pieces with the
level sets in one scan.

The rules for real video (`background.BackgroundOptions`: warm-up, rho = alpha / w, the variance
ceiling, the "background_match" decision, shadows) are fields of `KernelOptions` whose defaults turn
them off; `step_pixels_last` takes the frame's index for the warm-up (None: none).

Layout: weights w (K, N), means mu (K, C, N), variances (K, N), a frame x (C, N) float32, N = H W:
every per-component quantity is one elementwise loop over the pixels.
"""
from __future__ import annotations

import functools

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

__all__ = ["BackgroundState", "init_state", "log_density_pixels_last", "pixels_last", "scan_pixels_last",
           "step_pixels_last", "to_public", "KernelOptions", "learning_rate", "median3"]


class BackgroundState(NamedTuple):
    """The per-pixel Gaussian mixtures of the background model (LEVELSET TR §3.5; Stauffer & Grimson 1999).

    Each pixel holds K Gaussians with one variance each (isotropic, Sigma = sigma^2 I).

    Attributes:
        weights: (H, W, K) summing to 1 per pixel (0: an empty component).
        means: (H, W, K, C) component means.
        variances: (H, W, K) component variances sigma^2.
    """

    weights: Float[Array, "H W K"]
    means: Float[Array, "H W K C"]
    variances: Float[Array, "H W K"]


class KernelOptions(NamedTuple):
    """The traced form of `background.BackgroundOptions` (`background.check_options`)."""

    alpha: jax.Array
    use_eta: jax.Array
    match2: jax.Array
    init_variance: jax.Array
    init_weight: jax.Array
    min_variance: jax.Array
    background_ratio: jax.Array
    tr_rule: jax.Array
    # the rules for real video (`background.BackgroundOptions`); defaults: off (the TR's model)
    rho_over_weight: jax.Array = False
    max_variance: jax.Array = float("inf")
    any_rule: jax.Array = False
    decision2: jax.Array = 0.0
    shadow_tau: jax.Array = 1.0
    warmup: jax.Array = False
    median3: jax.Array = False


def _first_best(values, eligible, larger: bool):
    """Index (N,) of the first k with the largest (or smallest) values[k] among eligible[k], by K
    elementwise comparisons (XLA:CPU's index-carrying reductions, argmax over a short axis, are far
    slower than this unrolled chain); 0 where nothing is eligible."""
    best_val, best = values[0], jnp.zeros(values[0].shape, jnp.int32)
    found = eligible[0] | jnp.zeros(values[0].shape, bool)
    for k in range(1, len(values)):
        v, e = values[k], eligible[k]
        better = e & (~found | ((v > best_val) if larger else (v < best_val)))
        best = jnp.where(better, k, best)
        best_val = jnp.where(better, v, best_val)
        found = found | e
    return best, found


def _in_background(w, var, best, ratio):
    """(N,) bool: component `best` (N,) is among the first B in the w / sigma order (ties: lower index
    first), i.e. the weight ranked strictly before it is <= T (then b = its rank does not yet exceed
    T). w, var (K, N)."""
    K = w.shape[0]
    key = w * jax.lax.rsqrt(var)
    key_best = sum((jnp.where(best == k, key[k], 0.0) for k in range(1, K)), jnp.where(best == 0, key[0], 0.0))
    ahead = sum(jnp.where((key[j] > key_best) | ((key[j] == key_best) & (j < best)), w[j], 0.0) for j in range(K))
    return ahead <= ratio


def _background_components(w, var, ratio):
    """(K, N) bool: component k is among the first B in the w / sigma order (ties: lower index first),
    i.e. the weight ranked strictly before it is <= T. w, var (K, N)."""
    K = w.shape[0]
    key = w * jax.lax.rsqrt(var)
    rows = []
    for k in range(K):
        ahead = sum((jnp.where((key[j] > key[k]) | ((key[j] == key[k]) & (j < k)), w[j], 0.0)
                     for j in range(K) if j != k), jnp.zeros_like(w[k]))
        rows.append(ahead <= ratio)
    return jnp.stack(rows)


def _once(o: KernelOptions, fn, *args):
    """fn(*args), materialised: a conditional (on alpha > 0, always true after `check_options` but
    only known at run time; the other branch returns zeros) whose outputs XLA must store. XLA:CPU
    drops optimization barriers before fusing, and otherwise recomputes a chain of cheap per-pixel
    operations inside every one of its consumers, which made a frame several times slower."""
    def never(*a):
        return jax.tree.map(jnp.zeros_like, jax.eval_shape(fn, *a))

    return jax.lax.cond(o.alpha > 0, fn, never, *args)


def _rows_sum(a):
    """a[0] + ... + a[K-1] for a (K, ...) array, unrolled: XLA:CPU reduces a short leading axis far
    more slowly than it adds the rows elementwise."""
    return sum((a[k] for k in range(1, a.shape[0])), a[0])


def learning_rate(o: KernelOptions, t=None):
    """The frame's alpha: o.alpha, or with the warm-up max(alpha, 1 / (t + 1)) at frame t (0-based)."""
    if t is None:
        return o.alpha
    return jnp.where(o.warmup, jnp.maximum(o.alpha, 1.0 / (jnp.asarray(t, jnp.float32) + 1.0)), o.alpha)


def step_pixels_last(w, mu, var, x, learn, o: KernelOptions, t=None):
    """One frame with the pixels last: w, var (K, N), mu (K, C, N), x (C, N) float32, learn (N,)
    bool, t the frame's index in the video (a scalar; None: no warm-up). Returns the new (w, mu, var)
    and foreground (N,) bool.

    Every per-component quantity is a (K, N) array computed by broadcasting (one loop for all K),
    every choice among components an unrolled chain of K comparisons (no argmax: index-carrying
    reductions are slow on XLA:CPU). The variance update uses |X - mu_new|^2 = (1 - rho)^2 |X - mu|^2
    (mu_new - X = (1 - rho)(mu - X)).
    """
    K, C = mu.shape[:2]
    ks = jnp.arange(K)[:, None]
    alpha = learning_rate(o, t)

    def decide(w, mu, var, x):  # the match (step 1 of the module docstring)
        d2 = _rows_sum((x[:, None, :] - jnp.moveaxis(mu, 1, 0)) ** 2)  # (K, N)
        match = (w > 0) & (d2 < o.match2 * var)
        key = w * jax.lax.rsqrt(var)
        best, any_match = _first_best(key, match, larger=True)
        worst, _ = _first_best(key, jnp.ones_like(match), larger=False)
        return best, any_match, worst, d2

    def rates(w, var, best, any_match, worst, d2):  # eq. 10's M and rho, the replacement, new weights
        hit = (ks == best) & any_match & learn
        replace = (ks == worst) & ~any_match & learn
        new_w = jnp.where(replace, o.init_weight, (1.0 - alpha) * w + alpha * hit)
        new_w = jnp.where(learn, new_w / _rows_sum(new_w), w)

        def alpha_eta(d2, var, new_w):  # rho = alpha eta(X | mu, sigma^2 I), clipped to 1
            return jnp.minimum(alpha * jnp.exp(-0.5 * d2 / var - 0.5 * C * jnp.log(2 * jnp.pi * var)), 1.0)

        def constant(d2, var, new_w):  # the TR's rho = alpha needs no exp / log; or alpha / w (MOG2)
            over_w = jnp.minimum(alpha / jnp.maximum(new_w, 1e-12), 1.0)
            return jnp.where(o.rho_over_weight, over_w, jnp.broadcast_to(alpha, var.shape))

        rho = jnp.where(hit, jax.lax.cond(o.use_eta, alpha_eta, constant, d2, var, new_w), 0.0)
        return new_w, hit, replace, rho

    best, any_match, worst, d2 = _once(o, decide, w, mu, var, x)
    new_w, hit, replace, rho = _once(o, rates, w, var, best, any_match, worst, d2)
    new_mu = jnp.where(replace[:, None], x[None], mu + rho[:, None] * (x[None] - mu))
    new_var = jnp.where(replace, o.init_variance, jnp.where(
        hit, jnp.clip((1.0 - rho) * var + rho * (1.0 - rho) ** 2 * d2, o.min_variance, o.max_variance), var))

    def classify(new_w, new_mu, new_var, best, any_match, d2_new):
        def stauffer_grimson(in_bg):
            return ~any_match | (~o.tr_rule & ~_in_background(new_w, new_var, best, o.background_ratio))

        def background_match(in_bg):  # any of the first B explains X
            return ~jnp.any(in_bg & (d2_new < o.decision2 * new_var), axis=0)

        def shadow(in_bg):  # Prati et al. 2003; Zivkovic & van der Heijden 2006 (OpenCV MOG2)
            mm = _rows_sum(jnp.moveaxis(new_mu * new_mu, 1, 0))  # (K, N) |mu_k|^2
            xm = _rows_sum(jnp.moveaxis(new_mu * x[None], 1, 0))  # (K, N) X . mu_k
            a = xm / jnp.maximum(mm, 1e-12)
            off = _rows_sum(x * x)[None] - a * xm  # |a mu_k - X|^2 at the best a
            return jnp.any(in_bg & (mm > 0) & (a >= o.shadow_tau) & (a <= 1.0)
                           & (off < o.decision2 * new_var * a * a), axis=0)

        needs_all = o.any_rule | (o.shadow_tau < 1.0)
        in_bg = jax.lax.cond(needs_all, lambda: _background_components(new_w, new_var, o.background_ratio)
                             & (new_w > 0), lambda: jnp.zeros(new_w.shape, bool))
        foreground = jax.lax.cond(o.any_rule, background_match, stauffer_grimson, in_bg)
        return foreground & ~jax.lax.cond(o.shadow_tau < 1.0, shadow, lambda b: jnp.zeros(b.shape[1:], bool), in_bg)

    # |X - mu_new|^2 without a second pass over the channels: the replaced component sits at X, the
    # matched one moved by rho towards it, the others did not move
    d2_new = jnp.where(replace, 0.0, jnp.where(hit, (1.0 - rho) ** 2 * d2, d2))
    foreground = _once(o, classify, new_w, new_mu, new_var, best, any_match, d2_new)
    return new_w, new_mu, new_var, foreground


def log_density_pixels_last(w, mu, var, x, scale: float = 255.0):
    """Eq. 9's log P(X) of every pixel under its mixture, with the pixels last (w, var (K, N), mu
    (K, C, N), x (C, N)), in the coordinates X / scale: each component isotropic with per-channel
    variance sigma^2 / C (sigma^2 tracks the total squared distance over the C channels, module
    docstring). Empty components (weight 0) add nothing."""
    C = mu.shape[1]
    d2 = _rows_sum((x[:, None, :] - jnp.moveaxis(mu, 1, 0)) ** 2)  # (K, N)
    per_channel = var / (C * scale * scale)
    log_comp = -0.5 * C * jnp.log(2 * jnp.pi * per_channel) - 0.5 * C * d2 / var
    log_w = jnp.where(w > 0, jnp.log(jnp.where(w > 0, w, 1.0)), -jnp.inf)
    terms = log_w + log_comp
    # logsumexp over the K components unrolled row by row (as `_rows_sum`); all -inf gives -inf
    top = functools.reduce(jnp.maximum, [terms[k] for k in range(terms.shape[0])])
    top = jnp.where(jnp.isfinite(top), top, 0.0)
    return top + jnp.log(_rows_sum(jnp.exp(terms - top)))


def scan_pixels_last(w, mu, var, frames, masks, o: KernelOptions, t0=0):
    """frames (T, H, W, C) any real dtype, masks (T, H, W) bool, t0 the first frame's index in the
    video (the warm-up's clock) -> state, foreground (T, N)."""
    T, C = frames.shape[0], frames.shape[-1]
    xs = jnp.moveaxis(frames.reshape(T, -1, C), 2, 1)  # (T, C, N), still in the input dtype
    ts = jnp.asarray(t0, jnp.float32) + jnp.arange(T, dtype=jnp.float32)

    def body(carry, inp):
        x, m, t = inp
        *state, fg = step_pixels_last(*carry, x.astype(jnp.float32), ~m, o, t)
        return tuple(state), fg

    return jax.lax.scan(body, (w, mu, var), (xs, masks.reshape(T, -1), ts))


def median3(masks):
    """The 3 x 3 median of (..., H, W) bool masks, edges replicated: at least 5 of the 9 neighbours."""
    H, W = masks.shape[-2:]
    pad = [(0, 0)] * (masks.ndim - 2) + [(1, 1), (1, 1)]
    m = jnp.pad(masks.astype(jnp.int8), pad, mode="edge")
    rows = m[..., 0:H, :] + m[..., 1:H + 1, :] + m[..., 2:H + 2, :]
    return (rows[..., 0:W] + rows[..., 1:W + 1] + rows[..., 2:W + 2]) >= 5


def pixels_last(state: BackgroundState):
    """The kernel's layout of a state: weights (K, N), means (K, C, N), variances (K, N), N = H W."""
    H, W, K = state.weights.shape
    return (state.weights.reshape(H * W, K).T, jnp.moveaxis(state.means.reshape(H * W, K, -1), 0, 2),
            state.variances.reshape(H * W, K).T)


def to_public(w, mu, var, H, W) -> BackgroundState:
    K = w.shape[0]
    return BackgroundState(w.T.reshape(H, W, K), jnp.moveaxis(mu, 2, 0).reshape(H, W, K, -1),
                           var.T.reshape(H, W, K))


def init_state(frame, K: int, o: KernelOptions) -> BackgroundState:
    H, W, C = frame.shape
    x = frame.astype(jnp.float32)
    weights = jnp.zeros((H, W, K), jnp.float32).at[..., 0].set(1.0)
    means = jnp.broadcast_to(x[:, :, None, :], (H, W, K, C))
    return BackgroundState(weights, means, jnp.full((H, W, K), o.init_variance, jnp.float32))
