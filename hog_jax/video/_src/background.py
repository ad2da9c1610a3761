"""Per-pixel Gaussian-mixture background model (level-set TR §3.5, eqs. 9-10; Stauffer & Grimson,
"Adaptive background mixture models for real-time tracking", CVPR 1999).

Shapes: T frames, B videos, H x W pixels, C colour channels (3: RGB in [0, 255]), K components.

Each pixel holds K Gaussians with one variance each (isotropic, Sigma = sigma^2 I, as Stauffer-Grimson):
weights w (H, W, K), means mu (H, W, K, C), variances sigma^2 (H, W, K) (`BackgroundState`). Per frame
and pixel X (`update`):

1. match: component k matches when w_k > 0 and |X - mu_k| < lambda sigma_k (lambda = 2.5, TR §3.5; the
   Euclidean norm over the C channels); the *best match* is the matching component of highest
   w / sigma (Stauffer-Grimson's order: most weight, least spread first; ties: the lower index).
   Components of weight 0 are empty (the unused ones after `init_background`) and never match.
2. a match (eq. 10): w_k <- (1 - alpha) w_k + alpha M_k for all k (M = 1 for the best match, else 0);
   only the best match's mean and variance move: mu <- (1 - rho) mu + rho X, then
   sigma^2 <- max((1 - rho) sigma^2 + rho |X - mu|^2, min_variance) with the *updated* mean, as eq. 10
   and Stauffer-Grimson write it. rho = alpha (the TR's choice; `rho="alpha"`) or rho = alpha eta(X |
   mu, sigma^2 I) (eq. 10's alternative, `rho="alpha_eta"`, clipped to 1).
   As in eq. 10 the variance tracks the *total* squared distance over the C channels (not the
   per-channel one), so the 2.5 sigma test is on that scale (OpenCV's MOG2 does the same).
3. no match: all weights decay (M = 0), and the least probable component (lowest w / sigma, ties: the
   lower index) is replaced by one at X with variance `init_variance` and weight `init_weight`.
4. weights renormalised to sum to 1.
5. pixels in the frame's `no_update_mask` (the person and tracked objects, TR §3.5 last paragraph)
   keep their state unchanged: they are classified but never learned, so a person who stands still
   stays foreground.

Foreground decision, on the state after the update (`decision`):
* "stauffer_grimson" (default): order the components by w / sigma; the first B, B = argmin_b
  (sum_{k<=b} w_k > T), model the background (T = `background_ratio`); a pixel is foreground when
  nothing matched or its best match is not among them. This is the default because with the TR's
  simpler rule a component that has just replaced the worst one (wide, at the foreground colour)
  matches the next frame's foreground pixel at once, so a moving person would be background one
  frame after arriving; here a new component must earn weight T before it counts as background.
* "matched" (TR §3.5: "if there exists a Gaussian that matches well ... it is considered
  background"): foreground = nothing matched.

Defaults: K = 3, alpha = 0.05, rho = alpha, lambda = 2.5 (TR §3.5). Stauffer-Grimson leave T and the
replacement's "high variance, low weight" as parameters; we take the values of OpenCV's implementation
of their model (`bgsegm.BackgroundSubtractorMOG`, after KaewTraKulPong & Bowden 2001): T = 0.7 (its
backgroundRatio), initial weight 0.05, initial standard deviation 2 x 15 = 30 (variance 900).
`min_variance` = 4 is a floor that eqs. 9-10 lack: on integer pixel values a static pixel's variance
decays geometrically to 0, after which an exact repeat fails the strict test |X - mu| < 2.5 sigma; 4
is OpenCV MOG2's default floor (`fVarMin`), on the same total-squared-distance scale.

Rules for real video (each an option of `BackgroundOptions`, off by default so that the defaults are
the TR's model; `BackgroundOptions.real_video()` turns them on, chosen on real sequences): a warm-up
alpha_t = max(alpha, 1 / (t + 1)) (people in view from the first frame), rho = alpha / w, a variance
ceiling, the "background_match" decision at its own distance (Zivkovic 2004; Zivkovic & van der Heijden
2006, as OpenCV's MOG2), shadows (Prati et al. 2003) and a 3 x 3 median of the mask. The warm-up's
clock is the frame's index in the video (`run_background(start_frame=...)`, `update(frame_index=...)`),
so a video run in chunks gives the same masks as one run.

Options (`BackgroundOptions`) are traced: changing alpha, T or the decision rule does not recompile.
Vectorised over pixels, `lax.scan` over frames (`run_background`), `vmap` over videos
(`run_background_batch`, in groups of `videos_per_step`). Internally the pixels lie on the last axis
((K, N), (K, C, N), N = H W; the kernel is `background_kernel`): every per-component
quantity is one elementwise loop over the pixels. On the CPU `threads` cuts the rows into stripes
(or the videos into groups), each its own compiled call on a host thread.
Validation (ValueError naming the argument) happens at the boundary, outside jit.
"""
from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh
from jaxtyping import Array, ArrayLike, Bool, Float, Real

