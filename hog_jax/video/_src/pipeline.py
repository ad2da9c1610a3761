"""From RGB video to skin / person / object / background masks (LEVELSET TR §3-5): the background
model, the colour models and the competing level sets put together, and the stereo pipeline to the
hand-minus-face position (LfD 2009 §III-A).

Shapes: B videos (optional leading axis), T frames, H x W pixels; R = 4 regions in `REGIONS` order,
whose index is the label (-1: no region, a boundary pixel, TR §3.2).

The region scores e_i(x) of eq. 7 (TR §3.2-3.6), all log-densities of the pixel's RGB / 255 in the
unit cube, so that they compete on one scale (equal priors, as eq. 2 assumes):

* skin: the skin mixture of the one skin model of stills and video (`hog_jax.SkinModel`, GRASP §III-A:
  skin and non-skin mixtures over (Cr, Cb) / 255 or (Cr, Cb, Y) / 255 and a log-ratio threshold;
  `lfd_jax.fit_real_skin_model` fits it on real pixels), as a density of RGB / 255: the mixture's
  density times |det| of the linear map from RGB to YCrCb (`skin_log_density`; a (Cr, Cb) model is
  uniform in Y), so that it competes with the RGB densities of the person and the background on one
  scale (a (Cr, Cb, Y) model carries the same information as an RGB one: the TR's skin GMM in a
  rotated colour space). With `white_balance` the mixture is first seen under the recording's light
  (gray-world gains of the frames before `start`, `hog_jax.balanced_skin_model`); with `adapt_skin` it is then adapted to this person (Reynolds' relevance MAP,
  `hog_jax.adapt_to_skin`) on the pixels the generic model is most sure of in the frames before
  `start` (log ratio above its threshold by `skin_margin`): the person's own face and hands;
* person, background: the GMMs learnt at the start of each recording, sizes by BIC (TR §3.4,
  `colour_models.fit_person_background_models`), from the frames just before `start`, whose moving
  pixels (the Stauffer–Grimson foreground, TR §3.5) are the person. Pixels the skin mixture matches
  (TR §3.6's per-model threshold: a skin density at least that of `skin_match_quantile` of the
  mixture's own draws) teach neither model: skin is a region of its own, and a person model that had learnt this person's face and arms would outscore the
  skin model on them;
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

from collections.abc import Iterable, Iterator, Sequence
import functools
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
from hog_jax._src.segment import GMM, SkinModel, gmm_log_prob, median3, skin_features, skin_log_ratio
from hog_jax._src.skin_adapt import adapt_to_skin
from hog_jax._src.white_balance import YCRCB_FROM_RGB, balanced_skin_model, gray_world_gains
from hog_jax.video._src.stereo import StereoCamera
from hog_jax.video._src.tracks import HandFaceOptions, HandFacePositions, hand_face_chunk
from lfd_common import as_array, check_int, check_real, progress

__all__ = ["REGIONS", "SegmentState", "StereoSegmentation", "VideoModels", "VideoOptions", "VideoSegmentation",
           "fit_video_models", "person_skin", "follow_light", "frame_log_densities",
           "init_segment_state", "join_chunks", "region_scores", "segment_chunk", "segment_recording", "segment_stereo",
           "skin_log_density", "stream_recording", "stream_stereo"]

REGIONS = ("background", "person", "skin", "object")
BACKGROUND, PERSON, SKIN, OBJECT = range(4)
# `VideoOptions.real_video()`'s cap on the fine scale's iterations after the coarse one (its docstring)
REAL_VIDEO_FINE_IT_MAX = 12
# and its motion penalty, nats (the docstring says how it was chosen)
REAL_VIDEO_MOTION_PENALTY = 6.0
# The object score of a pixel that does not move: far below any other region's (the level sets floor
# scores at the best minus their max_log_ratio), finite so that averaging it to the coarse scale stays
# finite.
_NOT_MOVING = -1e4


class VideoModels(NamedTuple):
    """The colour models of the region scores (LEVELSET TR §3.3-3.4).

    Attributes:
        skin: the skin model (`hog_jax.SkinModel`, over (Cr, Cb) or (Cr, Cb, Y) / 255), adapted to the
            recording's person where `VideoOptions.adapt_skin`.
        person: the person's `hog_jax.GMM` over RGB / 255, learnt at the start of the recording.
        background: the background's `hog_jax.GMM` over RGB / 255, learnt likewise.
    """

    skin: SkinModel
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
        ghost_quantile: the colour models' ghost rule (`fit_person_background_models`): None (the TR:
            every moving pixel teaches the person) or a quantile in (0, 1) (0.01 for real video, where
            the person is in view from the first frame and uncovers the wall behind them).
        skin_match_quantile: in (0, 1), the skin mixture's match threshold (TR §3.6): a colour whose skin
            density is at least that of this quantile of the mixture's own draws is skin, and teaches
            neither the person nor the background model.
        adapt_skin: adapt the skin mixture to the person at the start of the recording (module
            docstring; `hog_jax.adapt_to_skin`). Off by default: on the validation recordings it did
            not help in video (rendered clips: face IoU 0.63 against 0.78 without; the real reach
            clip: the hands stay unfound), although it does on still photos (`experiments.skin_real`).
        white_balance: see the skin mixture under the recording's light: gray-world gains of the
            frames before `start` (`hog_jax.gray_world_gains`) turn it into the model of this scene's
            colours (`hog_jax.balanced_skin_model`; a (Cr, Cb, Y) model), before any adaptation. Off by
            default (rendered recordings are lit white); on in `real_video()`: on the real reach clip's
            warm, dithered frames the unbalanced model marks 7-9 % of the pixels in the face and hand
            boxes as skin and 6 % of the whole frame, balanced 21-35 % against 3 %.
        skin_margin: nats, >= 0: the pixels the adaptation learns from have a log ratio at least this
            far above the skin model's threshold.
        skin_relevance: the adaptation's MAP relevance, pixels, > 0 (1024: chosen on validation photos
            by `experiments.skin_real --preset model`).
        background: the background model's `BackgroundOptions`.
        background_components: K, the background model's Gaussians per pixel, >= 1 (TR: 3;
            `BackgroundStructure.real_video()`: 5).
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
    ghost_quantile: float | None = None
    skin_match_quantile: float = 0.1
    adapt_skin: bool = False
    white_balance: bool = False
    skin_margin: float = 2.0
    skin_relevance: float = 1024.0
    background: BackgroundOptions = BackgroundOptions()
    background_components: int = 3
    levelset: LevelSetOptions = LevelSetOptions(reseed_margin=3.0)
    coarse_scale: bool = True

    @classmethod
    def real_video(cls, **changes) -> VideoOptions:
        """The options for real camera video: the background model of `BackgroundOptions.real_video()`
        with K = 5 (`BackgroundStructure.real_video()`, chosen on six real sequences), the colour
        models' ghost rule at 0.01, the skin mixture seen under the recording's light (`white_balance`),
        the motion penalty `REAL_VIDEO_MOTION_PENALTY`, the fine scale's iterations after the coarse one
        capped at `REAL_VIDEO_FINE_IT_MAX` (`LevelSetOptions.fine_it_max`), the rest the defaults, then
        `changes` (field = value).

        The motion penalty: people who walk in after the colour models were learnt are not in the
        person model, and where their colours are the room's the background GMM outscored the moving
        pixel's "object" score by more than the default 4 nats; on two validation sequences (SBI
        HumanBody2 and Candela, 200 frames, segmented from frame 50) the front end's foreground F1 was
        0.40 / 0.50 at 4 nats, 0.68 / 0.51 at 6, 0.74 / 0.50 at 8; 6 is the largest that keeps every
        face and hand track of the real reach clip on its box (at 8 the reaching hand leaves it in one
        more annotated frame). A margin on the object's score instead (4 nats) took the reach clip's skin
        from 2 % of the pixels to 0.2 %.

        The cap is for real time at 320 x 240 on two CPU cores: on noisy camera frames the fine
        contour rarely settles below the length rule's tolerance, and its iterations were the bulk of
        the front end's time, while the person masks of a real sequence hardly change after a dozen.
        Frames below 240 x 320 run one scale, which the cap does not touch.

        Returns:
            The `VideoOptions`.
        """
        real = cls(background=BackgroundOptions.real_video(),
                   background_components=BackgroundStructure.real_video().n_components, ghost_quantile=0.01,
                   white_balance=True, motion_penalty=REAL_VIDEO_MOTION_PENALTY,
                   levelset=cls._field_defaults["levelset"]._replace(fine_it_max=REAL_VIDEO_FINE_IT_MAX))
        return real._replace(**changes)


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


ADAPT_PIXELS = 4096  # the most pixels the skin adaptation learns from (a random sample of the sure ones)
MIN_ADAPT_PIXELS = 16  # fewer sure pixels than this: the generic model is kept


def person_skin(skin: SkinModel, frames: Real[ArrayLike, "T H W 3"], options: VideoOptions = VideoOptions(),
                moving: Bool[ArrayLike, "T H W"] | None = None) -> SkinModel:
    """The skin model adapted to a recording's person (GRASP §III-A's model, Reynolds' relevance MAP):
    its skin mixture moved towards the pixels of `frames` whose log ratio is at least
    `options.skin_margin` above the model's threshold and that move with the person (`moving`: a
    skin-coloured table or a wooden ruler stands still; at most `ADAPT_PIXELS` of them, sampled with a
    fixed seed), with relevance `options.skin_relevance` (`hog_jax.adapt_to_skin`). With fewer than
    `MIN_ADAPT_PIXELS` such pixels the model is returned as is.

    Args:
        skin: the generic `hog_jax.SkinModel`.
        frames: (T, H, W, 3) RGB frames in [0, 255] (those before the segmentation starts).
        options: the `VideoOptions` (`skin_margin`, `skin_relevance`).
        moving: (T, H, W) bool, the person's moving pixels (the background model's foreground), or
            None for every pixel.

    Returns:
        The adapted `SkinModel` (its background mixture and threshold unchanged).

    Raises:
        ValueError: naming the argument for bad frames, a `moving` of another shape, a negative
            margin or a relevance <= 0.
    """
    arr = _check_frames(frames, "frames")
    where = True if moving is None else as_array(moving, "moving", shape=arr.shape[:3], dtype=bool)
    margin = check_real(options.skin_margin, "skin_margin", min_value=0.0)
    relevance = check_real(options.skin_relevance, "skin_relevance", min_value=0.0, exclusive_min=True)
    sure = (np.asarray(skin_log_ratio(skin, arr)) > float(skin.threshold) + margin) & where
    pixels = arr[sure]
    if len(pixels) < MIN_ADAPT_PIXELS:
        return skin
    if len(pixels) > ADAPT_PIXELS:
        pixels = pixels[np.random.default_rng(0).choice(len(pixels), ADAPT_PIXELS, replace=False)]
    return adapt_to_skin(skin, pixels, relevance)


def _check_frames(frames, name: str, ndims=(4,)) -> np.ndarray:
    arr = as_array(frames, name, ndim=ndims, dtype=None, min_value=0, max_value=255)
    if arr.shape[-1] != 3 or arr.shape[-4] == 0:
        raise ValueError(f"{name}: expected (..., T, H, W, 3) RGB frames with T >= 1, got shape {arr.shape}")
    return arr


def _check_models(models) -> VideoModels:
    """`models` if it is a `VideoModels` of a `SkinModel` and two `GMM`s, else a ValueError naming it
    (inside jit a wrong type would only show as an AttributeError or a tracing error)."""
    if not isinstance(models, VideoModels):
        raise ValueError(f"models: expected a VideoModels, got {type(models).__name__}")
    for field, kind in zip(VideoModels._fields, (SkinModel, GMM, GMM)):
        if not isinstance(getattr(models, field), kind):
            raise ValueError(f"models.{field}: expected a {kind.__name__}, got {type(getattr(models, field)).__name__}")
    return models


def skin_threshold(skin: GMM, quantile: float, n_draws: int = 20000, seed: int = 0) -> float:
    """The log-density above which a colour is matched by the skin mixture `skin` (TR §3.6), in the
    mixture's own colour space: the `quantile` of its log-densities at `n_draws` of its own draws
    (0.1: its 90 % highest-density region)."""
    q = check_real(quantile, "skin_match_quantile", min_value=0.0, max_value=1.0, exclusive_min=True)
    rng = np.random.default_rng(seed)
    weights = np.exp(np.asarray(skin.log_weights, np.float64))
    component = rng.choice(len(weights), n_draws, p=weights / weights.sum())
    z = rng.standard_normal((n_draws, skin.means.shape[-1]))
    draws = np.asarray(skin.means)[component] + np.einsum("nij,nj->ni", np.asarray(skin.chols)[component], z)
    return float(np.quantile(np.asarray(gmm_log_prob(skin, jnp.asarray(draws, jnp.float32))), q))


def _check_start(start, n_frames: int, person_frames: int) -> int:
    return check_int(start, "start", min_value=person_frames + 1, max_value=n_frames - 1)


def fit_video_models(key: Key[Array, ""], skin: SkinModel, frames: Real[ArrayLike, "T H W 3"], start: int,
                     options: VideoOptions = VideoOptions(), candidates: Sequence[int] = (1, 2, 3, 4, 5),
                     max_pixels: int = 20000) -> tuple[VideoModels, ColourFit]:
    """The recording's colour models, learnt at its start (LEVELSET TR §3.4).

    The Stauffer–Grimson model runs over frames[:start]; its foreground in the
    `options.person_frames` frames before `start` (median-filtered) is the person, the rest the
    background, both without the pixels the skin mixture matches (`VideoOptions.skin_match_quantile`);
    both GMMs are chosen by BIC over `candidates` (`fit_person_background_models`). With
    `options.white_balance` the skin mixture is first seen under the recording's light, with
    `options.adapt_skin` adapted to the person (module docstring).

    Args:
        key: a `jax.random` key.
        skin: the skin model (`hog_jax.SkinModel`, e.g. `lfd_jax.fit_real_skin_model`).
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
    if not isinstance(skin, SkinModel):
        raise ValueError(f"skin: expected a hog_jax.SkinModel (lfd_jax.fit_real_skin_model), got {type(skin).__name__}")
    arr = _check_frames(frames, "frames")
    n = check_int(options.person_frames, "person_frames", min_value=1)
    start = _check_start(start, arr.shape[0] + 1, n)
    structure = BackgroundStructure(check_int(options.background_components, "background_components", min_value=1))
    _, foreground = run_background(arr[:start], structure=structure, options=options.background)
    person = np.asarray(median3(foreground[start - n:start]))
    frames_n = arr[start - n:start]
    if options.white_balance:
        skin = balanced_skin_model(skin, gray_world_gains(arr[:start]))
    if options.adapt_skin:
        skin = person_skin(skin, frames_n, options, moving=person)
    features = skin_features(frames_n, skin.skin.means.shape[-1] == 3)
    skin_like = np.asarray(gmm_log_prob(skin.skin, features)) >= skin_threshold(skin.skin, options.skin_match_quantile)
    fit = fit_person_background_models(key, frames_n, person, BICOptions(candidates=candidates), max_pixels=max_pixels,
                                       space="rgb", ignore=skin_like, ghost_quantile=options.ghost_quantile)
    return VideoModels(skin, fit.models.person, fit.models.background), fit


