"""From RGB video to skin / person / object / background masks (LEVELSET TR §3-5): the background
model, the colour models and the competing level sets put together, and the stereo pipeline to the
hand-minus-face position (LfD 2009 §III-A).

Shapes: B videos (optional leading axis), T frames, H x W pixels; R = 4 regions in `REGIONS` order,
whose index is the label (-1: no region, a boundary pixel, TR §3.2).

The region scores e_i(x) of eq. 7 (TR §3.2-3.6), all log-densities of the pixel's RGB / 255 in the
unit cube, so that they compete on one scale (equal priors, as eq. 2 assumes):

* skin: the skin GMM (TR §3.3: 4 components), fitted in advance on skin pixels (`fit_skin`);
* person, background: the GMMs learnt at the start of each recording, sizes by BIC (TR §3.4,
  `colour_models.fit_person_background_models`), from the frames just before `start`, whose moving
  pixels (the Stauffer–Grimson foreground, TR §3.5) are the person. Pixels the skin model matches
  (TR §3.6's per-model threshold: a skin density at least that of `skin_match_quantile` of the skin
  model's own draws) teach neither model: skin is a region of its own, and a person model that had
  learnt this person's face and arms would outscore the generic skin model on them;
* background: the equal mixture of the background GMM and the pixel's own Stauffer–Grimson mixture
  before this frame's update (eq. 9, `background.log_density`). A pixel that still matches its own
  model stays background however far the drifting light has moved its colour from what the GMM
  learnt at the start: on a validation recording a table the colour of the person's clothing
  otherwise turned "person" for good. The own model counts also where another region claimed the
  pixel: scored by the GMM alone there, a white pitcher on the table turned "person" at once on
  grey-clothed validation persons (person IoU 0.687 against 0.663, mean of six validation clips);
* background also loses `motion_penalty` nats where the background model sees motion: a moving
  pixel is not background whatever its colour (the objects stood on the table while the background
  was learnt, so their colours are in the background GMM);
* object (TR §3.6, §4: "pixels that are not matched to any of our three models, and that are
  moving"): the uniform density on the colour cube (log 1 = 0) plus `object_margin`, on moving
  pixels only (a large negative score elsewhere). A moving pixel whose every model density is below the uniform one
  is an unrecognised object.

The TR's background model does not update pixels that belong to the person or a tracked object
(TR §3.5), so that a person sitting still is not absorbed into the background. Here a pixel is held
(classified, not learnt) where the previous frame's segmentation gave it to another region than
the background (`claimed`; for the first segmented frame: what the background model saw move or has
the person's or the skin's colour) *and* its colour in this frame is the person's or the skin's
(their density beats the background GMM's). So the background model and the level sets run in one `lax.scan` over the
frames from `start` on, carrying the background state and the level sets together. Each half alone
fails, both seen on validation recordings: held by colour alone, wall pixels whose colour drifted
near the clothing's with the light stopped adapting and turned "person"; held by label alone, a
table the colour of the clothing, once the person's level set had spread onto it beside the arm,
was never learnt again, moved against its stale model and stayed "person" to the end (the label
feeds the hold, the hold the motion, the motion the label). A pixel the person has just left is
learnt at once (its colour is the background's again). A held pixel's model is not frozen against
the light: it follows the mean change of the pixels learnt in the same frame (`follow_light`).
"""
from __future__ import annotations

from collections.abc import Sequence
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int, Key, Real

from hog_jax._src.checks import check_key
from hog_jax.video._src import background_kernel as bgk
from hog_jax.video._src.background import check_options as check_background_options
from hog_jax.video._src.background import BackgroundOptions, BackgroundStructure, run_background
from hog_jax.video._src.colour_models import BICOptions, ColourFit, fit_person_background_models
from hog_jax.video._src import levelset_evolution as levelset
from hog_jax.video._src.levelset_evolution import LevelSetOptions, LevelSetStructure
from hog_jax._src.segment import GMM, fit_gmm, gmm_log_prob, median3
from hog_jax.video._src.stereo import StereoCamera
from hog_jax.video._src.tracks import HandFaceOptions, HandFacePositions, hand_face_positions
from lfd_common import as_array, check_int, check_real

__all__ = ["REGIONS", "StereoSegmentation", "VideoModels", "VideoOptions", "VideoSegmentation", "fit_skin",
           "fit_video_models", "follow_light", "region_scores", "segment_recording", "segment_stereo"]