from hog_jax.video._src.background_kernel import (BackgroundState, KernelOptions, init_state,
    log_density_pixels_last, median3, pixels_last, scan_pixels_last, step_pixels_last, to_public)
from lfd_common import as_array, check_choice, check_int, check_real
from lfd_common import check_mesh, map_batch

__all__ = ["BackgroundOptions", "BackgroundState", "BackgroundStructure", "init_background", "log_density",
           "run_background", "run_background_batch", "update"]

_RHO = ("alpha", "alpha_eta", "alpha_over_weight")
_DECISIONS = ("stauffer_grimson", "matched", "background_match")
_CLEANUPS = ("none", "median3")


@dataclasses.dataclass(frozen=True)
class BackgroundStructure:
    """What changes the background state's shapes (LEVELSET TR §3.5).

    Attributes:
        n_components: K Gaussians per pixel, >= 1 (TR: 3).
        n_channels: C colour channels, >= 1 (3: RGB).

    Raises:
        ValueError: naming the field for a value < 1.
    """

    n_components: int = 3
    n_channels: int = 3

    @classmethod
    def real_video(cls) -> BackgroundStructure:
        """K = 5 RGB Gaussians per pixel (OpenCV MOG2's count), chosen with `BackgroundOptions.real_video()`
        on validation halves of real sequences (K = 3, 4, 5 tried).

        Returns:
            `BackgroundStructure(n_components=5)`.
        """
        return cls(n_components=5)

    def __post_init__(self):
        check_int(self.n_components, "n_components", min_value=1)
        check_int(self.n_channels, "n_channels", min_value=1)