def gmm_planes_log_prob(gmm: GMM, planes: Sequence[Float[Array, "*P"]]) -> Float[Array, "*P"]:
    """`hog_jax.gmm_log_prob` of pixels given as colour planes (x_0, ..., x_{P-1}), each (...), for a
    small mixture: per component the whitened difference L^{-1} (x - mu) with L^{-1} inverted once
    (P x P) and applied by unrolled multiply-adds, then an unrolled log-sum-exp over the components,
    all elementwise over the pixels (one fused loop). The same density as `gmm_log_prob` to float32
    rounding (~1e-6 nats); about ten times faster per frame on XLA:CPU, whose batched form of the
    per-pixel (G, P) whitening and reduction over G is slow. Traceable."""
    P = len(planes)
    inv = jnp.linalg.inv(gmm.chols)  # (G, P, P), lower triangular
    logdet = jnp.sum(jnp.log(jnp.diagonal(gmm.chols, axis1=-2, axis2=-1)), axis=-1)
    const = gmm.log_weights - logdet - 0.5 * P * jnp.log(2 * jnp.pi)
    comps = []
    for k in range(gmm.means.shape[0]):
        d = [planes[i] - gmm.means[k, i] for i in range(P)]
        maha = sum((sum(inv[k, i, j] * d[j] for j in range(i + 1)) ** 2 for i in range(P)), jnp.zeros_like(d[0]))
        comps.append(const[k] - 0.5 * maha)
    top = functools.reduce(jnp.maximum, comps)
    top = jnp.where(jnp.isfinite(top), top, 0.0)  # every component of weight 0: -inf, as logsumexp
    return top + jnp.log(sum(jnp.exp(c - top) for c in comps))