REGIONS = ("background", "person", "skin", "object")
BACKGROUND, PERSON, SKIN, OBJECT = range(4)
# The object score of a pixel that does not move: far below any other region's (the level sets floor
# scores at the best minus their max_log_ratio), finite so that averaging it to the coarse scale stays
# finite.
_NOT_MOVING = -1e4


class VideoModels(NamedTuple):
    """The three colour mixtures of the region scores, over RGB / 255 (LEVELSET TR §3.3-3.4).

    Attributes:
        skin: the skin `hog_jax.GMM` (P = 3; `fit_skin`).
        person: the person's `hog_jax.GMM`, learnt at the start of the recording.
        background: the background's `hog_jax.GMM`, learnt likewise.
    """

    skin: GMM
    person: GMM
    background: GMM


class VideoOptions(NamedTuple):
    """The options of the video front end (LEVELSET TR §3-5).

    Attributes:
        motion_penalty: nats, >= 0, the background's score loses this where the background model
            sees motion (a moving pixel is not background whatever its colour).
        object_margin: nats added to the object's uniform score (log 1 = 0) on moving pixels (TR §3.6,
            §4: "pixels that are not matched to any of our three models, and that are moving").
        follow_light: the held pixels' background models follow the frame's mean change of the learnt
            ones (`follow_light`).
        person_frames: how many frames before `start` teach the person and background GMMs, >= 1.
        skin_match_quantile: in (0, 1), the skin model's match threshold (TR §3.6): a colour whose skin
            density is at least that of this quantile of the model's own draws is skin, and teaches
            neither the person nor the background model.
        background: the background model's `BackgroundOptions`.
        levelset: the level sets' `LevelSetOptions`; by default they re-seed a region where its score
            beats every other by 3 nats (`reseed_margin`), so that a hand hidden in one frame comes
            back in the next.
        coarse_scale: TR §5's coarse scale (a quarter of each side) before the fine one on frames
            from 240 x 320 up; False: the fine scale alone. At a quarter of 240 x 320 a hand held out
            from the body is 2-3 pixels wide, averaged with the sleeve into "person", and the fine
            scale, started from there, keeps it person where skin beats person by less than the
            re-seed margin.
    """

    motion_penalty: float = 4.0
    object_margin: float = 0.0
    follow_light: bool = True
    person_frames: int = 10
    skin_match_quantile: float = 0.1
    background: BackgroundOptions = BackgroundOptions()
    levelset: LevelSetOptions = LevelSetOptions(reseed_margin=3.0)
    coarse_scale: bool = True


class VideoSegmentation(NamedTuple):
    """The region masks of a video (LEVELSET TR §3-5).

    Leading axes (.., T): (T,) or (B, T).

    Attributes:
        labels: (.., T, H, W) int8 in `REGIONS` order (-1: boundary); frames before `start` carry the
            training phase's answer (1 where the background model sees motion, else 0).
        foreground: (.., T, H, W) bool, the background model's motion mask.
        iterations: (.., T) int32 level-set iterations at the fine scale (0 before `start`).
        converged: (.., T) bool, the level sets stopped by the contour-length rule.
    """

    labels: Int[Array, "*T H W"]
    foreground: Bool[Array, "*T H W"]
    iterations: Int[Array, "*T"]
    converged: Bool[Array, "*T"]


class StereoSegmentation(NamedTuple):
    """Both views' masks and the tracked hand-minus-face positions (`segment_stereo`).

    Attributes:
        left: the left view's `VideoSegmentation`.
        right: the right view's `VideoSegmentation`.
        positions: the `HandFacePositions`.
    """

    left: VideoSegmentation
    right: VideoSegmentation
    positions: HandFacePositions


def _unit_rgb(frames):
    return jnp.asarray(frames, jnp.float32) / 255.0


def fit_skin(key: Key[Array, ""], skin_rgb: Real[ArrayLike, "N 3"], n_components: int = 4, n_iter: int = 100) -> GMM:
    """The skin GMM of LEVELSET TR §3.3 over RGB / 255 of skin pixels (by `hog_jax.fit_gmm`).

    Args:
        key: a `jax.random` key.
        skin_rgb: (N, 3) skin pixels, RGB in [0, 255].
        n_components: the mixture's components (TR: 4).
        n_iter: EM iterations.

    Returns:
        The skin `hog_jax.GMM` (P = 3).

    Raises:
        ValueError: naming the argument for pixels that are not (N, 3) in [0, 255], or as
            `hog_jax.fit_gmm`.
    """
    x = as_array(skin_rgb, "skin_rgb", shape=(None, 3), min_value=0, max_value=255)
    return fit_gmm(key, np.asarray(x, np.float32) / 255.0, n_components=n_components, n_iter=n_iter)


