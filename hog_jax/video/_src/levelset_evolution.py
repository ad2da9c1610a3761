"""Multi-region competing level sets on one device (LEVELSET TR §3.1-3.2, eqs. 1-7 and 11;
implementation §5): the model's types, the evolution and the kernel that `levelset` and
`levelset_sharded` run.

Shapes: B videos (or independent frames), T frames, R regions (R >= 2), H x W pixels.

One level set phi_i per region (region i = {phi_i > 0}), driven by per-pixel region scores
e_i(x) = log p_i(x) that the caller computes (skin / person / background GMMs, an object score...;
this module does not know where they come from). Each explicit Euler step (TR §5: central
differences, Euler in time) applies eq. 7 plus the distance-regularising flow of eq. 11
(Li, Xu, Gui & Fox 2005, the gradient flow of mu P(phi)), instead of re-initialisation:

    d phi_i/dt = delta(phi_i) (e_i - max_{j != i, H(phi_j) > 0} e_j + alpha/2 kappa(phi_i))
                 + mu (laplacian(phi_i) - kappa(phi_i)),     kappa = div(grad phi / |grad phi|)

with the smoothed Heaviside and delta of eqs. 5-6 (half-width `epsilon`, pixels).

Choices (each documented where it is made):
* The competitor where no other region is present (every H(phi_j) = 0, j != i: a pixel that only
  region i, or no region, claims): the max over all j != i. Region i then grows into an unclaimed
  pixel only where its model beats every other one, and the winning region's front advances into it.
* Scores: -inf (log 0) is valid input. Every score is floored at the pixel's best score minus
  `max_log_ratio` (a likelihood ratio of at most exp(max_log_ratio) between two regions, i.e. a
  uniform outlier floor); a pixel where every region scores -inf gets 0 for all (no evidence). So
  |e_i - e_j| <= max_log_ratio and nothing is ever NaN (the floor comes before any resampling).
  NaN or +inf scores are a ValueError.
* R = 2 is the same code: with phi_2 = -phi_1 (what `init_level_sets` gives; eq. 5 has
  H(-phi) = 1 - H(phi)) the two updates are exact negatives, so phi_2 = -phi_1 stays, and eq. 7 is
  eq. 4 for phi_1 with curvature weight alpha/2: the gradient flow of eq. 3 with length weight
  alpha/2 plus mu P(phi_1) (eq. 11).
* Time step: `dt=None` takes 0.9 / (4 (2 mu + alpha / (2 epsilon))) (at most 2.25): an explicit
  step of a diffusion of coefficient D needs dt D <= 1/4 on the 5-point stencil; eq. 11's flow
  div((1 - 1/|grad phi|) grad phi) is a Laplacian (coefficient mu) minus a curvature term (about mu
  near a distance function), and eq. 7's curvature term has coefficient at most alpha/2 * max delta
  = alpha / (2 epsilon). With mu counted once (Li et al.'s mu dt < 1/4) we saw period-2
  oscillations of the contour (then `converged` is False); the data term needs no bound (its sign
  is fixed per pixel, so its Euler step is monotone). A given dt must satisfy the same bound
  without the 0.9.
* Stopping (TR §5): the total contour length L = sum_i sum_x |grad H(phi_i)| (computed as
  sum delta(phi_i) |grad phi_i|, `contour_length`); the loop stops once |L_t - L_{t-1}| / L_{t-1}
  < tol for `patience` consecutive iterations, never before `it_min` and always by `it_max`
  iterations (per scale). L of phi_t is computed inside step t + 1 (it shares that step's gradient
  and delta), so the rule sees each change one iteration late: with every change below tol the loop
  stops after max(it_min, patience + 1) iterations. `converged` says whether the final scale met
  the length rule (False: stopped by it_max). A pure translation keeps L: warm starts need a tol
  below the per-iteration length change of a moving contour.
* Two scales (TR §5, structure `coarse`, default 60 x 80 for 240 x 320): the score maps are
  downsampled (linear, antialiased: a pixel's coarse score is a weighted mean of the
  log-likelihoods of its block), phi evolves there with alpha divided by the size ratio s (so both scales minimise the
  same energy in fine pixels), is upsampled bilinearly and multiplied by s (phi is a distance)
  to start the fine scale. s is the geometric mean of the two axes' ratios.
* Cold start (no previous frame, no phi0): each phi_i is the signed Euclidean distance (to pixel
  edges) of the partition argmax_i e_i at the first scale (`init_level_sets`): the data's own
  best guess, an exact signed distance (as eqs. 4-7 assume), and phi_2 = -phi_1 for R = 2. A
  checkerboard (Chan-Vese's start) is what `levelset_grey` uses instead, where no scores exist yet.
* Warm start (TR §3.7): frame t + 1 starts from frame t's level sets (`segment_video`, a lax.scan),
  downsampled by s to start the coarse scale. A region absent from frame t (phi_i < -epsilon
  everywhere) has no front and cannot reappear by itself, and a pixel that every region has left
  stays unclaimed; `reseed_margin` re-seeds both from the scores, or pass phi0 from
  `init_level_sets` or a tracker's prediction.
* Output labels: argmax of phi_i among the positive ones, -1 where none is positive (TR §3.2:
  those pixels lie on region boundaries).

Limitation (of eqs. 6 and 11 as the TR uses them): the delta of eq. 6 vanishes for |phi| >
epsilon, so only pixels within epsilon of a contour move; beyond that band a front advances at
the pace of eq. 11's regulariser (a fraction of a pixel per iteration), and new contours never
nucleate far from old ones. A start far from the answer converges slowly, and the length rule
can stop it early; the argmax start, the coarse scale and small frame-to-frame motion keep the
distance short.
"""
from __future__ import annotations