def _planes(frame):
    """(H, W, 3) in [0, 255] -> the three colour planes (H, W) of RGB / 255."""
    x = _unit_rgb(frame)
    return [x[..., c] for c in range(x.shape[-1])]


# log |det| of the linear map from RGB / 255 to (Cr, Cb, Y) / 255 (BT.601 with OpenCV's coefficients,
# `hog_jax.skin_features`): the skin mixture's density over YCrCb times this is a density over RGB
_LOG_DET_YCRCB = float(np.log(abs(np.linalg.det(YCRCB_FROM_RGB))))


def skin_log_density(models: VideoModels, planes: Sequence[Float[Array, "*P"]]) -> Float[Array, "*P"]:
    """The skin region's colour log-density (TR §3.3, GRASP §III-A) of pixels given as their colour
    planes (R, G, B) / 255, each (...): the skin model's skin mixture over (Cr, Cb) / 255 (uniform in
    Y) or (Cr, Cb, Y) / 255, as a density of RGB / 255 (module docstring). Traceable; the one place
    where the video pipeline scores skin."""
    r, g, b = planes
    y = 0.299 * r + 0.587 * g + 0.114 * b
    features = [(r - y) * 0.713 + 128.0 / 255.0, (b - y) * 0.564 + 128.0 / 255.0]
    if models.skin.skin.means.shape[-1] == 3:
        features.append(y)
    return gmm_planes_log_prob(models.skin.skin, features) + _LOG_DET_YCRCB