def _check_frames(frames, name: str, ndims=(4,)) -> np.ndarray:
    arr = as_array(frames, name, ndim=ndims, dtype=None, min_value=0, max_value=255)
    if arr.shape[-1] != 3 or arr.shape[-4] == 0:
        raise ValueError(f"{name}: expected (..., T, H, W, 3) RGB frames with T >= 1, got shape {arr.shape}")
    return arr


def skin_threshold(skin: GMM, quantile: float, n_draws: int = 20000, seed: int = 0) -> float:
    """The log-density above which a colour is matched by `skin` (TR §3.6): the `quantile` of the
    model's log-densities at `n_draws` of its own draws (0.1: its 90 % highest-density region)."""
    q = check_real(quantile, "skin_match_quantile", min_value=0.0, max_value=1.0, exclusive_min=True)
    rng = np.random.default_rng(seed)
    weights = np.exp(np.asarray(skin.log_weights, np.float64))
    component = rng.choice(len(weights), n_draws, p=weights / weights.sum())
    z = rng.standard_normal((n_draws, skin.means.shape[-1]))
    draws = np.asarray(skin.means)[component] + np.einsum("nij,nj->ni", np.asarray(skin.chols)[component], z)
    return float(np.quantile(np.asarray(gmm_log_prob(skin, jnp.asarray(draws, jnp.float32))), q))


def _check_start(start, n_frames: int, person_frames: int) -> int:
    return check_int(start, "start", min_value=person_frames + 1, max_value=n_frames - 1)


def fit_video_models(key: Key[Array, ""], skin: GMM, frames: Real[ArrayLike, "T H W 3"], start: int,
                     options: VideoOptions = VideoOptions(), candidates: Sequence[int] = (1, 2, 3, 4, 5),
                     max_pixels: int = 20000) -> tuple[VideoModels, ColourFit]:
    """The recording's colour models, learnt at its start (LEVELSET TR §3.4).

    The Stauffer–Grimson model runs over frames[:start]; its foreground in the
    `options.person_frames` frames before `start` (median-filtered) is the person, the rest the
    background, both without the pixels the skin model matches (`VideoOptions.skin_match_quantile`);
    both GMMs are chosen by BIC over `candidates` (`fit_person_background_models`).

    Args:
        key: a `jax.random` key.
        skin: the skin `hog_jax.GMM` (`fit_skin`).
        frames: (T, H, W, 3) RGB frames in [0, 255]: the empty scene, then the person entering.
        start: the first frame of the segmentation phase; it must leave at least one empty frame
            before the person frames.
        options: the `VideoOptions`.
        candidates: the numbers of components BIC chooses from.
        max_pixels: the most pixels per region for the fits.

    Returns:
        (`VideoModels`, the BIC fit `ColourFit`).

    Raises:
        ValueError: naming the argument for a key that is not a `jax.random` key, bad frames, a start
            out of range, or bad options or candidates.
    """
    check_key(key, "key")
    arr = _check_frames(frames, "frames")
    n = check_int(options.person_frames, "person_frames", min_value=1)
    start = _check_start(start, arr.shape[0] + 1, n)
    _, foreground = run_background(arr[:start], options=options.background)
    person = np.asarray(median3(foreground[start - n:start]))
    frames_n = arr[start - n:start]
    skin_like = np.asarray(gmm_log_prob(skin, _unit_rgb(frames_n))) >= skin_threshold(skin, options.skin_match_quantile)
    fit = fit_person_background_models(key, frames_n, person, BICOptions(candidates=candidates), max_pixels=max_pixels,
                                       space="rgb", ignore=skin_like)
    return VideoModels(skin, fit.models.person, fit.models.background), fit