import dataclasses
import functools
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from hog_jax.video._src.levelset_ops import dirac, divergence, laplacian, max_others, resize, sq_edt, unit_normal
from lfd_common import as_array, check_int, check_real

__all__ = ["FIXED", "LevelSetOptions", "LevelSetResult", "LevelSetStructure", "check_options", "clip_scores",
           "evolve_kernel", "labels_of", "partition_sdf", "run", "segment_frame"]


@dataclasses.dataclass(frozen=True)
class LevelSetStructure:
    """What shapes the level-set computation (LEVELSET TR §3.2, §5).

    Attributes:
        n_regions: R regions, >= 2 (one level set each).
        shape: (H, W) the frame shape, each >= 3.
        coarse: (h, w) the coarse scale evolved first (TR §5: 60 x 80 for 240 x 320), at most the
            frame shape, or None for one scale. The scores are downsampled (antialiased), phi evolves
            there with alpha divided by the size ratio s (the geometric mean of the two axes' ratios),
            is upsampled and multiplied by s (phi is a distance) to start the fine scale.

    Raises:
        ValueError: naming the field for R < 2, a shape that is not a (height, width) tuple of
            integers >= 3, or a coarse scale larger than the frames.
    """

    n_regions: int
    shape: tuple[int, int] = (240, 320)
    coarse: tuple[int, int] | None = (60, 80)

    def __post_init__(self):
        check_int(self.n_regions, "n_regions", min_value=2)
        _check_shape(self.shape, "shape")
        if self.coarse is not None:
            _check_shape(self.coarse, "coarse")
            if self.coarse[0] > self.shape[0] or self.coarse[1] > self.shape[1]:
                raise ValueError(f"coarse: the coarse scale {tuple(self.coarse)} must not be larger than the "
                                 f"frames {tuple(self.shape)}; use coarse=None for one scale")

    @property
    def scale(self) -> float:
        """s, the fine-to-coarse size ratio (geometric mean of the two axes; 1 for one scale)."""
        if self.coarse is None:
            return 1.0
        return float(np.sqrt(self.shape[0] / self.coarse[0] * self.shape[1] / self.coarse[1]))


def _check_shape(shape, name: str) -> None:
    if not isinstance(shape, tuple) or len(shape) != 2:
        raise ValueError(f"{name}: expected a (height, width) tuple, got {shape!r}")
    for v in shape:
        check_int(v, name, min_value=3)