def frame_log_densities(models: VideoModels, frame: Real[Array, "H W 3"]) -> Float[Array, "3 H W"]:
    """One frame in [0, 255] -> (3, H, W): its background, person and skin colour log-densities
    (TR §3.3-3.4; `gmm_planes_log_prob`). Traceable."""
    planes = _planes(frame)
    return jnp.stack([gmm_planes_log_prob(models.background, planes), gmm_planes_log_prob(models.person, planes),
                      skin_log_density(models, planes)])


@jax.jit
def colour_log_densities(models: VideoModels, frames):
    """(.., T, H, W, 3) in [0, 255] -> (.., T, 3, H, W): `frame_log_densities` frame by frame
    (`lax.map`: one frame's (H, W, G, 3) intermediates stay in cache, where the whole video's would
    not)."""
    flat = frames.reshape(-1, *frames.shape[-3:])
    return jax.lax.map(partial(frame_log_densities, models), flat).reshape(*frames.shape[:-3], 3, *frames.shape[-3:-1])


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
    # the sum over the K components unrolled: the same additions in the same order, but XLA:CPU's
    # reduction over a leading axis of (K, C, N) was about ten times slower
    change = functools.reduce(jnp.add, [mu_after[k] - mu_before[k] for k in range(mu_after.shape[0])])
    moved = jnp.sum(change * w, axis=-1)  # (C,)
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
        ValueError: naming the argument for models that are not `VideoModels`, frames that are not
            (.., T, H, W, 3) in [0, 255], a foreground of another shape, or bad options.
    """
    models = _check_models(models)
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
    return jnp.maximum(densities[..., 1, :, :], densities[..., 2, :, :]) > densities[..., 0, :, :]


class SegmentState(NamedTuple):
    """The carry of the video segmentation between frames and chunks (LEVELSET TR §3.5, §3.7).

    Leading axis (B,) for a batch of videos on every field but `frame`.

    Attributes:
        weights: (.., K, N) the background model's weights, N = H W pixels (the kernel's layout).
        means: (.., K, 3, N) its means.
        variances: (.., K, N) its variances.
        phi: (.., R, H, W) float32 the level sets of the last segmented frame (zeros before `start`).
        claimed: (.., N) bool: before `start` the previous frame's foreground, from `start` on the
            previous frame's pixels of another region than the background (the hold of TR §3.5).
        frame: () int32 the index in the video of the next frame.
    """

    weights: Float[Array, "*B K N"]
    means: Float[Array, "*B K 3 N"]
    variances: Float[Array, "*B K N"]
    phi: Float[Array, "*B R H W"]
    claimed: Bool[Array, "*B N"]
    frame: Int[Array, ""]


def _init_one(first, bo, K: int):
    H, W, _ = first.shape
    w, mu, var = bgk.pixels_last(bgk.init_state(first, K, bo))
    return w, mu, var, jnp.zeros((len(REGIONS), H, W), jnp.float32), jnp.zeros(H * W, bool)


@partial(jax.jit, static_argnums=2)
def _init_jit(first, bo, K: int):
    """first (B, H, W, 3) -> a `SegmentState` with leading B."""
    return SegmentState(*jax.vmap(_init_one, in_axes=(0, None, None))(first, bo, K), jnp.int32(0))


def init_segment_state(first: Real[ArrayLike, "*B H W 3"], options: VideoOptions = VideoOptions()) -> SegmentState:
    """The segmentation's state before a video's first frame (`segment_chunk`): the background model
    started from the first frame (TR §3.5), no level sets, nothing claimed.

    Args:
        first: (H, W, 3) the video's first frame, or (B, H, W, 3) those of B videos, in [0, 255].
        options: the `VideoOptions` (the background model's).

    Returns:
        A `SegmentState` (leading B on its per-video fields for a batch).

    Raises:
        ValueError: naming `first` for a frame that is not (.., H, W, 3) in [0, 255], and as
            `BackgroundOptions`.
    """
    arr = as_array(first, "first", ndim=(3, 4), dtype=None, min_value=0, max_value=255)
    if arr.shape[-1] != 3:
        raise ValueError(f"first: expected an (.., H, W, 3) RGB frame, got shape {arr.shape}")
    bo = check_background_options(options.background)
    K = check_int(options.background_components, "background_components", min_value=1)
    state = _init_jit(jnp.asarray(arr if arr.ndim == 4 else arr[None]), bo, K)
    return state if arr.ndim == 4 else state._replace(**{f: getattr(state, f)[0] for f in SegmentState._fields[:-1]})


def _step_one(structure: LevelSetStructure, start, margins, follow, bo, lo, carry, x, densities, mode):
    """One frame of one video: carry (w, mu, var, phi, claimed, t), x (C, N) the frame, densities
    (3, H, W) its `frame_log_densities`, mode 0 padding (nothing changes), 1 training (t < start), 2
    segmenting -> (carry, (labels (H, W) int8, foreground (H, W), fine-scale iterations, converged)). Before `start` the background model
    does not learn what moved in the previous frame; from `start` on each frame is classified, learnt
    outside the held pixels, scored and segmented from the previous frame's level sets (module
    docstring). `t` is the frame's index in the video."""
    H, W = structure.shape
    t = carry[-1]
    state = carry[:-1]

    def learn(bg, x, held):
        w, mu, var, fg = bgk.step_pixels_last(*bg, x, ~held, bo, t.astype(jnp.float32))
        return (w, jnp.where(follow, follow_light(bg[1], mu, x, ~held & ~fg, held), mu), var), fg

    def padding(state):
        return state, (jnp.zeros((H, W), jnp.int8), jnp.zeros((H, W), bool), jnp.int32(0), jnp.bool_(False))

    def training(state):  # no labels yet: what moved in the previous frame is held (TR §3.5)
        *bg, phi, moved = state
        bg, fg = learn(tuple(bg), x.astype(jnp.float32), moved)
        labels = jnp.where(fg, jnp.int8(PERSON), jnp.int8(BACKGROUND)).reshape(H, W)
        return (*bg, phi, fg), (labels, fg.reshape(H, W), jnp.int32(0), jnp.bool_(False))

    def segmenting(state):
        *bg, phi, claimed = state
        dens = densities
        first = t == start
        # before the first segmented frame no labels exist: what moved or has the person's colour counts as claimed
        claimed = jnp.where(first, claimed | person_coloured(dens).reshape(-1), claimed)
        xf = x.astype(jnp.float32)
        held = claimed & person_coloured(dens).reshape(-1)
        own = bgk.log_density_pixels_last(*bg, xf)  # before this frame's update
        background = jnp.logaddexp(dens[0].reshape(-1), own) - jnp.log(2.0)
        bg, fg = learn(tuple(bg), xf, held)
        fg = fg.reshape(H, W)
        dens = dens.at[0].set(background.reshape(H, W))
        res = levelset.segment_frame(structure, levelset.FIXED, _scores(dens, fg, *margins), phi, first, lo)
        claimed = res.labels.reshape(-1) != BACKGROUND
        return (*bg, res.phi, claimed), (res.labels.astype(jnp.int8), fg, res.iterations, res.converged)

    return jax.lax.switch(mode, (padding, training, segmenting), state)