@jax.jit
def colour_log_densities(models: VideoModels, frames):
    """(.., T, H, W, 3) in [0, 255] -> (.., T, 3, H, W): background, person and skin log-densities,
    frame by frame (`lax.map`: one frame's (H, W, G, 3) intermediates stay in cache, where the whole
    video's would not)."""
    flat = frames.reshape(-1, *frames.shape[-3:])

    def one(frame):
        x = _unit_rgb(frame)
        return jnp.stack([gmm_log_prob(models.background, x), gmm_log_prob(models.person, x),
                          gmm_log_prob(models.skin, x)])

    return jax.lax.map(one, flat).reshape(*frames.shape[:-3], 3, *frames.shape[-3:-1])


@jax.jit
def _scores(densities, foreground, motion_penalty, object_margin):
    """Region scores (.., T, 4, H, W) from `colour_log_densities` and the motion mask (.., T, H, W)."""
    background = densities[..., 0, :, :] - motion_penalty * foreground.astype(jnp.float32)
    unmatched = jnp.where(foreground, object_margin, _NOT_MOVING)
    return jnp.stack([background, densities[..., 1, :, :], densities[..., 2, :, :], unmatched], axis=-3)


def _checked_margins(options: VideoOptions):
    penalty = check_real(options.motion_penalty, "motion_penalty", min_value=0.0)
    margin = check_real(options.object_margin, "object_margin")
    return jnp.float32(penalty), jnp.float32(margin)


def _checked_follow(options: VideoOptions):
    if not isinstance(options.follow_light, (bool, np.bool_)):
        raise ValueError(f"follow_light: expected a bool, got {options.follow_light!r}")
    return jnp.bool_(options.follow_light)


def follow_light(mu_before: Float[Array, "K C N"], mu_after: Float[Array, "K C N"], x: Float[Array, "C N"],
                 followed: Bool[Array, "N"], held: Bool[Array, "N"]) -> Float[Array, "K C N"]:
    """Scale the held pixels' background means by the light change of the learnt pixels (LEVELSET TR §3.5).

    The TR's hold freezes a pixel's model while the person covers it; the scene's light keeps
    changing, and a held wall pixel whose light had drifted beyond the 2.5 sigma match when the arm
    left it would stay foreground, and then "person", for good. The held pixels' components are scaled
    by 1 + s_c, s_c (per channel) the relative change of the followed pixels' means this frame:
    sum_n sum_k (mu_after - mu_before)[k, c, n] / sum_n x[c, n]. The light of a demonstration scene is
    one scale on every lamp, a global gain; a real camera's exposure and daylight change the same way
    to first order. Traceable; no input checks.

    Args:
        mu_before: (K, C, N) the means before this frame's update (pixels last).
        mu_after: (K, C, N) the means after it.
        x: (C, N) the frame.
        followed: (N,) bool, the pixels learnt and matched (one component moved, by rho (X - mu)).
        held: (N,) bool, the pixels not learnt.

    Returns:
        (K, C, N) the means after the update, the held pixels' scaled (s = 0 where nothing was
        followed).
    """
    w = followed.astype(mu_after.dtype)
    moved = jnp.sum(jnp.sum(mu_after - mu_before, axis=0) * w, axis=-1)  # (C,)
    level = jnp.sum(x * w, axis=-1)
    s = jnp.where(level > 0, moved / jnp.where(level > 0, level, 1.0), 0.0)
    return jnp.where(held, mu_after * (1.0 + s[None, :, None]), mu_after)


def region_scores(models: VideoModels, frames: Real[ArrayLike, "*T H W 3"], foreground: Bool[ArrayLike, "*T H W"],
                  options: VideoOptions = VideoOptions()) -> Float[Array, "*T 4 H W"]:
    """The region scores e_i(x) of LEVELSET TR eq. 7 for the four regions (TR §3.2-3.6).

    All are log-densities of the pixel's RGB / 255 in the unit cube, so that they compete on one
    scale: skin and person by their GMMs; background by its GMM, minus `motion_penalty` where the
    background model sees motion; object the uniform density plus `object_margin` on moving pixels
    only. (`segment_recording` also mixes the background's own Stauffer–Grimson density in.)

    Args:
        models: the `VideoModels`.
        frames: (.., T, H, W, 3) RGB frames in [0, 255].
        foreground: (.., T, H, W) the background model's foreground.
        options: the `VideoOptions` (motion_penalty, object_margin).

    Returns:
        (.., T, 4, H, W) scores in `REGIONS` order.

    Raises:
        ValueError: naming the argument for frames that are not (.., T, H, W, 3) in [0, 255], a
            foreground of another shape, or bad options.
    """
    arr = _check_frames(frames, "frames", ndims=(4, 5))
    fg = as_array(foreground, "foreground", shape=arr.shape[:-1], dtype=None)
    densities = colour_log_densities(models, jnp.asarray(arr))
    return _scores(densities, jnp.asarray(fg, bool), *_checked_margins(options))