class BackgroundOptions(NamedTuple):
    """The Stauffer–Grimson update and decision options (LEVELSET TR §3.5, eqs. 9-10).

    Traced under jit: changing them does not recompile; validated by `check_options` at every entry
    point. Stauffer and Grimson leave T and the replacement's "high variance, low weight" as
    parameters; the defaults take the values of OpenCV's implementation of their model
    (`bgsegm.BackgroundSubtractorMOG`).

    Attributes:
        alpha: the learning rate of eq. 10, in (0, 1] (TR: 0.05).
        rho: the mean and variance rate of eq. 10: "alpha" (rho = alpha, the TR's choice),
            "alpha_eta" (rho = alpha eta(X | mu, sigma^2 I), clipped to 1) or "alpha_over_weight"
            (rho = alpha / w_k, clipped to 1: Power & Schoonees, "Understanding background mixture
            models", 2002; Zivkovic 2004 eq. 5, OpenCV MOG2: a young component learns its mean as a
            running average of its own samples).
        match_sigmas: lambda, > 0: component k matches when |X - mu_k| < lambda sigma_k (TR: 2.5; the
            norm over the C channels, the variance tracking the total squared distance, as OpenCV's
            MOG2).
        init_variance: the variance of a component that replaces the least probable one when nothing
            matched (900: standard deviation 2 x 15), >= min_variance.
        init_weight: the weight of that component, in (0, 1].
        min_variance: the variance floor, > 0 (4, OpenCV MOG2's `fVarMin`): on integer pixel values a
            static pixel's variance decays to 0, after which an exact repeat fails the strict match.
        background_ratio: T in (0, 1): the first B components by w / sigma, B = argmin_b
            (sum_{k<=b} w_k > T), model the background.
        decision: "stauffer_grimson" (a pixel is foreground when nothing matched or its best match is
            not among the first B; a new component must earn weight T before it counts as background)
            or "matched" (TR §3.5: foreground = nothing matched), or "background_match" (Zivkovic 2004,
            "Improved adaptive Gaussian mixture model for background subtraction", ICPR, eq. 8, as
            OpenCV's MOG2: background when X lies within `decision_sigmas` sigma_k of any of the first
            B components, not only the best match).
        max_variance: a ceiling on a matched component's variance (inf: none, the TR; OpenCV MOG2
            keeps 5 x its initial variance): a component never widens until it swallows the
            foreground colours that pass by.
        decision_sigmas: the distance, in sigma_k, within which a background component explains X for
            "background_match" and the shadow rule (MOG2's Tb = 4 sigma against Tg = 3 sigma for the
            match); None: `match_sigmas`.
        shadow_tau: None (no shadow rule, the TR) or tau in (0, 1): a foreground pixel X is shadow, and
            so background, when for one of the first B components X = a mu_k with tau <= a <= 1 up to
            |a mu_k - X| < decision_sigmas a sigma_k: darker by a ratio in [tau, 1] with the same
            chromaticity (Prati, Mikic, Trivedi & Cucchiara, PAMI 2003; Zivkovic & van der Heijden,
            PRL 2006, §4, OpenCV MOG2's `detectShadows`, tau = 0.5). CDnet scores hard shadow as
            background.
        warmup: the learning rate of frame t (0-based) is max(alpha, 1 / (t + 1)) (Zivkovic & van der
            Heijden 2006, §3; KaewTraKulPong & Bowden 2001's "expected sufficient statistics"): early
            on the model averages all the frames seen, so what stood in the first frame and then
            moved (people in view from frame 0) leaves the background within a few frames instead of
            1 / alpha. False: alpha from the first frame (the TR).
        cleanup: "none" or "median3": the 3 x 3 median of each frame's foreground mask (edges
            replicated; a binary median is the majority of the 9 neighbours), a common
            post-processing of background subtraction (e.g. Piccardi, "Background subtraction
            techniques: a review", SMC 2004), which removes isolated pixels and fills pinholes. It
            changes `run_background`'s masks only, never the learning.
    """

    alpha: float = 0.05
    rho: str = "alpha"
    match_sigmas: float = 2.5
    init_variance: float = 900.0
    init_weight: float = 0.05
    min_variance: float = 4.0
    background_ratio: float = 0.7
    decision: str = "stauffer_grimson"
    max_variance: float = float("inf")
    decision_sigmas: float | None = None
    shadow_tau: float | None = None
    warmup: bool = False
    cleanup: str = "none"

    @classmethod
    def stauffer_grimson(cls) -> BackgroundOptions:
        """The TR's model (LEVELSET TR §3.5, eqs. 9-10) with none of the rules for real video: the defaults.

        Returns:
            `BackgroundOptions()`: alpha = 0.05, rho = alpha, lambda = 2.5, no warm-up, no variance
            ceiling, no shadows, no cleanup.
        """
        return cls()

    @classmethod
    def real_video(cls) -> BackgroundOptions:
        """The setting for real camera video, chosen on validation halves of six real sequences.

        The TR's Stauffer–Grimson update with the rules of Zivkovic's adaptive mixture (Zivkovic 2004;
        Zivkovic & van der Heijden 2006; OpenCV MOG2's variance constants) and a 3 x 3 median:
        alpha = 0.01 with the warm-up max(alpha, 1 / (t + 1)) (people in view from the first frame
        leave the model), rho = alpha / w, a variance between 4 and 75 (15 for a new component, which
        starts at weight 0.002), a match at 3 sigma and the background decision at 4 sigma over the
        components that make up T = 0.8 of the weight, shadows darker by a ratio in [0.85, 1]. Use it
        with `BackgroundStructure.real_video()` (K = 5). It was chosen by mean F1 over
        the first half of the evaluated frames of CDnet baseline/highway and baseline/pedestrians
        (Goyette et al. 2012) and SBI Candela_m1.10, HallAndMonitor, Board and HumanBody2 (Maddalena &
        Petrosino 2015; masks of Wang, Luo & Jodoin 2017), one setting for all six, against OpenCV's
        MOG2 and KNN on the same frames.

        Returns:
            The `BackgroundOptions`.
        """
        return cls(alpha=0.01, rho="alpha_over_weight", match_sigmas=3.0, init_variance=15.0, init_weight=0.002,
                   min_variance=4.0, background_ratio=0.8, decision="background_match", max_variance=75.0,
                   decision_sigmas=4.0, shadow_tau=0.85, warmup=True, cleanup="median3")

    @classmethod
    def for_fps(cls, fps: float, alpha: float = 0.05, reference_fps: float = 25.0) -> BackgroundOptions:
        """The options whose learning rate forgets as fast per second at `fps` as `alpha` does at `reference_fps`.

        The TR's learning rate alpha = 0.05 per frame (LEVELSET TR §3.5, eq. 10) holds at 25 fps; at
        another frame rate the same forgetting time asks for 1 - (1 - alpha)^(reference_fps / fps) per
        frame (at 10 fps the lighting drifts 2.5 times as far between frames). The other options keep
        their defaults.

        Args:
            fps: the video's frame rate, frames per second, > 0.
            alpha: the learning rate at `reference_fps`, in (0, 1].
            reference_fps: the frame rate at which `alpha` holds, > 0.

        Returns:
            `BackgroundOptions` with the scaled `alpha`.

        Raises:
            ValueError: naming the argument for a non-positive or non-finite frame rate, or an
                `alpha` outside (0, 1].
        """
        fps = check_real(fps, "fps", min_value=0.0, exclusive_min=True)
        alpha = check_real(alpha, "alpha", min_value=0.0, max_value=1.0, exclusive_min=True)
        reference_fps = check_real(reference_fps, "reference_fps", min_value=0.0, exclusive_min=True)
        return cls(alpha=float(1.0 - (1.0 - alpha) ** (reference_fps / fps)))