class LevelSetOptions(NamedTuple):
    """The evolution options of the competing level sets (LEVELSET TR eqs. 5-7, 11, §5).

    Traced: changing them does not recompile; validated (ValueError naming the field) at every entry
    point.

    Attributes:
        alpha: the curvature weight of eq. 7, >= 0, in fine-scale pixels.
        mu: the weight of eq. 11's distance-regularising flow (Li, Xu, Gui & Fox 2005), >= 0.
        epsilon: the half-width of the smoothed Heaviside and delta of eqs. 5-6, pixels, > 0. Only
            pixels within epsilon of a contour move by eq. 7.
        dt: the explicit Euler step; None: 0.9 / (4 (2 mu + alpha / (2 epsilon))) (at most 2.25), the
            stable bound of the 5-point stencil with margin. A given dt must satisfy the bound without
            the 0.9.
        tol: the relative change of the total contour length L = sum_i sum_x |grad H(phi_i)| counted
            as "no change", >= 0 (TR §5's stopping rule).
        it_min: the fewest iterations per scale, >= 0.
        it_max: the most iterations per scale, >= max(it_min, 1).
        patience: consecutive unchanged iterations that stop the loop, >= 1 (with every change below
            tol the loop stops after max(it_min, patience + 1) iterations).
        max_log_ratio: the score floor below the pixel's best score, nats, > 0 (a likelihood ratio of
            at most exp(max_log_ratio) between two regions; a pixel where every region scores -inf
            gets 0 for all).
        refit_every: iterations between re-estimates of score models that depend on the partition
            (`chan_vese_segment`), >= 1; fixed scores ignore it.
        reseed_margin: an absent region has no front and an unclaimed pixel stays unclaimed; where a
            region beats every other by more than this many nats but the warm start does not give it
            the pixel, the frame starts from the re-seeded partition (TR §3.7's "add small curves"),
            >= 0; None: never.
        fine_it_max: the most iterations at the fine scale after a coarse one, >= 1 (None:
            `it_max`). The coarse scale has moved the fronts close; a cap here bounds a frame's cost
            where the fine contour keeps changing by more than `tol` (noisy real frames).
    """

    alpha: float = 1.0
    mu: float = 0.5
    epsilon: float = 1.5
    dt: float | None = None
    tol: float = 3e-3
    it_min: int = 5
    it_max: int = 200
    patience: int = 5
    max_log_ratio: float = 10.0
    refit_every: int = 5
    reseed_margin: float | None = None
    fine_it_max: int | None = None


class LevelSetResult(NamedTuple):
    """The segmentation of frames by competing level sets (LEVELSET TR §3.2, §5).

    Attributes:
        labels: (*batch, H, W) int32, the region of each pixel (argmax of the positive phi_i), -1
            where no phi_i > 0 (TR §3.2: those pixels lie on region boundaries).
        phi: (*batch, R, H, W) the final level sets.
        iterations: (*batch,) int32 iterations at the fine scale.
        iterations_coarse: (*batch,) int32 iterations at the coarse scale (0 for one scale).
        converged: (*batch,) bool, the final scale stopped by the contour-length rule, not by it_max.
    """

    labels: Int[Array, "*batch H W"]
    phi: Float[Array, "*batch R H W"]
    iterations: Int[Array, " *batch"]
    iterations_coarse: Int[Array, " *batch"]
    converged: Bool[Array, " *batch"]


def check_options(options: LevelSetOptions) -> LevelSetOptions:
    """Validate `options` (ValueError naming the field) and return them as float32/int32 scalars
    (dt resolved to a number; the coarse scale recomputes the default for its own alpha)."""
    if not isinstance(options, LevelSetOptions):
        raise ValueError(f"options: expected a LevelSetOptions, got {type(options).__name__}")
    o = options
    alpha = check_real(o.alpha, "alpha", min_value=0.0)
    mu = check_real(o.mu, "mu", min_value=0.0)
    eps = check_real(o.epsilon, "epsilon", min_value=0.0, exclusive_min=True)
    dt = 0.0 if o.dt is None else check_real(o.dt, "dt", min_value=0.0, exclusive_min=True)
    limit = float(_dt_limit(alpha, mu, eps))
    if dt > limit * (1 + 1e-6):
        raise ValueError(f"dt: {dt:g} exceeds the explicit Euler bound 1 / (4 (2 mu + alpha / (2 epsilon))) = "
                         f"{limit:g} for these alpha, mu and epsilon; use a smaller dt or dt=None")
    it_min = check_int(o.it_min, "it_min", min_value=0)
    it_max = check_int(o.it_max, "it_max", min_value=max(it_min, 1))
    f32, i32 = np.float32, np.int32  # numpy scalars: cheaper to make than device arrays
    return LevelSetOptions(
        f32(alpha), f32(mu), f32(eps), f32(dt), f32(check_real(o.tol, "tol", min_value=0.0)), i32(it_min),
        i32(it_max), i32(check_int(o.patience, "patience", min_value=1)),
        f32(check_real(o.max_log_ratio, "max_log_ratio", min_value=0.0, exclusive_min=True)),
        i32(check_int(o.refit_every, "refit_every", min_value=1)),
        f32(np.inf if o.reseed_margin is None else check_real(o.reseed_margin, "reseed_margin", min_value=0.0)),
        i32(it_max if o.fine_it_max is None else check_int(o.fine_it_max, "fine_it_max", min_value=1)))