@partial(jax.jit, static_argnames=("structure",))
def _chunk_jit(structure: LevelSetStructure, models: VideoModels, state: SegmentState, frames, n_valid, start,
               margins, follow, bo, lo):
    """frames (B, t, H, W, 3), of which the first n_valid are real (the rest padding) -> (the state
    after them, `_step_one`'s outputs (B, t, ...)). One compilation per chunk length t (and B, H, W);
    `start`, `n_valid` and the state's frame index are traced."""
    B, t_len, H, W, C = frames.shape
    one = partial(_step_one, structure, start, margins, follow, bo, lo)
    # the colour densities of the whole chunk before the scan: vectorised over the frames they cost about a
    # sixth of what the same computation costs inside the scan's loop on XLA:CPU (measured at 320 x 240)
    densities = jax.vmap(jax.vmap(partial(frame_log_densities, models)))(frames)  # (B, t, 3, H, W)

    def step(carry, inp):
        per_video, t = carry
        k, frame, dens = inp
        x = jnp.moveaxis(frame.reshape(B, H * W, C), 2, 1)  # (B, C, N), the background kernel's layout
        mode = jnp.where(k >= n_valid, 0, jnp.where(t < start, 1, 2))
        if B == 1:  # no batched while loops (as levelset's kernel)
            new, out = one((*[a[0] for a in per_video], t), x[0], dens[0], mode)
            new, out = tuple(a[None] for a in new), tuple(a[None] for a in out)
        else:  # mode and t are shared by the videos: the switch stays a switch under vmap
            new, out = jax.vmap(lambda c, x, d: one((*c, t), x, d, mode))(per_video, x, dens)
        return (new, t + jnp.where(k < n_valid, 1, 0)), out

    per_video = tuple(state[:-1])
    (per_video, t), outs = jax.lax.scan(step, (per_video, state.frame),
                                        (jnp.arange(t_len), jnp.moveaxis(frames, 1, 0), jnp.moveaxis(densities, 1, 0)))
    return SegmentState(*per_video, t), tuple(jnp.moveaxis(o, 0, 1) for o in outs)