def check_options(options: BackgroundOptions) -> KernelOptions:
    """Validate `BackgroundOptions` and return their traced form.

    Args:
        options: the `BackgroundOptions`.

    Returns:
        The options as float32 / bool scalars for the jitted kernel.

    Raises:
        ValueError: naming the field for alpha outside (0, 1], match_sigmas <= 0, variances <= 0 (or
            init_variance < min_variance), init_weight outside (0, 1], background_ratio outside
            (0, 1), or an unknown rho or decision; naming `options` when it is not a
            `BackgroundOptions`.
    """
    if not isinstance(options, BackgroundOptions):
        raise ValueError(f"options: expected a BackgroundOptions, got {type(options).__name__}")
    o = options
    alpha = check_real(o.alpha, "alpha", min_value=0.0, max_value=1.0, exclusive_min=True)
    lam = check_real(o.match_sigmas, "match_sigmas", min_value=0.0, exclusive_min=True)
    v0 = check_real(o.init_variance, "init_variance", min_value=0.0, exclusive_min=True)
    w0 = check_real(o.init_weight, "init_weight", min_value=0.0, max_value=1.0, exclusive_min=True)
    vmin = check_real(o.min_variance, "min_variance", min_value=0.0, exclusive_min=True)
    if v0 < vmin:
        raise ValueError(f"init_variance: must be >= min_variance = {vmin}, got {v0}")
    ratio = check_real(o.background_ratio, "background_ratio", min_value=0.0, max_value=1.0, exclusive_min=True)
    if ratio >= 1.0:
        raise ValueError(f"background_ratio: must be < 1 (the weights sum to 1), got {ratio}")
    check_choice(o.rho, "rho", _RHO)
    check_choice(o.decision, "decision", _DECISIONS)
    check_choice(o.cleanup, "cleanup", _CLEANUPS)
    real = isinstance(o.max_variance, (int, float, np.floating, np.integer)) and not isinstance(o.max_variance, bool)
    vmax = float(o.max_variance) if real else float("nan")
    if np.isnan(vmax) or vmax < v0:
        raise ValueError(f"max_variance: expected a real >= init_variance = {v0} (inf: none), got {o.max_variance!r}")
    lam_d = lam if o.decision_sigmas is None else check_real(o.decision_sigmas, "decision_sigmas", min_value=0.0,
                                                              exclusive_min=True)
    if o.shadow_tau is None:
        tau = 1.0
    else:
        tau = check_real(o.shadow_tau, "shadow_tau", min_value=0.0, max_value=1.0, exclusive_min=True)
        if tau >= 1.0:
            raise ValueError(f"shadow_tau: must be < 1 (None: no shadow rule), got {tau}")
    if not isinstance(o.warmup, (bool, np.bool_)):
        raise ValueError(f"warmup: expected a bool, got {o.warmup!r}")
    f = jnp.float32
    return KernelOptions(f(alpha), jnp.bool_(o.rho == "alpha_eta"), f(lam * lam), f(v0), f(w0), f(vmin), f(ratio),
                         jnp.bool_(o.decision == "matched"), jnp.bool_(o.rho == "alpha_over_weight"), f(vmax),
                         jnp.bool_(o.decision == "background_match"), f(lam_d * lam_d), f(tau), jnp.bool_(o.warmup),
                         jnp.bool_(o.cleanup == "median3"))


