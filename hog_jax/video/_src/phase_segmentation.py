"""Likelihoods of the manipulated object around the hand from gradient phase (LfD 2009 §III-B,
eqs. 1-4, Fig. 3b-g): which pixels of a window around the hand move with the hand (temporal cue)
and lie at the hand's depth (stereo cue).

Shapes: T frames, H x W images, a window of h x w = (2 hh + 1) x (2 hw + 1) pixels around the hand
position p (row, column), delta its offsets. Positions are rounded to whole pixels.

* Phase (`gradient_phase`): Psi = arctan((dI/dy) / (dI/dx)) of the Gaussian-blurred grey image (the
  paper blurs "increasing image scale ... making the phase less noisy"), central differences, in
  *degrees* in [-90, 90). Phase differences are taken modulo 180 degrees into [-90, 90) (an
  orientation, not a direction). Degrees, because the paper's sigma_m is "the width of the hand"
  (tens of pixels) and its ratio threshold exp(0.01): in radians a difference is at most pi/2, so
  |log r| <= (pi/2)^2 / (2 sigma^2) < 0.003 for sigma = 20 and no pixel could pass the threshold.
* Temporal cue (eq. 1 and the text's background hypothesis): foreground G(Psi_t(p_t + delta) -
  Psi_{t-1}(p_{t-1} + delta); 0, sigma_m), the object translated with the hand; background the same
  with Psi_{t-1}(p_t + delta), a static scene. Eq. 2 as printed repeats eq. 1's argument; the text
  ("the rest of the scene near the hand is static") compares the same image position at t and
  t - 1, which is what is computed here. log r_m = log fg - log bg.
* Stereo cue (eqs. 3-4): foreground G(Psi^L_t(p^L_t + delta) - Psi^R_t(p^R_t + delta); 0,
  sigma_s), the pixel at the hand's disparity; background the mean over N random disparity offsets
  rho_n (whole pixels, uniform in [-max_offset, max_offset], along the rows: rectified cameras) of
  G(Psi^L_t(p^L_t + delta) - Psi^R_t(p^R_t + (0, rho_n) + delta)), the pixel at any depth.
  log r_s = log fg - log bg. The mean is taken over the 2 max_offset + 1 possible offsets, each
  weighted by how often it was drawn: the same mean, in 2 max_offset + 1 terms whatever N.

Pixels of a window outside the image have no phase: they are flagged (`valid` False) and their log
ratio is 0; a background sample outside the image is left out of eq. 4's mean (a pixel with none
inside is invalid). Everything is vmapped over frames; the Gaussians' normalisers cancel in the
ratios. `segment_objects` computes the phase only on crops around the windows the cues read, with
the full frame's values (the same blur, border padding and one-sided border gradient).
"""
from __future__ import annotations

import dataclasses
from functools import partial
from typing import NamedTuple

import cv2
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Key

from hog_jax._src.checks import check_key
from hog_jax.video._src.phase import crop_phase, frame_phase, gaussian_kernel
from lfd_common import as_array, check_int, check_real

__all__ = ["CHUNK", "LogRatio", "ObjectOptions", "ObjectSegmentation", "gradient_phase", "object_masks",
           "segment_objects", "stereo_log_ratio", "temporal_log_ratio"]


class LogRatio(NamedTuple):
    """A cue's log-likelihood ratio in the window around the hand (LfD 2009 §III-B, eqs. 1-4).

    Attributes:
        log_ratio: (T, h, w) log P_fg - log P_bg of each window pixel (0 where not valid).
        valid: (T, h, w) bool, every sample the pixel needs lies inside the image.
    """

    log_ratio: Float[Array, "T h w"]
    valid: Bool[Array, "T h w"]