def _checked_structure(shape: tuple[int, int], options: VideoOptions) -> LevelSetStructure:
    if not isinstance(options.coarse_scale, (bool, np.bool_)):
        raise ValueError(f"coarse_scale: expected a bool, got {options.coarse_scale!r}")
    return LevelSetStructure(len(REGIONS), shape, _coarse(shape) if options.coarse_scale else None)


def segment_chunk(models: VideoModels, state: SegmentState, frames: Real[ArrayLike, "*B T H W 3"], start: int,
                  options: VideoOptions = VideoOptions(), pad_to: int | None = None
                  ) -> tuple[SegmentState, VideoSegmentation]:
    """`segment_recording` on a chunk of frames, from the state after the previous chunk (TR §3-5).

    The chunks of a video in order, each from the state the previous one returned (the first from
    `init_segment_state` of the video's first frame), give the masks of `segment_recording` on the
    whole video: the background model, the hold and the level sets are carried from frame to frame
    (TR §3.5, §3.7), and the frame index in the state tells training frames (before `start`) from
    segmented ones. One compilation serves every chunk of one length; `pad_to` pads a shorter chunk
    (the last one of a video) to that length, the padded frames changing nothing.

    Args:
        models: the `VideoModels` (`fit_video_models`).
        state: the `SegmentState` (`init_segment_state`, or the previous chunk's).
        frames: (T, H, W, 3) the chunk's frames, or (B, T, H, W, 3) for B videos (the state's B), in
            [0, 255].
        start: the video's first segmented frame (`segment_recording`), >= 1.
        options: the `VideoOptions` (the same for every chunk).
        pad_to: compile for chunks of this many frames, >= T (None: T).

    Returns:
        (the state after the chunk, the chunk's `VideoSegmentation` with the leading axes of the
        frames).

    Raises:
        ValueError: naming the argument for models that are not `VideoModels`, bad frames, a state of
            other videos or frame size, a start < 1, a pad_to below T, or bad options.
    """
    models = _check_models(models)
    arr = _check_frames(frames, "frames", ndims=(4, 5))
    batched = arr.ndim == 5
    x = arr if batched else arr[None]
    B, T, H, W, _ = x.shape
    if not isinstance(state, SegmentState) or np.shape(state.phi) != ((B,) if batched else ()) + (len(REGIONS), H, W):
        raise ValueError(f"state: expected the SegmentState of {B if batched else 'one'} video(s) of {H} x {W} "
                         f"frames (init_segment_state)")
    start = check_int(start, "start", min_value=1)
    length = T if pad_to is None else check_int(pad_to, "pad_to", min_value=T)
    if length > T:
        x = np.concatenate([x, np.repeat(x[:, -1:], length - T, axis=1)], axis=1)
    carry = state if batched else SegmentState(*(a[None] for a in state[:-1]), state.frame)
    structure = _checked_structure((H, W), options)
    carry, out = _chunk_jit(structure, models, carry, jnp.asarray(x), np.int32(T), np.int32(start),
                            _checked_margins(options), _checked_follow(options),
                            check_background_options(options.background), levelset.check_options(options.levelset))
    seg = VideoSegmentation(*(o[:, :T] for o in out))
    if batched:
        return carry, seg
    return SegmentState(*(a[0] for a in carry[:-1]), carry.frame), jax.tree.map(lambda a: a[0], seg)