def _coarse(shape: tuple[int, int]) -> tuple[int, int] | None:
    """TR §5's coarse scale, a quarter of each side (60 x 80 for 240 x 320), from 240 x 320 up;
    smaller frames use one scale (a hand of a few pixels would vanish at a quarter of their size)."""
    H, W = shape
    return (H // 4, W // 4) if H % 4 == 0 and W % 4 == 0 and min(H, W) >= 240 else None


def person_coloured(densities):
    """(.., H, W) from (.., 3, H, W) densities: the person or the skin density beats the background's."""
    return jnp.max(densities[..., 1:, :, :], axis=-3) > densities[..., 0, :, :]


def _segment_one(structure: LevelSetStructure, frames, densities, start: int, margins, follow, bo, lo):
    """One video: frames (T, H, W, 3), densities (T, 3, H, W) -> labels (T, H, W) int8, foreground
    (T, H, W), fine-scale iterations (T,), converged (T,). Before `start` the background model does
    not learn what moved in the previous frame; from `start` on each frame is classified, learnt
    outside the held pixels, scored and segmented from the previous frame's level sets (module
    docstring)."""
    T, H, W, C = frames.shape
    xs = jnp.moveaxis(frames.reshape(T, H * W, C), 2, 1)  # (T, C, N), the background kernel's layout
    state = bgk.pixels_last(bgk.init_state(frames[0], BackgroundStructure().n_components, bo))

    def learn(state, x, held):
        w, mu, var, fg = bgk.step_pixels_last(*state, x, ~held, bo)
        return (w, jnp.where(follow, follow_light(state[1], mu, x, ~held & ~fg, held), mu), var), fg

    def training(carry, x):  # no labels yet: what moved in the previous frame is held (TR §3.5)
        state, moved = carry
        state, fg = learn(state, x.astype(jnp.float32), moved)
        return (state, fg), fg

    (state, _), fg_before = jax.lax.scan(training, (state, jnp.zeros(H * W, bool)), xs[:start])

    def step(carry, inp):
        state, phi, claimed = carry
        t, x, dens = inp
        x = x.astype(jnp.float32)
        held = claimed & person_coloured(dens).reshape(-1)
        own = bgk.log_density_pixels_last(*state, x)  # before this frame's update
        background = jnp.logaddexp(dens[0].reshape(-1), own) - jnp.log(2.0)
        state, fg = learn(state, x, held)
        fg = fg.reshape(H, W)
        dens = dens.at[0].set(background.reshape(H, W))
        res = levelset.segment_frame(structure, levelset.FIXED, _scores(dens, fg, *margins), phi, t == 0, lo)
        claimed = res.labels.reshape(-1) != BACKGROUND
        return (state, res.phi, claimed), (res.labels, fg, res.iterations, res.converged)

    phi0 = jnp.zeros((len(REGIONS), H, W), jnp.float32)
    # before the first segmented frame no labels exist: what moved or has the person's colour counts as claimed
    carry = (state, phi0, fg_before[-1] | person_coloured(densities[start]).reshape(-1))
    _, (labels, fg, iterations, converged) = jax.lax.scan(
        step, carry, (jnp.arange(T - start), xs[start:], densities[start:]))
    before = jnp.where(fg_before.reshape(start, H, W), jnp.int8(PERSON), jnp.int8(BACKGROUND))
    pad = jnp.zeros(start, jnp.int32)
    return (jnp.concatenate([before, labels.astype(jnp.int8)]), jnp.concatenate([fg_before.reshape(start, H, W), fg]),
            jnp.concatenate([pad, iterations]), jnp.concatenate([pad.astype(bool), converged]))


@partial(jax.jit, static_argnames=("structure", "start"))
def _segment_jit(structure: LevelSetStructure, models: VideoModels, frames, start: int, margins, follow, bo, lo):
    """frames (B, T, H, W, 3) -> `_segment_one`'s outputs with a leading B (vmapped where B > 1)."""
    densities = colour_log_densities(models, frames)
    one = partial(_segment_one, structure, start=start, margins=margins, follow=follow, bo=bo, lo=lo)
    if frames.shape[0] == 1:  # no batched while loops (as levelset's kernel)
        return jax.tree.map(lambda a: a[None], one(frames[0], densities[0]))
    return jax.vmap(one)(frames, densities)


def segment_recording(models: VideoModels, frames: Real[ArrayLike, "*T H W 3"], start: int,
                      options: VideoOptions = VideoOptions()) -> VideoSegmentation:
    """Skin, person, object and background masks of a video (LEVELSET TR §3-5).

    The background model runs over all frames; from `start` on it does not learn the held pixels (the
    previous frame's person, skin or object that still has the person's or the skin's colour, TR
    §3.5), in one `lax.scan` with the level sets, which warm-start from frame to frame (TR §3.7). The
    background's score is the equal mixture of its GMM and the pixel's own Stauffer–Grimson mixture
    before this frame's update (eq. 9), so that a pixel that still matches its own model stays
    background however far the light has moved its colour.

    Args:
        models: the `VideoModels` (`fit_video_models`).
        frames: (T, H, W, 3) a video or (B, T, H, W, 3) a batch, uint8 or real in [0, 255]; the frames
            before `start` are the empty scene, then the person entering (TR §3).
        start: the first frame of the segmentation phase, 1 <= start < T.
        options: the `VideoOptions`.

    Returns:
        A `VideoSegmentation` with the leading axes of the frames.

    Raises:
        ValueError: naming the argument for bad frames, a start out of range, or bad options.
    """
    arr = _check_frames(frames, "frames", ndims=(4, 5))
    batched = arr.ndim == 5
    start = _check_start(start, arr.shape[-4], 0)
    margins = _checked_margins(options)
    shape = tuple(arr.shape[-3:-1])
    if not isinstance(options.coarse_scale, (bool, np.bool_)):
        raise ValueError(f"coarse_scale: expected a bool, got {options.coarse_scale!r}")
    structure = LevelSetStructure(len(REGIONS), shape, _coarse(shape) if options.coarse_scale else None)
    x = jnp.asarray(arr if batched else arr[None])
    out = _segment_jit(structure, models, x, start, margins, _checked_follow(options),
                       check_background_options(options.background),
                       levelset.check_options(options.levelset))
    seg = VideoSegmentation(*out)
    return seg if batched else jax.tree.map(lambda a: a[0], seg)


def segment_stereo(models: VideoModels, left: Real[ArrayLike, "T H W 3"], right: Real[ArrayLike, "T H W 3"],
                   start: int, camera: StereoCamera, options: VideoOptions = VideoOptions(),
                   tracking: HandFaceOptions = HandFaceOptions()) -> StereoSegmentation:
    """The stereo front end: both views' masks and the tracked hand-minus-face position.

    Stereo frames -> masks of both views (one batched `segment_recording`, LEVELSET TR §3-5) ->
    skin blobs tracked as hand and face, objects tracked (`hand_face_positions`, LEVELSET TR §3.7)
    -> the hand-minus-face position in the left image (2-D) and triangulated (3-D) (LfD 2009
    §III-A).

    Args:
        models: the recording's colour models (`fit_video_models`).
        left: (T, H, W, 3) RGB frames of the left view, uint8 or real in [0, 255].
        right: (T, H, W, 3) RGB frames of the right view, rectified.
        start: the first frame of the segmentation phase (see `segment_recording`).
        camera: the rectified pair (`StereoCamera`), its image H x W.
        options: the segmentation options (`VideoOptions`).
        tracking: the blob and tracker options (`HandFaceOptions`); the skin and object labels are
            `SKIN` and `OBJECT`.

    Returns:
        A `StereoSegmentation`: both views' `VideoSegmentation` and the `HandFacePositions`.

    Raises:
        ValueError: naming the argument, as `segment_recording` and `hand_face_positions`, and for a
            pair of other sizes (`right`).
    """
    a = _check_frames(left, "left")
    b = _check_frames(right, "right")
    if a.shape != b.shape:
        raise ValueError(f"right: expected the shape of left {a.shape}, got {b.shape}")
    both = segment_recording(models, np.stack([a, b]), start, options)
    views = jax.tree.map(lambda v: v[0], both), jax.tree.map(lambda v: v[1], both)
    labels = np.asarray(both.labels)
    positions = hand_face_positions(labels[0], labels[1], camera, skin_label=SKIN, object_label=OBJECT,
                                    options=tracking)
    return StereoSegmentation(*views, positions)