def gradient_phase(images: Float[ArrayLike, "*T H W"], blur_sigma: float = 2.0) -> Float[Array, "*T H W"]:
    """The gradient phase Psi of Gaussian-blurred grey images (LfD 2009 §III-B).

    Psi = arctan((dI/dy) / (dI/dx)) of the blurred image (the paper blurs "increasing image scale ...
    making the phase less noisy"), central differences, in degrees in [-90, 90) (an orientation, not a
    direction). Degrees, because the paper's sigma_m is "the width of the hand" (tens of pixels): in
    radians no pixel could pass its threshold exp(0.01).

    Args:
        images: (..., H, W) grey images, H, W >= 2.
        blur_sigma: the Gaussian blur, pixels, > 0.

    Returns:
        (..., H, W) Psi in degrees.

    Raises:
        ValueError: naming the argument for NaN, fewer than 2 rows or columns, or blur_sigma <= 0.
    """
    arr = as_array(images, "images", dtype=np.float32)
    if arr.ndim < 2 or min(arr.shape[-2:]) < 2:
        raise ValueError(f"images: expected (..., H, W) with H, W >= 2, got shape {arr.shape}")
    sigma = check_real(blur_sigma, "blur_sigma", min_value=0.0, exclusive_min=True)
    flat = arr.reshape(-1, *arr.shape[-2:])
    return frame_phase(jnp.asarray(flat), gaussian_kernel(sigma)).reshape(arr.shape)


def _window(phase, centre, half: tuple[int, int]):
    """phase (H, W) -> the (h, w) window around centre (2,): a gather, NaN outside the image."""
    H, W = phase.shape
    rows = centre[0] + jnp.arange(-half[0], half[0] + 1)[:, None]
    cols = centre[1] + jnp.arange(-half[1], half[1] + 1)[None, :]
    inside = (rows >= 0) & (rows < H) & (cols >= 0) & (cols < W)
    return jnp.where(inside, phase[jnp.clip(rows, 0, H - 1), jnp.clip(cols, 0, W - 1)], jnp.nan)


def _log_gauss(d, sigma):
    """log G(d; 0, sigma) up to its normaliser for a difference d of two phases in [-90, 90) (so in
    (-180, 180)), taken modulo 180 by one exact shift (NaN stays NaN)."""
    d = jnp.where(d >= 90.0, d - 180.0, jnp.where(d < -90.0, d + 180.0, d))
    return -0.5 * (d / sigma) ** 2


def _temporal_ratio(now, moved, static, sigma) -> LogRatio:
    """Eq. 1 over the static background from the windows (.., h, w) of Psi_t(p_t + delta),
    Psi_{t-1}(p_{t-1} + delta) and Psi_{t-1}(p_t + delta)."""
    ratio = _log_gauss(now - moved, sigma) - _log_gauss(now - static, sigma)
    valid = jnp.isfinite(ratio)
    return LogRatio(jnp.where(valid, ratio, 0.0), valid)


@partial(jax.jit, static_argnames="half")
def _temporal(psi, centres, sigma, half: tuple[int, int]):
    """psi (T, H, W), centres (T, 2) -> LogRatio of frames 1..T-1 (T - 1, h, w)."""
    window = jax.vmap(partial(_window, half=half))
    return _temporal_ratio(window(psi[1:], centres[1:]), window(psi[:-1], centres[:-1]),
                           window(psi[:-1], centres[1:]), sigma)


def _stereo_ratio(window_l, strip_r, counts, sigma) -> LogRatio:
    """Eq. 3 over eq. 4 for one frame from the left window (h, w) and the right view's strip (h, w +
    2 d) around p^R (the window widened by d each side): eq. 4's mean over the draws, as the mean
    over the 2 d + 1 possible offsets -d..d weighted by how often each was drawn (`counts` (2 d +
    1,), `_offset_counts`), the samples outside the image left out."""
    h, w = window_l.shape
    d = (len(counts) - 1) // 2
    fg = _log_gauss(window_l - strip_r[:, d:d + w], sigma)
    shifted = jnp.stack([strip_r[:, k:k + w] for k in range(2 * d + 1)], axis=1)  # (h, 2 d + 1, w): offset k - d
    samples = _log_gauss(window_l[:, None] - shifted, sigma)
    inside = jnp.isfinite(samples)
    n_inside = jnp.sum(jnp.where(inside, counts[:, None], 0.0), axis=1)
    bg = jax.nn.logsumexp(jnp.where(inside, samples + jnp.log(counts)[:, None], -jnp.inf), axis=1)  # log 0: not drawn
    valid = jnp.isfinite(fg) & (n_inside > 0)
    return LogRatio(jnp.where(valid, fg - jnp.where(valid, bg - jnp.log(jnp.maximum(n_inside, 1.0)), 0.0), 0.0),
                    valid)