def _cleaned(fg, o):
    """`BackgroundOptions.cleanup` on (..., H, W) masks."""
    return jax.lax.cond(o.median3, median3, lambda m: m, fg)


@jax.jit
def _update_jit(state, frame, mask, o, t):
    H, W = frame.shape[:2]
    w, mu, var = pixels_last(state)
    x = jnp.moveaxis(frame.reshape(H * W, -1), 1, 0).astype(jnp.float32)
    *new, fg = step_pixels_last(w, mu, var, x, ~mask.reshape(-1), o, t)
    return to_public(*new, H, W), _cleaned(fg.reshape(H, W), o)


def _run_one(state, frames, masks, o, t0=0):
    """masks None: every pixel learns (no (T, H, W) array of False made and copied)."""
    H, W = frames.shape[1:3]
    masks = jnp.zeros(frames.shape[:3], bool) if masks is None else masks
    (w, mu, var), fg = scan_pixels_last(*pixels_last(state), frames, masks, o, t0)
    return to_public(w, mu, var, H, W), fg.reshape(-1, H, W)


_run_jit = jax.jit(_run_one)
_clean_jit = jax.jit(_cleaned)
_init_jit = jax.jit(init_state, static_argnums=1)


@partial(jax.jit, static_argnums=(3, 4))
def _run_batch_jit(frames, masks, o, K: int, videos_per_step: int):
    """B videos, `videos_per_step` of them vmapped together, the groups one after another (`lax.map`)."""
    state = jax.vmap(init_state, in_axes=(0, None, None))(frames[:, 0], K, o)
    state, fg = jax.lax.map(lambda a: _run_one(*a, o), (state, frames, masks), batch_size=videos_per_step)
    return state, _cleaned(fg, o)


# ----------------------------------------------------------------------------- boundary checks
def _check_frames(frames, name: str, ndim: int, channels: int) -> np.ndarray:
    arr = as_array(frames, name, ndim=ndim, dtype=None, min_value=0, max_value=255)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise ValueError(f"{name}: expected uint8 or real pixel values in [0, 255], got dtype {arr.dtype}")
    if arr.shape[-1] != channels:
        raise ValueError(f"{name}: expected {channels} colour channels on the last axis, got shape {arr.shape}")
    return arr


def _check_masks(masks, name: str, shape: tuple[int, ...]) -> np.ndarray | None:
    if masks is None:
        return None
    arr = as_array(masks, name, dtype=None)
    if arr.shape != shape:
        raise ValueError(f"{name}: expected shape {shape} (True = do not update), got {arr.shape}")
    if arr.dtype != bool and not np.all((arr == 0) | (arr == 1)):
        raise ValueError(f"{name}: expected a boolean mask (or 0/1), got other values")
    return arr.astype(bool)