def _dt_limit(alpha, mu, eps):
    """The explicit Euler bound 1 / (4 (2 mu + alpha / (2 eps))), at most 2.5 (floats or traced)."""
    return 0.25 / jnp.maximum(2.0 * mu + alpha / (2.0 * eps), 0.1)


def clip_scores(e, max_log_ratio):
    """Floor every score at the pixel's best minus max_log_ratio; all -inf -> all 0 (module doc)."""
    # the maximum over the few regions unrolled (exact either way): XLA:CPU's reduction over this
    # leading axis cost ten times the elementwise maxima
    top = functools.reduce(jnp.maximum, [e[..., j:j + 1, :, :] for j in range(e.shape[-3])])
    ok = jnp.isfinite(top)
    return jnp.where(ok, jnp.maximum(e, jnp.where(ok, top, 0.0) - max_log_ratio), 0.0)


def partition_sdf(e):
    """Signed distances (`labels_sdf`) of the argmax partition of scores e (R, h, w) -> (R, h, w)."""
    return labels_sdf(jnp.argmax(e, axis=0), e.shape[0])


def labels_sdf(labels, n_regions: int):
    """Signed distances (R, h, w) of the regions of a partition `labels` (h, w) in [0, R). Outside a
    region lie the others, so R distance transforms suffice."""
    masks = labels == jnp.arange(n_regions)[:, None, None]
    dist = jnp.sqrt(sq_edt(masks)) - 0.5  # to each region
    return jnp.where(masks, -max_others(-dist), -dist)


# ------------------------------------------------------------------------------ eq. 7 + eq. 11
def _competitor(e, phi, eps):
    """max over the other regions present (H(phi_j) > 0 <=> phi_j > -eps); where none is, over all."""
    present = max_others(jnp.where(phi > -eps, e, -jnp.inf))
    return jnp.where(jnp.isfinite(present), present, max_others(e))


def _step(phi, e, o, alpha, dt):
    """One explicit Euler step of eq. 7 + eq. 11 for all R level sets (R, H, W) -> (the new level
    sets, `contour_length` of the old ones: it shares the step's gradient and delta)."""
    ny, nx, norm = unit_normal(phi)
    kappa = divergence(ny, nx)
    delta = dirac(phi, o.epsilon)
    force = e - _competitor(e, phi, o.epsilon) + 0.5 * alpha * kappa
    new = phi + dt * (delta * force + o.mu * (laplacian(phi) - kappa))
    return new, jnp.sum(delta * norm)


def labels_of(phi):
    return jnp.where(jnp.any(phi > 0, axis=-3), jnp.argmax(phi, axis=-3), -1).astype(jnp.int32)


@dataclasses.dataclass(frozen=True)
class _FixedScores:
    """The score model for given score maps: the data are the scores (R, H, W)."""

    refits: bool = False

    @staticmethod
    def prepare(data, o):  # before any resampling: a -inf weighted by 0 would be NaN
        return clip_scores(data, o.max_log_ratio)

    @staticmethod
    def init(data, o):
        return partition_sdf(data)

    @staticmethod
    def scores(data, phi, o):
        return data


FIXED = _FixedScores()


def _run(phi0, data, model, o, alpha):
    """Evolve one scale until the stopping rule of TR §5 -> (phi, iterations, converged). The length
    of phi_t comes out of step t + 1 (it shares that step's gradient), so the rule sees each
    iteration's change one iteration late."""
    dt = jnp.where(o.dt > 0, o.dt, 0.9 * _dt_limit(alpha, o.mu, o.epsilon))

    def cond(c):
        _, _, it, stall, _ = c
        return (it < o.it_max) & ((it < o.it_min) | (stall < o.patience))

    def body(c):
        phi, e, it, stall, previous = c
        if model.refits:  # a Python-level choice: fixed score maps never re-estimate
            e = jax.lax.cond((it > 0) & (it % o.refit_every == 0), lambda: model.scores(data, phi, o), lambda: e)
        phi, length = _step(phi, e, o, alpha, dt)
        rel = jnp.abs(length - previous) / jnp.maximum(previous, 1e-6)
        stall = jnp.where(it == 0, 0, jnp.where(rel < o.tol, stall + 1, 0))
        return phi, e, it + 1, stall, length

    init = (phi0, model.scores(data, phi0, o), jnp.int32(0), jnp.int32(0), jnp.float32(0))
    phi, _, it, stall, _ = jax.lax.while_loop(cond, body, init)
    return phi, it, stall >= o.patience


