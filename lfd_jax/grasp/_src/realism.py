"""Realism steps for rendered training frames (beyond GRASP): what a real camera adds to a rendered
scene of a grasping hand, as pure functions of explicit parameters, and `sample_realism` /
`realistic_frames`, which draw the parameters from the ranges below and apply the steps in a camera's
order (the scene, its light, the lens, the sensor, the compression):

1. `paste_backgrounds`: real background texture (patches cut from real video frames,
   `background_patches`) wherever the renderer drew neither the hand nor the object, in a share of
   the frames (`Realism.background_share`; the others keep their rendered background).
2. `adjust_light`: exposure, white balance and gamma. Ranges from real skin (the HGR1 photos'
   skin pixels, per-photo means, 106 photos): log(R/G) has a standard deviation of 0.10 and log(B/G)
   of 0.08 across photos, the skin's luma 96 +- 28 of 255. Drawn: log white-balance gains of R and
   B (G fixed) uniform in +-0.15 and +-0.12 (1.5 standard deviations), exposure log-uniform in
   [0.7, 1.4] (about the luma's relative spread), gamma log-uniform in [0.8, 1.25].
3. `blur`: a per-frame kernel, Gaussian (`gaussian_kernels`, sigma uniform in [0, 1.5] pixels) or,
   with probability 0.5, motion along a line (`motion_kernels`, length uniform in [1, 9] pixels, any
   direction), as a head-mounted camera smears a moving hand.
4. `add_noise`: sensor noise, read noise plus shot noise: variance a + b x for a pixel of value x
   (a standard deviation sqrt(a) uniform in [0, 6], b uniform in [0, 0.5]).
5. `jpeg_roundtrip`: JPEG compression at a quality uniform in [30, 95] (OpenCV's codec).

Shapes: N frames of H x W pixels, 3 channels (RGB), P background patches, K x K kernels.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import cv2
import numpy as np
from scipy import fft as sp_fft

from lfd_common import as_array, check_int, check_real

_WB_LOG = (0.15, 0.12)          # log white-balance gain ranges of R and B (module docstring)
_EXPOSURE = (0.7, 1.4)
_GAMMA = (0.8, 1.25)
_SIGMA_MAX = 1.5
_MOTION_LENGTH = (1.0, 9.0)
_READ_SIGMA_MAX = 6.0
_SHOT_GAIN_MAX = 0.5
_QUALITY = (30, 95)
_STEPS = ("background", "light", "blur", "noise", "jpeg")
_PATCH_SHARE = (0.3, 1.0)       # a background patch's side as a share of the source frame's shorter side


@dataclasses.dataclass(frozen=True)
class Realism:
    """Which realism steps `realistic_frames` applies (all off: the frames unchanged).

    Attributes:
        background: real background texture behind the hand and object (`paste_backgrounds`).
        background_share: the share of the frames that get it, in [0, 1].
        light: exposure, white balance and gamma (`adjust_light`).
        blur: Gaussian or motion blur (`blur`).
        noise: read and shot noise (`add_noise`).
        jpeg: JPEG compression (`jpeg_roundtrip`).
    """

    background: bool = False
    light: bool = False
    blur: bool = False
    noise: bool = False
    jpeg: bool = False
    background_share: float = 1.0

    def __post_init__(self):
        for name in _STEPS:
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name}: expected a bool, got {getattr(self, name)!r}")
        check_real(self.background_share, "background_share", min_value=0.0, max_value=1.0)


class RealismParams(NamedTuple):
    """The drawn parameters of N frames (`sample_realism`).

    Attributes:
        patch: (N,) index of each frame's background patch.
        pasted: (N,) whether the frame gets it.
        exposure: (N,) exposure gains.
        white_balance: (N, 3) per-channel gains (G = 1).
        gamma: (N,) gammas.
        kernels: (N, K, K) blur kernels, each summing to 1.
        read_sigma: (N,) read-noise standard deviations (pixel values).
        shot_gain: (N,) shot-noise variance per unit of pixel value.
        quality: (N,) JPEG qualities.
    """

    patch: np.ndarray
    pasted: np.ndarray
    exposure: np.ndarray
    white_balance: np.ndarray
    gamma: np.ndarray
    kernels: np.ndarray
    read_sigma: np.ndarray
    shot_gain: np.ndarray
    quality: np.ndarray


def _frames(frames) -> np.ndarray:
    return as_array(frames, "frames", shape=(None, None, None, 3), dtype=None)


def _uint8(images, name: str, shape) -> np.ndarray:
    images = np.asarray(images)
    if images.dtype != np.uint8:
        raise ValueError(f"{name}: expected uint8 pixels, got dtype {images.dtype}")
    return as_array(images, name, shape=shape, dtype=None)


def _positive(value, name: str, shape) -> np.ndarray:
    value = as_array(value, name, shape=shape, dtype=np.float32)
    if np.any(value <= 0):
        raise ValueError(f"{name}: expected positive values, got a minimum of {value.min()}")
    return value


def paste_backgrounds(frames, foreground, patches, index) -> np.ndarray:
    """Real background behind the rendered hand and object: out = frames where `foreground`, else
    patches[index].

    Args:
        frames: (N, H, W, 3) frames.
        foreground: (N, H, W) bool, where the renderer drew the hand or the object.
        patches: (P, H, W, 3) background patches (`background_patches`).
        index: (N,) each frame's patch, in [0, P).

    Returns:
        (N, H, W, 3) frames of `frames`' dtype.

    Raises:
        ValueError: shapes that do not match or an index out of range (the message names the argument).
    """
    frames = _frames(frames)
    foreground = as_array(foreground, "foreground", shape=frames.shape[:3], dtype=bool)
    patches = as_array(patches, "patches", shape=(None, *frames.shape[1:]), dtype=None)
    index = as_array(index, "index", shape=(len(frames),), dtype=np.int64, min_value=0, max_value=len(patches) - 1)
    return np.where(foreground[..., None], frames, patches[index].astype(frames.dtype))


def background_patches(images, size: int, n: int, seed: int = 0) -> np.ndarray:
    """Background texture cut from real frames: `n` random square crops of a random frame, each of a
    side uniform in 0.3 to 1 of the frame's shorter side at a uniform position, resized to `size`
    (pixel-area interpolation) and mirrored left-right with probability 0.5.

    Args:
        images: M >= 1 uint8 real frames (h, w, 3), h, w >= 2, of any sizes; none evaluation data.
        size: the patches' side (the training frames').
        n: patches to cut.
        seed: the crops' seed.

    Returns:
        (n, size, size, 3) uint8 patches.

    Raises:
        ValueError: `images` empty or not uint8 (h, w, 3) frames, or `size` / `n` not positive (the
            message names the argument).
    """
    if len(images) == 0:
        raise ValueError("images: expected at least one frame")
    images = [_uint8(im, f"images[{i}]", (None, None, 3)) for i, im in enumerate(images)]
    if min(min(im.shape[:2]) for im in images) < 2:
        raise ValueError("images: expected frames of at least 2 x 2 pixels")
    size, n = check_int(size, "size", min_value=1), check_int(n, "n", min_value=1)
    rng = np.random.default_rng(seed)
    out = np.empty((n, size, size, 3), np.uint8)
    for i in range(n):
        image = images[rng.integers(len(images))]
        h, w = image.shape[:2]
        side = max(2, int(rng.uniform(*_PATCH_SHARE) * min(h, w)))
        top, left = rng.integers(0, h - side + 1), rng.integers(0, w - side + 1)
        patch = cv2.resize(image[top:top + side, left:left + side], (size, size), interpolation=cv2.INTER_AREA)
        out[i] = patch[:, ::-1] if rng.uniform() < 0.5 else patch
    return out


def adjust_light(frames, exposure, white_balance, gamma) -> np.ndarray:
    """Exposure, white balance and gamma: out = 255 * clip(exposure * white_balance_c * x / 255, 0, 1)
    ** gamma for a pixel value x of channel c.

    Args:
        frames: (N, H, W, 3) frames, values in [0, 255].
        exposure: (N,) positive gains.
        white_balance: (N, 3) positive per-channel gains.
        gamma: (N,) positive gammas.

    Returns:
        (N, H, W, 3) float32 frames in [0, 255].

    Raises:
        ValueError: shapes that do not match, or gains / gammas not positive (the message names it).
    """
    frames = _frames(frames)
    n = len(frames)
    exposure, white_balance, gamma = (_positive(v, name, shape) for v, name, shape in (
        (exposure, "exposure", (n,)), (white_balance, "white_balance", (n, 3)), (gamma, "gamma", (n,))))
    gain = (exposure[:, None] * white_balance / 255.0)[:, None, None, :]
    return 255.0 * np.clip(frames.astype(np.float32) * gain, 0.0, 1.0) ** gamma[:, None, None, None]


def gaussian_kernels(sigma, radius: int) -> np.ndarray:
    """Isotropic Gaussian kernels exp(-(i^2 + j^2) / (2 sigma^2)), |i|, |j| <= radius, normalised to sum
    1 (sigma 0: the identity).

    Args:
        sigma: (N,) standard deviations in pixels, >= 0.
        radius: the kernels' radius R (K = 2 R + 1).

    Returns:
        (N, K, K) float32 kernels.

    Raises:
        ValueError: a negative sigma or radius (the message names it).
    """
    sigma = as_array(sigma, "sigma", ndim=1, dtype=np.float64, min_value=0.0)
    radius = check_int(radius, "radius", min_value=0)
    r = np.arange(-radius, radius + 1, dtype=np.float64)
    d2 = r[:, None] ** 2 + r[None, :] ** 2
    k = np.exp(-d2[None] / (2.0 * np.maximum(sigma, 1e-6)[:, None, None] ** 2))
    return (k / k.sum((1, 2), keepdims=True)).astype(np.float32)


def motion_kernels(length, angle, radius: int) -> np.ndarray:
    """Motion-blur kernels: the mean over a line segment of `length` pixels through the kernel's centre
    at `angle` (radians from the x axis), the segment sampled at 8 points per pixel of length and each
    sample shared bilinearly among its four nearest taps.

    Args:
        length: (N,) segment lengths in pixels, in [0, 2 * radius].
        angle: (N,) directions in radians.
        radius: the kernels' radius R (K = 2 R + 1).

    Returns:
        (N, K, K) float32 kernels summing to 1, symmetric about the centre.

    Raises:
        ValueError: mismatched shapes, or a length outside [0, 2 radius] (the message names it).
    """
    radius = check_int(radius, "radius", min_value=0)
    length = as_array(length, "length", ndim=1, dtype=np.float64, min_value=0.0, max_value=2.0 * radius)
    angle = as_array(angle, "angle", shape=length.shape, dtype=np.float64)
    n_samples = 8 * 2 * radius + 1
    t = np.linspace(-0.5, 0.5, n_samples)[None, :] * length[:, None]            # (N, S) along the line
    x, y = radius + t * np.cos(angle)[:, None], radius + t * np.sin(angle)[:, None]
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    k = np.zeros((len(length), 2 * radius + 2, 2 * radius + 2))
    rows = np.arange(len(length))[:, None]
    for dy, dx, w in ((0, 0, (1 - fy) * (1 - fx)), (0, 1, (1 - fy) * fx), (1, 0, fy * (1 - fx)), (1, 1, fy * fx)):
        np.add.at(k, (rows, y0 + dy, x0 + dx), w)
    k = k[:, :-1, :-1]
    return (k / k.sum((1, 2), keepdims=True)).astype(np.float32)


def _blur(x: np.ndarray, kernels: np.ndarray) -> np.ndarray:
    """(N, H, W, C) float32 frames correlated with their own (N, K, K) kernel, reflected borders, by FFT:
    the circular convolution of the padded frame with the flipped kernel, whose central H x W window
    wraps nothing (about 9x faster on CPU than a grouped convolution in XLA)."""
    n, h, w, _ = x.shape
    r = kernels.shape[1] // 2
    xp = np.pad(x, ((0, 0), (r, r), (r, r), (0, 0)), mode="reflect")
    shape = xp.shape[1:3]
    kp = np.zeros((n, *shape), np.float32)
    kp[:, :2 * r + 1, :2 * r + 1] = kernels[:, ::-1, ::-1]
    y = sp_fft.irfft2(sp_fft.rfft2(xp, axes=(1, 2)) * sp_fft.rfft2(kp, axes=(1, 2))[..., None], shape, axes=(1, 2))
    return y[:, 2 * r:2 * r + h, 2 * r:2 * r + w].astype(np.float32)


def blur(frames, kernels) -> np.ndarray:
    """Each frame correlated with its own kernel, borders reflected without repeating the edge pixel
    (OpenCV's BORDER_REFLECT_101): out[y, x] = sum_ij kernel[i, j] * frame[y + i - R, x + j - R].

    Args:
        frames: (N, H, W, 3) frames with H, W > R.
        kernels: (N, K, K) kernels, K = 2 R + 1 odd.

    Returns:
        (N, H, W, 3) float32 frames.

    Raises:
        ValueError: mismatched shapes, an even K, or frames smaller than the kernel (the message names
            the argument).
    """
    frames = _frames(frames)
    kernels = as_array(kernels, "kernels", shape=(len(frames), None, None), dtype=np.float32)
    k = kernels.shape[1]
    if kernels.shape[2] != k or k % 2 == 0:
        raise ValueError(f"kernels: expected (N, K, K) with K odd, got {kernels.shape}")
    if min(frames.shape[1:3]) <= k // 2:
        raise ValueError(f"frames: expected frames larger than the kernels' radius {k // 2}, got {frames.shape}")
    return _blur(frames.astype(np.float32), kernels)


def add_noise(frames, read_sigma, shot_gain, seed=0) -> np.ndarray:
    """Read and shot noise: out = clip(x + sqrt(read_sigma^2 + shot_gain * x) * z, 0, 255), z standard
    normal, independent per pixel and channel.

    Args:
        frames: (N, H, W, 3) frames, values in [0, 255].
        read_sigma: (N,) read-noise standard deviations, >= 0.
        shot_gain: (N,) shot-noise variance per unit of pixel value, >= 0.
        seed: the noise's seed (an int or a sequence of ints, as `numpy.random.default_rng` takes).

    Returns:
        (N, H, W, 3) float32 frames in [0, 255].

    Raises:
        ValueError: mismatched shapes or negative parameters (the message names the argument).
    """
    frames = _frames(frames)
    n = len(frames)
    read_sigma = as_array(read_sigma, "read_sigma", shape=(n,), dtype=np.float32, min_value=0.0)
    shot_gain = as_array(shot_gain, "shot_gain", shape=(n,), dtype=np.float32, min_value=0.0)
    x = frames.astype(np.float32)
    std = np.sqrt(read_sigma[:, None, None, None] ** 2 + shot_gain[:, None, None, None] * np.maximum(x, 0.0))
    z = np.random.default_rng(seed).standard_normal(x.shape, dtype=np.float32)
    return np.clip(x + std * z, 0.0, 255.0)


def jpeg_roundtrip(frames, quality) -> np.ndarray:
    """Each frame JPEG-encoded at its quality and decoded (OpenCV's codec, 4:2:0 chroma).

    Args:
        frames: (N, H, W, 3) uint8 RGB frames.
        quality: (N,) JPEG qualities in [1, 100].

    Returns:
        (N, H, W, 3) uint8 RGB frames.

    Raises:
        ValueError: frames not uint8, or a quality outside [1, 100] (the message names the argument).
    """
    frames = _uint8(frames, "frames", (None, None, None, 3))
    quality = as_array(quality, "quality", shape=(len(frames),), dtype=np.int64, min_value=1, max_value=100)
    out = np.empty_like(frames)
    for i, (f, q) in enumerate(zip(frames, quality)):
        _, data = cv2.imencode(".jpg", np.ascontiguousarray(f[..., ::-1]), [cv2.IMWRITE_JPEG_QUALITY, int(q)])
        out[i] = cv2.imdecode(data, cv2.IMREAD_COLOR)[..., ::-1]
    return out


def sample_realism(n: int, n_patches: int, seed: int = 0, background_share: float = 1.0) -> RealismParams:
    """Parameters of `n` frames drawn from the ranges of the module docstring.

    Args:
        n: frames.
        n_patches: background patches to choose from (P >= 1).
        seed: the draws' seed.
        background_share: the probability that a frame gets a background patch, in [0, 1].

    Returns:
        The `RealismParams` (kernels of radius 5: K = 11).

    Raises:
        ValueError: `n` or `n_patches` not positive, or `background_share` outside [0, 1] (the message
            names it).
    """
    n, n_patches = check_int(n, "n", min_value=1), check_int(n_patches, "n_patches", min_value=1)
    share = check_real(background_share, "background_share", min_value=0.0, max_value=1.0)
    rng = np.random.default_rng(seed)
    log_wb = rng.uniform(-1.0, 1.0, (n, 2)) * np.array(_WB_LOG)
    white_balance = np.stack([np.exp(log_wb[:, 0]), np.ones(n), np.exp(log_wb[:, 1])], 1)
    radius = int(np.ceil(_MOTION_LENGTH[1] / 2))
    motion = rng.uniform(size=n) < 0.5
    kernels = np.where(motion[:, None, None],
                       motion_kernels(rng.uniform(*_MOTION_LENGTH, n), rng.uniform(0, np.pi, n), radius),
                       gaussian_kernels(rng.uniform(0.0, _SIGMA_MAX, n), radius))
    patch = rng.integers(0, n_patches, n)
    params = dict(
        exposure=np.exp(rng.uniform(*np.log(_EXPOSURE), n)).astype(np.float32),
        white_balance=white_balance.astype(np.float32),
        gamma=np.exp(rng.uniform(*np.log(_GAMMA), n)).astype(np.float32),
        kernels=kernels.astype(np.float32),
        read_sigma=rng.uniform(0.0, _READ_SIGMA_MAX, n).astype(np.float32),
        shot_gain=rng.uniform(0.0, _SHOT_GAIN_MAX, n).astype(np.float32),
        quality=rng.integers(_QUALITY[0], _QUALITY[1] + 1, n))
    # drawn last: the other parameters do not depend on the share
    return RealismParams(patch=patch, pasted=rng.uniform(size=n) < share, **params)


def realistic_frames(frames, foreground, realism: Realism, patches=None, seed: int = 0,
                     chunk: int = 256) -> np.ndarray:
    """The realism steps `realism` turns on, in a camera's order (the module docstring), with parameters
    drawn by `sample_realism`, `chunk` frames at a time (bounded memory).

    Args:
        frames: (N, H, W, 3) uint8 rendered frames.
        foreground: (N, H, W) bool, where the renderer drew the hand or the object.
        realism: which steps.
        patches: (P, H, W, 3) uint8 background patches; required when `realism.background`.
        seed: the draws' seed (the same seed and frames: the same output).
        chunk: frames per step.

    Returns:
        (N, H, W, 3) uint8 frames (`frames` itself when every step is off).

    Raises:
        ValueError: `patches` missing for the background step, or inputs as the steps reject them (the
            message names the argument).
    """
    frames = _uint8(frames, "frames", (None, None, None, 3))
    if not isinstance(realism, Realism):
        raise ValueError(f"realism: expected a Realism, got {type(realism).__name__}")
    if realism.background and patches is None:
        raise ValueError("patches: the background step needs background patches")
    chunk = check_int(chunk, "chunk", min_value=1)
    if not any(getattr(realism, name) for name in _STEPS):
        return frames
    p = sample_realism(len(frames), 1 if patches is None else len(patches), seed, realism.background_share)
    out = np.empty_like(frames)
    for start in range(0, len(frames), chunk):
        s = slice(start, start + chunk)
        x = frames[s]
        if realism.background:
            keep = np.asarray(foreground[s]) | ~p.pasted[s, None, None]
            x = paste_backgrounds(x, keep, patches, p.patch[s])
        if realism.light:
            x = adjust_light(x, p.exposure[s], p.white_balance[s], p.gamma[s])
        if realism.blur:
            x = blur(x, p.kernels[s])
        if realism.noise:
            x = add_noise(x, p.read_sigma[s], p.shot_gain[s], seed=[seed, start])
        x = np.clip(np.round(x), 0, 255).astype(np.uint8)
        out[s] = jpeg_roundtrip(x, p.quality[s]) if realism.jpeg else x
    return out