@partial(jax.jit, static_argnames="half")
def _stereo(left, right, centres_left, centres_right, counts, sigma, half: tuple[int, int]):
    """left, right (T, H, W), centres (T, 2), counts (2 d + 1,) -> LogRatio (T, h, w)."""
    strip_half = (half[0], half[1] + (len(counts) - 1) // 2)

    def frame(psi_l, psi_r, c_l, c_r):
        return _stereo_ratio(_window(psi_l, c_l, half), _window(psi_r, c_r, strip_half), counts, sigma)

    return jax.vmap(frame)(left, right, centres_left, centres_right)


def _offset_counts(key, n_samples: int, max_offset: int) -> np.ndarray:
    """Eq. 4's N = n_samples offsets rho_n drawn from `key` (whole pixels, uniform in [-max_offset,
    max_offset]) as how often each of the 2 d + 1 possible offsets was drawn (2 d + 1,): the mean
    over the N samples then costs 2 d + 1 terms, not N (fewer wherever N > 2 d + 1, as with the
    paper's N = 100 and d the half window)."""
    drawn = np.asarray(jax.random.randint(key, (n_samples,), -max_offset, max_offset + 1))
    return np.bincount(drawn + max_offset, minlength=2 * max_offset + 1).astype(np.float32)


def _check_positions(positions, name: str, n_frames: int) -> np.ndarray:
    arr = as_array(positions, name, shape=(n_frames, 2))
    return np.round(arr).astype(np.int32)


def _check_window(half_window) -> tuple[int, int]:
    if np.ndim(half_window) != 1 or len(half_window) != 2:
        raise ValueError(f"half_window: expected (rows, columns), got {half_window!r}")
    return tuple(check_int(v, "half_window", min_value=0) for v in half_window)


def _check_phase(phase, name: str) -> np.ndarray:
    arr = as_array(phase, name, ndim=3, dtype=np.float32)
    if arr.shape[0] < 1:
        raise ValueError(f"{name}: expected (T, H, W) phase images with T >= 1, got shape {arr.shape}")
    return arr


def temporal_log_ratio(phase: Float[ArrayLike, "T H W"], hand: Float[ArrayLike, "T 2"],
                       half_window: tuple[int, int], sigma: float) -> LogRatio:
    """The temporal cue log r_m of the window around the hand (LfD 2009 §III-B, eq. 1).

    Foreground G(Psi_t(p_t + delta) - Psi_{t-1}(p_{t-1} + delta); 0, sigma_m): the object translated
    with the hand; background the same with Psi_{t-1}(p_t + delta): the static scene. Eq. 2 as printed
    repeats eq. 1's argument; the text ("the rest of the scene near the hand is static") compares the
    same image position at t and t - 1, which is what is computed. Phase differences are taken modulo
    180 degrees.

    Args:
        phase: (T, H, W) phase images (`gradient_phase`), T >= 2.
        hand: (T, 2) the hand's position (row, column; rounded).
        half_window: (hh, hw) the window's half sizes, >= 0.
        sigma: sigma_m, degrees, > 0.

    Returns:
        A `LogRatio` (T - 1, h, w) of frames 1..T-1.

    Raises:
        ValueError: naming the argument for T < 2, NaN phases or positions, positions of another
            shape, a bad window or sigma <= 0.
    """
    psi = _check_phase(phase, "phase")
    if psi.shape[0] < 2:
        raise ValueError(f"phase: the temporal cue needs T >= 2 frames, got {psi.shape[0]}")
    centres = _check_positions(hand, "hand", psi.shape[0])
    s = check_real(sigma, "sigma", min_value=0.0, exclusive_min=True)
    return _temporal(jnp.asarray(psi), jnp.asarray(centres), np.float32(s), _check_window(half_window))


def stereo_log_ratio(key: Key[Array, ""], left: Float[ArrayLike, "T H W"], right: Float[ArrayLike, "T H W"],
                     hand_left: Float[ArrayLike, "T 2"], hand_right: Float[ArrayLike, "T 2"],
                     half_window: tuple[int, int], sigma: float, max_offset: int,
                     n_samples: int = 100) -> LogRatio:
    """The stereo cue log r_s of the window around the hand (LfD 2009 §III-B, eqs. 3-4).

    Foreground G(Psi^L_t(p^L_t + delta) - Psi^R_t(p^R_t + delta); 0, sigma_s): the pixel at the hand's
    disparity; background (eq. 4) the mean over N random disparity offsets rho_n (whole pixels,
    uniform in [-max_offset, max_offset], along the rows of rectified views) of the same with
    p^R_t + (0, rho_n): the pixel at any depth. A background sample outside the image is left out of
    the mean.

    Args:
        key: a `jax.random` key (the offsets).
        left: (T, H, W) phase images of the left view.
        right: (T, H, W) phase images of the right view.
        hand_left: (T, 2) the hand's position in the left view (row, column; rounded).
        hand_right: (T, 2) the hand's position in the right view.
        half_window: (hh, hw) the window's half sizes, >= 0.
        sigma: sigma_s, degrees, > 0.
        max_offset: the largest offset d, pixels, >= 1.
        n_samples: eq. 4's N, >= 1.

    Returns:
        A `LogRatio` (T, h, w).

    Raises:
        ValueError: naming the argument for a key that is not a `jax.random` key, views of other
            shapes (`right`), NaN phases or positions, or parameters out of range.
    """
    check_key(key, "key")
    psi_l, psi_r = _check_phase(left, "left"), _check_phase(right, "right")
    if psi_l.shape != psi_r.shape:
        raise ValueError(f"right: expected the shape of left {psi_l.shape}, got {psi_r.shape}")
    c_l = _check_positions(hand_left, "hand_left", psi_l.shape[0])
    c_r = _check_positions(hand_right, "hand_right", psi_l.shape[0])
    s = check_real(sigma, "sigma", min_value=0.0, exclusive_min=True)
    d = check_int(max_offset, "max_offset", min_value=1)
    n = check_int(n_samples, "n_samples", min_value=1)
    return _stereo(jnp.asarray(psi_l), jnp.asarray(psi_r), jnp.asarray(c_l), jnp.asarray(c_r),
                   _offset_counts(key, n, d), np.float32(s), _check_window(half_window))


def _stack(masks: np.ndarray, gap: int) -> np.ndarray:
    """Frames (T, h, w) one above the other with `gap` blank rows after each, as uint8: one OpenCV
    call for all frames, and no operation of reach < gap crosses from one frame into the next."""
    T, h, w = masks.shape
    out = np.zeros((T, h + gap, w), np.uint8)
    out[:, :h] = masks
    return out.reshape(T * (h + gap), w)


def _unstack(image: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    T, h, w = shape
    return image.reshape(T, -1, w)[:, :h] > 0


def _nearest_large_component(fg: np.ndarray, min_fraction: float) -> np.ndarray:
    """(T, h, w): per frame the 8-connected component of fg with more than `min_fraction` of the
    frame's foreground pixels whose nearest pixel is closest to the window centre (the hand)."""
    T, h, w = fg.shape
    n, labels = cv2.connectedComponents(_stack(fg, 1), connectivity=8)
    labels = labels.reshape(T, h + 1, w)[:, :h]
    f, r, c = np.nonzero(labels)
    lab = labels[f, r, c]
    area = np.bincount(lab, minlength=n)
    frame = np.zeros(n, np.int64)
    frame[lab] = f
    distance = np.full(n, np.inf)
    np.minimum.at(distance, lab, np.hypot(r - h // 2, c - w // 2))
    total = np.bincount(f, minlength=T)
    eligible = (np.arange(n) > 0) & (area > min_fraction * total[frame])
    chosen = np.zeros(T, np.int64)
    ids = np.flatnonzero(eligible)
    for_frame = ids[np.lexsort((ids, distance[ids], frame[ids]))]  # by frame, nearest first, lowest id on ties
    firsts = for_frame[np.r_[True, frame[for_frame][1:] != frame[for_frame][:-1]]] if ids.size else ids
    chosen[frame[firsts]] = firsts
    return (labels == chosen[:, None, None]) & (chosen[:, None, None] > 0)


def _fill_holes(masks: np.ndarray) -> np.ndarray:
    """Background pixels (4-connected) that do not reach the border of their frame become foreground."""
    T, h, w = masks.shape
    inverse = ~masks
    n, labels = cv2.connectedComponents(_stack(inverse, 1), connectivity=4)  # the gaps join only border regions
    labels = labels.reshape(T, h + 1, w)
    border = np.zeros(n, bool)
    border[labels[:, 0]] = border[labels[:, h - 1]] = True
    border[labels[:, :h, 0]] = border[labels[:, :h, -1]] = True
    return masks | (inverse & ~border[labels[:, :h]])


def object_masks(temporal: LogRatio, stereo: LogRatio, hand: Bool[ArrayLike, "T h w"], threshold: float = 0.01,
                 min_fraction: float = 0.1, morphology: int = 2) -> tuple[Bool[Array, "T h w"], Bool[Array, "T"]]:
    """The object mask in each window from both cues (LfD 2009 §III-B, assumption 4, Fig. 3h-j).

    Pixels where both cues are valid and log r_m + log r_s > threshold (the paper's exp(0.01) on
    r_m r_s), the hand's own pixels removed; of the 8-connected regions larger than `min_fraction` of
    the frame's foreground pixels the one nearest the window centre (the hand); its holes filled;
    then `morphology` 3 x 3 erosions and as many dilations (OpenCV, all frames in one call).

    Args:
        temporal: the temporal `LogRatio` (T, h, w).
        stereo: the stereo `LogRatio` of the same shape.
        hand: (T, h, w) bool, the hand's own pixels.
        threshold: the joint log ratio a pixel must exceed.
        min_fraction: the smallest region kept, as a fraction of the frame's foreground, in [0, 1].
        morphology: erosions and dilations, >= 0.

    Returns:
        (masks (T, h, w) bool, found (T,) bool: a region was selected).

    Raises:
        ValueError: naming the argument for cues that are not `LogRatio`s or of other shapes
            (`stereo`), a hand mask of another shape, or parameters out of range.
    """
    for name, cue in (("temporal", temporal), ("stereo", stereo)):
        if not isinstance(cue, LogRatio):
            raise ValueError(f"{name}: expected a LogRatio, got {type(cue).__name__}")
    shape = np.shape(temporal.log_ratio)
    if np.shape(stereo.log_ratio) != shape or len(shape) != 3:
        raise ValueError(f"stereo: expected log ratios of the temporal cue's shape {shape}, "
                         f"got {np.shape(stereo.log_ratio)}")
    hand_mask = as_array(hand, "hand", shape=shape, dtype=bool)
    th = check_real(threshold, "threshold")
    fraction = check_real(min_fraction, "min_fraction", min_value=0.0, max_value=1.0)
    k = check_int(morphology, "morphology", min_value=0)
    joint = np.asarray(temporal.log_ratio) + np.asarray(stereo.log_ratio)
    fg = np.asarray(temporal.valid) & np.asarray(stereo.valid) & (joint > th) & ~hand_mask
    mask = _fill_holes(_nearest_large_component(fg, fraction))
    if k:
        kernel = np.ones((3, 3), np.uint8)
        stacked = _stack(mask, k + 1)
        mask = _unstack(cv2.dilate(cv2.erode(stacked, kernel, iterations=k), kernel, iterations=k), mask.shape)
    return jnp.asarray(mask), jnp.asarray(mask.any(axis=(1, 2)))


@dataclasses.dataclass(frozen=True)
class ObjectOptions:
    """The options of `segment_objects` (LfD 2009 §III-B, eqs. 1-4, Fig. 3), validated on construction.

    The window, sigma and the largest disparity offset scale with the hand in the image (the paper's
    sigma_m is "the width of the hand"), so they have no default.

    Attributes:
        half_window: (rows, columns) half sizes (hh, hw) >= 0 of the window around the hand,
            h x w = (2 hh + 1) x (2 hw + 1) pixels.
        sigma: the phase-difference scale sigma_m = sigma_s of eqs. 1-4, degrees, > 0.
        max_offset: the largest disparity offset d of eq. 4's background samples, pixels, >= 1.
        blur_sigma: the Gaussian blur before the phase (`gradient_phase`), pixels, > 0.
        n_samples: eq. 4's N random offsets, >= 1.
        threshold: the log r_m + log r_s an object pixel must exceed (the paper's exp(0.01) on
            r_m r_s).
        min_fraction: the smallest region kept, as a fraction of the frame's foreground pixels, in
            [0, 1].
        morphology: 3 x 3 erosions and as many dilations after the hole filling, >= 0.
        min_hand_motion: px (max norm) the rounded left hand position must move since the previous
            frame for `ObjectSegmentation.hand_moved`, >= 0 (2: chosen on validation recordings).

    Raises:
        ValueError: naming the field for a value out of its range.
    """

    half_window: tuple[int, int]
    sigma: float
    max_offset: int
    blur_sigma: float = 2.0
    n_samples: int = 100
    threshold: float = 0.01
    min_fraction: float = 0.1
    morphology: int = 2
    min_hand_motion: float = 2.0

    def __post_init__(self):
        object.__setattr__(self, "half_window", _check_window(self.half_window))
        check_real(self.sigma, "sigma", min_value=0.0, exclusive_min=True)
        check_int(self.max_offset, "max_offset", min_value=1)
        check_real(self.blur_sigma, "blur_sigma", min_value=0.0, exclusive_min=True)
        check_int(self.n_samples, "n_samples", min_value=1)
        check_real(self.threshold, "threshold")
        check_real(self.min_fraction, "min_fraction", min_value=0.0, max_value=1.0)
        check_int(self.morphology, "morphology", min_value=0)
        check_real(self.min_hand_motion, "min_hand_motion", min_value=0.0)


class ObjectSegmentation(NamedTuple):
    """The object in the hand's window of each left frame (LfD 2009 §III-B, Fig. 3).

    Attributes:
        masks: (T, h, w) bool object masks.
        found: (T,) bool, a region was selected (frame 0, without a previous frame, is never found).
        hand_moved: (T,) bool, the rounded left hand position moved at least `min_hand_motion` px (max
            norm) since the previous frame (False at frame 0); where it did not, eq. 1 equals the static
            background (r_m = 1) and `found` rests on the stereo cue alone, which also passes the table
            and body at the hand's depth (`hold_undecided`).
        temporal: the temporal `LogRatio` of frames 1..T-1.
        stereo: the stereo `LogRatio` of frames 1..T-1.
    """

    masks: Bool[Array, "T h w"]
    found: Bool[Array, " T"]
    hand_moved: Bool[Array, " T"]
    temporal: LogRatio
    stereo: LogRatio


CHUNK = 10  # frames per step of `_in_chunks` (10 and 13 were fastest of 1-26 on 130 frames, 2 CPU cores)


def _in_chunks(fn, *xs):
    """vmap(fn)(*xs) over the leading axis (T) of every x (T, ...), `CHUNK` frames at a time
    (`lax.map`). Why: eq. 4's samples (h, 2 d + 1, w) of all T frames at once are tens of MB (36 MB
    for 130 frames of 41 x 41 windows, d = 20), which XLA:CPU writes to fresh memory several times
    (the stacked shifts, the samples, the masked samples); a chunk's stay in cache (eq. 4 about 4x
    faster on those 130 frames). The frames are padded with copies of the last one to whole chunks,
    so that every step has the same shape and XLA the same kernels: a frame's values do not depend
    on T (tests), and on the bench's clip they equal those of one vmap over all frames bit for bit
    (which for T <= 2 frames picks other kernels, last bits apart)."""
    T = xs[0].shape[0]
    n = -(-T // CHUNK)

    def chunks(x):
        x = jnp.concatenate([x, jnp.repeat(x[-1:], n * CHUNK - T, axis=0)])
        return x.reshape(n, CHUNK, *x.shape[1:])

    out = jax.lax.map(lambda c: jax.vmap(fn)(*c), tuple(chunks(x) for x in xs))
    return jax.tree.map(lambda y: y.reshape(n * CHUNK, *y.shape[2:])[:T], out)


@partial(jax.jit, static_argnames="half")
def _cues(left, right, hand_masks, centres_l, centres_r, counts, kernel, sigma, half: tuple[int, int]):
    """Both cues and the hand's pixels in the window of frames 1..T-1 from grey frames (T, H, W), the
    phase computed only where the cues read it (`crop_phase`): the left window at p_t in every frame
    (Psi_t(p_t + delta), and Psi_{t-1}(p_{t-1} + delta) of the next frame), the left window of frame
    t - 1 at p_t (the static background), the right view's window at p^R_t widened by the largest
    offset d (eqs. 3-4; `counts` (2 d + 1,), `_offset_counts`). The stereo cue goes in chunks of
    frames (`_in_chunks`), its right-view crops with it."""
    crop = jax.vmap(partial(crop_phase, half=half, kernel=kernel))
    strip = partial(crop_phase, half=(half[0], half[1] + (len(counts) - 1) // 2), kernel=kernel)
    own = crop(left, centres_l)
    temporal = _temporal_ratio(own[1:], own[:-1], crop(left[:-1], centres_l[1:]), sigma)
    stereo = _in_chunks(lambda w, r, c: _stereo_ratio(w, strip(r, c), counts, sigma), own[1:], right[1:],
                        centres_r[1:])
    hands = jax.vmap(partial(_window, half=half))(hand_masks[1:].astype(jnp.float32), centres_l[1:])
    return temporal, stereo, hands > 0.5  # NaN outside the image: not the hand


def _check_frames(images, name: str, shape=None) -> np.ndarray:
    """Grey frames (T, H, W): 8-bit ones as they are (a quarter of float32's transfer; only `_cues`'
    crops are converted, on the device), others as float32."""
    arr = as_array(images, name, ndim=3, dtype=np.uint8 if getattr(images, "dtype", None) == np.uint8 else np.float32)
    if arr.shape[0] < 2 or min(arr.shape[1:]) < 2:
        raise ValueError(f"{name}: expected (T, H, W) frames with T >= 2 (the temporal cue) and H, W >= 2, "
                         f"got shape {arr.shape}")
    if shape is not None and arr.shape != shape:
        raise ValueError(f"{name}: expected (T, H, W) frames of the shape of left {shape}, got {arr.shape}")
    return arr


def segment_objects(key: Key[Array, ""], left: Float[ArrayLike, "T H W"], right: Float[ArrayLike, "T H W"],
                    hand_left: Float[ArrayLike, "T 2"], hand_right: Float[ArrayLike, "T 2"],
                    hand_masks: Bool[ArrayLike, "T H W"], options: ObjectOptions) -> ObjectSegmentation:
    """The object in the hand from gradient-phase differences, end to end (LfD 2009 §III-B, eqs. 1-4).

    The temporal and stereo cues around the hand (those of `temporal_log_ratio` and
    `stereo_log_ratio` on `gradient_phase` of both views), then `object_masks` without the hand's
    own pixels (Fig. 3h-j). The phase is computed only on crops around the windows that the cues
    read, with the values of the full frames' (the same blur, border padding and one-sided border
    gradient).

    Args:
        key: a `jax.random` key (eq. 4's disparity offsets).
        left: (T, H, W) grey frames of the left view, T >= 2 (8-bit or real).
        right: (T, H, W) grey frames of the right view, rectified.
        hand_left: (T, 2) the hand's position (row, column; rounded) in the left view.
        hand_right: (T, 2) the hand's position in the right view.
        hand_masks: (T, H, W) the hand's pixels in the left view, removed from the object.
        options: the window, the cues' and the masks' options (`ObjectOptions`).

    Returns:
        An `ObjectSegmentation`: masks (T, h, w) and found (T,) (frame 0, without a previous frame,
        is never found), hand_moved (T,), and both cues of frames 1..T-1.

    Raises:
        ValueError: naming the argument for a key that is not a `jax.random` key, frames that are
            not (T, H, W) with T >= 2 or of different shapes (`right`), NaN frames or positions,
            positions or masks of another shape, or options that are not an `ObjectOptions`.
    """
    check_key(key, "key")
    if not isinstance(options, ObjectOptions):
        raise ValueError(f"options: expected an ObjectOptions, got {type(options).__name__}")
    o = options
    frames_l = _check_frames(left, "left")
    frames_r = _check_frames(right, "right", frames_l.shape)
    centres_l = _check_positions(hand_left, "hand_left", frames_l.shape[0])
    centres_r = _check_positions(hand_right, "hand_right", frames_l.shape[0])
    hands = as_array(hand_masks, "hand_masks", shape=frames_l.shape, dtype=bool)
    counts = _offset_counts(key, o.n_samples, o.max_offset)
    temporal, stereo, in_window = _cues(jnp.asarray(frames_l), jnp.asarray(frames_r), jnp.asarray(hands),
                                        jnp.asarray(centres_l), jnp.asarray(centres_r), counts,
                                        gaussian_kernel(float(o.blur_sigma)), np.float32(o.sigma), o.half_window)
    masks, found = object_masks(temporal, stereo, in_window, o.threshold, o.min_fraction, o.morphology)
    none = jnp.zeros((1, *masks.shape[1:]), bool)
    moved = np.concatenate([[False], np.abs(np.diff(centres_l, axis=0)).max(axis=1) >= o.min_hand_motion])
    return ObjectSegmentation(jnp.concatenate([none, masks]), jnp.concatenate([jnp.zeros(1, bool), found]),
                              jnp.asarray(moved), temporal, stereo)