def _frames_of(chunks, name):
    for chunk in chunks:
        yield _check_frames(chunk, name, ndims=(4, 5))


def stream_recording(models: VideoModels, chunks: Iterable[Real[ArrayLike, "*B T H W 3"]], start: int,
                     options: VideoOptions = VideoOptions(), total: int | None = None
                     ) -> Iterator[VideoSegmentation]:
    """`segment_recording` chunk by chunk, for a recording that does not fit in memory (TR §3-5).

    Each chunk is segmented from the state the previous one left (`segment_chunk`) and its masks are
    yielded before the next chunk is read, so that memory holds one chunk, never the video. Chunks
    shorter than the first (the last one) are padded to its length: one compilation. A progress bar
    counts the frames on stderr (silent when the environment variable `LFD_NO_PROGRESS` is set).

    Args:
        models: the `VideoModels` (`fit_video_models`).
        chunks: an iterable of (T_k, H, W, 3) frames (or (B, T_k, H, W, 3) for B videos), e.g.
            `lfd_jax.iter_video`, uint8 or real in [0, 255].
        start: the first segmented frame of the recording (`segment_recording`), >= 1.
        options: the `VideoOptions`.
        total: the recording's number of frames, for the progress bar (None: unknown).

    Returns:
        An iterator of each chunk's `VideoSegmentation` (leading axes as the chunk's frames).

    Raises:
        ValueError: as `segment_chunk`, when the chunk that raises is reached.
    """
    state, length = None, None
    with progress(desc="segmenting", total=total, unit="frame") as bar:
        for x in _frames_of(chunks, "chunks"):
            if state is None:
                state, length = init_segment_state(x[..., 0, :, :, :], options), x.shape[-4]
            state, seg = segment_chunk(models, state, x, start, options, pad_to=max(length, x.shape[-4]))
            bar.update(x.shape[-4])
            yield seg