def _check_state(state, name: str, shape_hw: tuple[int, int], channels: int) -> BackgroundState:
    if not isinstance(state, BackgroundState):
        raise ValueError(f"{name}: expected a BackgroundState, got {type(state).__name__}")
    H, W = shape_hw
    K = np.shape(state.weights)[-1] if np.ndim(state.weights) == 3 else 0
    want = ((H, W, K), (H, W, K, channels), (H, W, K))
    got = tuple(np.shape(a) for a in state)
    if K < 1 or got != want:
        raise ValueError(f"{name}: expected weights, means, variances of shapes {want} for {H} x {W} frames, "
                         f"got {got}")
    return state


# ------------------------------------------------------------------------------------ public API
def init_background(first_frame: Real[ArrayLike, "H W C"], structure: BackgroundStructure = BackgroundStructure(),
                    options: BackgroundOptions = BackgroundOptions()) -> BackgroundState:
    """The background state before any update (LEVELSET TR §3.5).

    Component 0 at the first frame with weight 1 and the initial variance; the other K - 1 empty
    (weight 0: they never match).

    Args:
        first_frame: (H, W, C) the first frame, uint8 or real in [0, 255].
        structure: K and C (`BackgroundStructure`).
        options: the `BackgroundOptions` (its init_variance).

    Returns:
        The `BackgroundState`.

    Raises:
        ValueError: naming the argument for a frame of the wrong shape or dtype, NaN or values outside
            [0, 255], or bad options.
    """
    frame = _check_frames(first_frame, "first_frame", 3, structure.n_channels)
    return _init_jit(jnp.asarray(frame), structure.n_components, check_options(options))


def log_density(state: BackgroundState, frame: Real[ArrayLike, "H W C"], scale: float = 255.0) -> Float[Array, "H W"]:
    """Eq. 9's log P(X) of a frame under every pixel's mixture (LEVELSET TR §3.5).

    Args:
        state: the `BackgroundState`.
        frame: (H, W, C) a frame in [0, 255].
        scale: the density is of X / scale (255: the unit colour cube of the video colour models), > 0.

    Returns:
        (H, W) log-densities; -inf nowhere a component has weight.

    Raises:
        ValueError: naming the argument for a frame or state of other shapes, bad values or
            scale <= 0.
    """
    C = np.shape(state.means)[-1] if isinstance(state, BackgroundState) else 0
    arr = _check_frames(frame, "frame", 3, max(C, 1))
    _check_state(state, "state", arr.shape[:2], arr.shape[2])
    s = check_real(scale, "scale", min_value=0.0, exclusive_min=True)
    return _log_density_jit(state, jnp.asarray(arr), np.float32(s))


@jax.jit
def _log_density_jit(state, frame, scale):
    H, W = frame.shape[:2]
    x = jnp.moveaxis(frame.reshape(H * W, -1), 1, 0).astype(jnp.float32)
    return log_density_pixels_last(*pixels_last(state), x, scale).reshape(H, W)


def update(state: BackgroundState, frame: Real[ArrayLike, "H W C"],
           no_update_mask: Bool[ArrayLike, "H W"] | None = None,
           options: BackgroundOptions = BackgroundOptions(),
           frame_index: int | None = None) -> tuple[BackgroundState, Bool[Array, "H W"]]:
    """One frame of the Stauffer–Grimson update (LEVELSET TR §3.5, eqs. 9-10).

    Per pixel: the best matching component (highest w / sigma among those with |X - mu| <
    lambda sigma) moves by eq. 10; without a match the least probable component is replaced by one at
    X; weights are renormalised; the pixel is classified on the state after the update.

    Args:
        state: the `BackgroundState`.
        frame: (H, W, C) a frame in [0, 255].
        no_update_mask: (H, W) bool, True where a pixel keeps its state (the person and tracked
            objects, TR §3.5 last paragraph: still classified, never learned), or None.
        options: the `BackgroundOptions`.
        frame_index: the frame's 0-based index in the video, the clock of `options.warmup` (the first
            frame, learnt by `init_background`, is 0); None: alpha, no warm-up.

    Returns:
        (the new state, foreground (H, W) bool).

    Raises:
        ValueError: naming the argument for bad frames, masks or a state of other shapes, a negative
            frame_index, or bad options.
    """
    C = np.shape(state.means)[-1] if isinstance(state, BackgroundState) else 0
    arr = _check_frames(frame, "frame", 3, max(C, 1))
    _check_state(state, "state", arr.shape[:2], arr.shape[2])
    mask = _check_masks(no_update_mask, "no_update_mask", arr.shape[:2])
    mask = np.zeros(arr.shape[:2], bool) if mask is None else mask
    o = check_options(options)
    t = np.float32(1e30 if frame_index is None else check_int(frame_index, "frame_index", min_value=0))
    return _update_jit(state, jnp.asarray(arr), jnp.asarray(mask), o, t)