def segment_frame(structure: LevelSetStructure, model, data, phi_prev, cold, o) -> LevelSetResult:
    """Both scales for one frame, from the previous level sets (warm) or, where `cold`, the model's
    start."""
    def start(d, warm):
        return jax.lax.cond(cold, lambda: model.init(d, o), warm)

    data = model.prepare(data, o)
    if structure.coarse is None:
        phi = start(data, lambda: phi_prev)
        phi = _reseed(phi, model.scores(data, phi, o), o)
        phi, it, conv = _run(phi, data, model, o, o.alpha)
        it_c = jnp.int32(0)
    else:
        s = structure.scale
        small = resize(data, structure.coarse)
        phi = start(small, lambda: resize(phi_prev, structure.coarse) / s)
        phi = _reseed(phi, model.scores(small, phi, o), o)
        phi, it_c, _ = _run(phi, small, model, o, o.alpha / s)
        phi, it, conv = _run(resize(phi, structure.shape) * s, data, model, o._replace(it_max=o.fine_it_max), o.alpha)
    return LevelSetResult(labels_of(phi), phi, it, it_c, conv)


def _reseed(phi, e, o):
    """`reseed_margin` (LevelSetOptions) at a frame's first scale: a pixel whose best region wins by the
    margin but is not its label joins that region, unclaimed pixels join their best region, and then
    every phi_i restarts as the signed distance of that partition (a seed pasted into phi without its
    distance function is a spike that eq. 11's Laplacian flattens in one step); no seed: unchanged."""
    labels = labels_of(phi)
    best = jnp.argmax(e, axis=0)
    seeds = (jnp.max(e - max_others(e), axis=0) > o.reseed_margin) & (labels != best)
    partition = jnp.where(seeds | (labels < 0), best, labels)
    return jax.lax.cond(jnp.any(seeds), lambda: labels_sdf(partition, phi.shape[0]), lambda: phi)


@partial(jax.jit, static_argnames=("structure", "model", "batched", "frames"))
def evolve_kernel(structure: LevelSetStructure, model, data, phi0, cold0, o, batched: bool, frames: bool) -> LevelSetResult:
    """data (B, T, ...) per frame as `model` reads it; phi0 (B, R, H, W) the level sets before frame 0,
    ignored where cold0 (a traced bool: one compiled kernel serves both); o checked options.
    -> LevelSetResult with leading axes (B, T), without B unless `batched`, without T when
    `frames` (independent frames, T = 1)."""
    def video(d, p0):
        def step(prev, xs):
            t, frame = xs
            res = segment_frame(structure, model, frame, prev, (t == 0) & cold0, o)
            return res.phi, res
        res = jax.lax.scan(step, p0, (jnp.arange(d.shape[0]), d))[1]
        return jax.tree_util.tree_map(lambda a: a[0], res) if frames else res
    if data.shape[0] == 1:  # one input: no batched while loops (half the compile time, no masked steps)
        res = video(data[0], phi0[0])
        return jax.tree_util.tree_map(lambda a: a[None], res) if batched else res
    return jax.vmap(video)(data, phi0)


def run(structure: LevelSetStructure, model, data: np.ndarray, phi0, options: LevelSetOptions, batched: bool,
        frames: bool, kernel=evolve_kernel) -> LevelSetResult:
    """Check phi0 and the options, run `kernel` (or a drop-in). data (B, T, ...) numpy, checked by the caller;
    phi0 None (cold start) or (R, H, W) / (B, R, H, W) as `batched`; frames: independent frames."""
    shape = (data.shape[0], structure.n_regions, *structure.shape)
    if phi0 is None:
        start = np.zeros(shape, np.float32)
    else:
        start = as_array(phi0, "phi0", shape=shape if batched else shape[1:], dtype=np.float32).reshape(shape)
    return kernel(structure, model, jnp.asarray(data), start, np.bool_(phi0 is None), check_options(options),
                  batched, frames)