def stereo_chunks(models, chunks, start, camera, options, tracking, bar=None):
    """`stream_stereo`'s generator; `bar` (a progress bar or None) counts the frames."""
    state = tracks = length = None
    for left, right in chunks:
        a, b = _check_pair(left, right)
        both = np.stack([a, b])
        if state is None:
            state, length = init_segment_state(both[:, 0], options), a.shape[0]
        state, seg = segment_chunk(models, state, both, start, options, pad_to=max(length, a.shape[0]))
        labels = np.asarray(seg.labels)
        tracks, positions = hand_face_chunk(labels[0], labels[1], camera, tracks, skin_label=SKIN,
                                            object_label=OBJECT, options=tracking)
        if bar is not None:
            bar.update(a.shape[0])
        yield StereoSegmentation(jax.tree.map(lambda v: v[0], seg), jax.tree.map(lambda v: v[1], seg), positions)


def segment_recording(models: VideoModels, frames: Real[ArrayLike, "*T H W 3"], start: int,
                      options: VideoOptions = VideoOptions()) -> VideoSegmentation:
    """Skin, person, object and background masks of a video (LEVELSET TR §3-5).

    The background model runs over all frames; from `start` on it does not learn the held pixels (the
    previous frame's person, skin or object that still has the person's or the skin's colour, TR
    §3.5), in one `lax.scan` with the level sets, which warm-start from frame to frame (TR §3.7). The
    background's score is the equal mixture of its GMM and the pixel's own Stauffer–Grimson mixture
    before this frame's update (eq. 9), so that a pixel that still matches its own model stays
    background however far the light has moved its colour. The whole video is one chunk of
    `segment_chunk` (`stream_recording` reads it chunk by chunk).

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
    start = _check_start(start, arr.shape[-4], 0)
    return segment_chunk(models, init_segment_state(arr[..., 0, :, :, :], options), arr, start, options)[1]


def _check_pair(left, right, ndims=(4,)):
    a = _check_frames(left, "left", ndims)
    b = _check_frames(right, "right", ndims)
    if a.shape != b.shape:
        raise ValueError(f"right: expected the shape of left {a.shape}, got {b.shape}")
    return a, b


def stream_stereo(models: VideoModels, chunks: Iterable[tuple[Real[ArrayLike, "T H W 3"], Real[ArrayLike, "T H W 3"]]],
                  start: int, camera: StereoCamera, options: VideoOptions = VideoOptions(),
                  tracking: HandFaceOptions = HandFaceOptions(), total: int | None = None
                  ) -> Iterator[StereoSegmentation]:
    """`segment_stereo` chunk by chunk: both views' masks and the tracks, carried across chunks.

    The segmentation state (`segment_chunk`) and the trackers' state (`hand_face_chunk`) go from one
    chunk to the next; each chunk's `StereoSegmentation` is yielded before the next is read. Chunks
    shorter than the first are padded to its length (one compilation). A progress bar counts the
    frames (silent when `LFD_NO_PROGRESS` is set).

    Args:
        models: the recording's colour models (`fit_video_models`).
        chunks: an iterable of (left (T_k, H, W, 3), right (T_k, H, W, 3)) frame pairs, e.g.
            `lfd_jax.iter_stereo_videos`.
        start: the first segmented frame (`segment_recording`), >= 1.
        camera: the rectified pair (`StereoCamera`), its image H x W.
        options: the segmentation options (`VideoOptions`).
        tracking: the blob and tracker options (`HandFaceOptions`).
        total: the recording's number of frames, for the progress bar (None: unknown).

    Returns:
        An iterator of each chunk's `StereoSegmentation`.

    Raises:
        ValueError: as `segment_stereo`, when the chunk that raises is reached.
    """
    with progress(desc="segmenting", total=total, unit="frame") as bar:
        yield from stereo_chunks(models, chunks, start, camera, options, tracking, bar)


def join_chunks(parts: Sequence, axis: int = 0):
    """The per-chunk results of a stream (NamedTuples of arrays, None fields kept) joined along `axis`
    (the frame axis)."""
    return jax.tree.map(lambda *a: np.concatenate([np.asarray(x) for x in a], axis=axis), *parts)


def segment_stereo(models: VideoModels, left: Real[ArrayLike, "T H W 3"], right: Real[ArrayLike, "T H W 3"],
                   start: int, camera: StereoCamera, options: VideoOptions = VideoOptions(),
                   tracking: HandFaceOptions = HandFaceOptions()) -> StereoSegmentation:
    """The stereo front end: both views' masks and the tracked hand-minus-face position.

    Stereo frames -> masks of both views (one batched `segment_recording`, LEVELSET TR §3-5) ->
    skin blobs tracked as hand and face, objects tracked (`hand_face_positions`, LEVELSET TR §3.7)
    -> the hand-minus-face position in the left image (2-D) and triangulated (3-D) (LfD 2009
    §III-A). The whole recording is one chunk of `stream_stereo`.

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
    a, b = _check_pair(left, right)
    start = _check_start(start, a.shape[0], 0)
    return next(stereo_chunks(models, [(a, b)], start, camera, options, tracking))