def _run(frames, no_update_masks, structure, options, ndim: int):
    """Checked numpy frames, masks (or None) and traced options."""
    arr = _check_frames(frames, "frames", ndim, structure.n_channels)
    return arr, _check_masks(no_update_masks, "no_update_masks", arr.shape[:-1]), check_options(options)


def _default_threads() -> int:
    """One host thread per core this process may use on the CPU backend; 1 on an accelerator."""
    if jax.default_backend() != "cpu":
        return 1
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


_POOL: list[ThreadPoolExecutor] = []


def _in_threads(fn, items: list) -> list:
    """[fn(item) for item in items], concurrently on host threads (XLA releases the GIL while a
    compiled call runs). On the CPU this beats XLA's own split of each fused loop over the cores: a
    frame is a dozen short fused loops, and every one of them ends in a barrier of all threads."""
    if len(items) == 1:
        return [fn(items[0])]
    if not _POOL:
        _POOL.append(ThreadPoolExecutor(max(_default_threads(), 2), thread_name_prefix="hog_jax.background"))
    return list(_POOL[0].map(fn, items))


def _parts(n: int, threads: int | None, name: str) -> list[slice]:
    """n items (rows or videos) in min(threads, n) contiguous parts of near-equal size (equal sizes
    share one compilation)."""
    k = _default_threads() if threads is None else check_int(threads, name, min_value=1)
    bounds = np.linspace(0, n, min(k, n) + 1).round().astype(int)
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def _part(masks, index):
    return None if masks is None else jnp.asarray(masks[index])


def _joined(results: list, fg_axis: int):
    """The parts' (state, foreground) put back together: states along their first axis (rows or
    videos), foregrounds along `fg_axis`."""
    if len(results) == 1:
        return results[0]
    states, fgs = zip(*results)
    return BackgroundState(*(jnp.concatenate(a, axis=0) for a in zip(*states))), jnp.concatenate(fgs, axis=fg_axis)


def run_background(frames: Real[ArrayLike, "T H W C"], no_update_masks: Bool[ArrayLike, "T H W"] | None = None,
                   structure: BackgroundStructure = BackgroundStructure(),
                   options: BackgroundOptions = BackgroundOptions(),
                   initial_state: BackgroundState | None = None,
                   threads: int | None = None, start_frame: int = 0) -> tuple[BackgroundState, Bool[Array, "T H W"]]:
    """Run the Stauffer–Grimson background model over a video (LEVELSET TR §3.5, eqs. 9-10).

    The state starts from `init_background(frames[0])` (or `initial_state`, to continue a video), and
    every frame, the first included, is classified and then learned (`update`) in one `lax.scan`.

    Args:
        frames: (T, H, W, C) a video, uint8 or real in [0, 255].
        no_update_masks: (T, H, W) bool, True where a frame's pixel is not learned (TR §3.5), or None.
        structure: K and C (`BackgroundStructure`).
        options: the `BackgroundOptions`.
        initial_state: a `BackgroundState` to continue from, or None.
        threads: the pixels are independent, so the rows are cut into this many stripes, each its own
            compiled scan on a host thread; the result does not depend on it. Default: one per core on
            the CPU backend, 1 on an accelerator.
        start_frame: the index of `frames[0]` in the video, the clock of `options.warmup`: 0 for a new
            video, the number of frames already seen when `initial_state` continues one (then the
            result equals one run over the whole video), >= 0.

    Returns:
        (the final `BackgroundState`, foreground (T, H, W) bool).

    Raises:
        ValueError: naming the argument for frames of the wrong shape or dtype, zero frames, NaN,
            values outside [0, 255], masks of another shape or non-boolean values, an initial state of
            other shapes, threads < 1, or bad options.
    """
    x, m, o = _run(frames, no_update_masks, structure, options, 4)
    if initial_state is not None:
        _check_state(initial_state, "initial_state", x.shape[1:3], x.shape[3])

    def stripe(rows: slice):
        frames_part = jnp.asarray(x[:, rows])
        if initial_state is None:
            state = _init_jit(frames_part[0], structure.n_components, o)
        else:
            state = BackgroundState(*(a[rows] for a in initial_state))
        # waited for in its thread: dispatched without waiting, the stripes' scans ran one after another
        return jax.block_until_ready(_run_jit(state, frames_part, _part(m, (slice(None), rows)), o, t0))

    t0 = np.float32(check_int(start_frame, "start_frame", min_value=0))
    state, fg = _joined(_in_threads(stripe, _parts(x.shape[1], threads, "threads")), fg_axis=1)
    return state, (fg if options.cleanup == "none" else _clean_jit(fg, o))


def _batch_shard(o, frames, *masks, K: int, videos_per_step: int):
    """`_run_batch_jit` on one shard's videos (B/S, T, H, W, C) of a batch split over a mesh."""
    return _run_batch_jit(frames, masks[0] if masks else None, o, K, min(videos_per_step, frames.shape[0]))


def run_background_batch(frames: Real[ArrayLike, "B T H W C"],
                         no_update_masks: Bool[ArrayLike, "B T H W"] | None = None,
                         structure: BackgroundStructure = BackgroundStructure(),
                         options: BackgroundOptions = BackgroundOptions(), videos_per_step: int | None = None,
                         threads: int | None = None, *,
                         mesh: Mesh | None = None) -> tuple[BackgroundState, Bool[Array, "B T H W"]]:
    """`run_background` for B videos of equal length in one call.

    Args:
        frames: (B, T, H, W, C) videos, uint8 or real in [0, 255].
        no_update_masks: (B, T, H, W) bool, or None.
        structure: K and C (`BackgroundStructure`).
        options: the `BackgroundOptions`.
        videos_per_step: how many videos are vmapped together (the groups run one after another in
            one compiled `lax.map`), 1..B. Default: all B on an accelerator; one on the CPU, where one
            video's state (K (C + 2) floats per pixel) stays in the cache from frame to frame and B of
            them would not.
        threads: the videos are cut into this many groups, each its own compiled call on a host
            thread; default one per core on the CPU, 1 on an accelerator.
        mesh: a `jax.sharding.Mesh`, or None for one device. The videos are split over its devices
            (padded to the mesh, the padding cut off; `threads` is then unused); the result equals the
            one-device result. With several processes each passes its own videos and gets its own back.

    Returns:
        (final states with a leading B axis, foreground (B, T, H, W) bool).

    Raises:
        ValueError: naming the argument, as `run_background`, for videos_per_step outside [1, B], and
            for a `mesh` that is not a `jax.sharding.Mesh`.
    """
    mesh = check_mesh(mesh)
    x, m, o = _run(frames, no_update_masks, structure, options, 5)
    B = x.shape[0]
    if videos_per_step is None:
        videos_per_step = 1 if jax.default_backend() == "cpu" else B
    step = check_int(videos_per_step, "videos_per_step", min_value=1, max_value=B)
    if mesh is not None:
        return map_batch(_batch_shard, mesh, (o,), (x,) if m is None else (x, m),
                         static=(("K", structure.n_components), ("videos_per_step", step)))

    def group(videos: slice):
        n = videos.stop - videos.start
        return jax.block_until_ready(_run_batch_jit(jnp.asarray(x[videos]), _part(m, videos), o,
                                                    structure.n_components, min(step, n)))

    return _joined(_in_threads(group, _parts(B, threads, "threads")), fg_axis=0)
