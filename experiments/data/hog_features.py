"""Procedural hand images and their HOG features: a stand-in for GRASP's Poser database (§III-B).

A hand is drawn as a 2-D silhouette with inner contours: an elliptic palm and five two-segment
fingers (capsules), each finger with its own flexion (the distal segment bends by the curl angle),
spread and length. Six grasp classes (as GRASP's six) differ in their mean finger curls, spreads and
thumb placement; every sample perturbs them (anatomy and pose jitter), and the view changes the
image: a random in-plane rotation (roll), foreshortening along two axes from the out-of-plane angles
(pitch, yaw), a random scale and offset. Parts are shaded with different grey levels (so fingers in
front of the palm leave inner edges), the edges are soft (a sigmoid of the signed distance, i.e. a
blur), and pixel noise is added on the hand; the background is black, as in the segmented images.

Drawing is OpenCV (anti-aliased ellipse and thick lines on a 256 x 256 hand-frame canvas, one affine
warp for the view, a Gaussian blur); parameters are drawn vectorised with numpy. Deterministic from a seed; `features()` caches its result under
`lfd_common.cache_dir("hog_features")`.
"""
from __future__ import annotations

import cv2
import numpy as np

from lfd_common import cache_dir, write_npz

N_CLASSES = 6
# per class: mean curl (radians) of thumb, index, middle, ring, little; finger spread factor; thumb angle
_CURL = np.array([
    [0.9, 1.3, 1.3, 1.3, 1.3],   # large diameter (wrap)
    [1.2, 1.9, 1.9, 1.9, 1.9],   # small diameter
    [0.3, 0.2, 0.2, 0.2, 0.2],   # flat / abducted thumb
    [1.0, 0.6, 1.8, 1.8, 1.8],   # precision (pinch, index out)
    [0.6, 0.7, 0.7, 0.7, 0.7],   # power sphere (spread)
    [1.4, 1.2, 2.2, 2.2, 2.2],   # tripod / lateral
], np.float32)
_SPREAD = np.array([0.15, 0.08, 0.05, 0.12, 0.35, 0.1], np.float32)
_THUMB = np.array([0.9, 1.2, 1.6, 0.7, 1.1, 1.0], np.float32)
_BASE_ANGLES = np.array([0.0, -0.3, 0.0, 0.3, 0.6], np.float32)  # finger directions relative to the palm axis
_LENGTH = np.array([0.55, 0.7, 0.78, 0.72, 0.58], np.float32)    # proximal + distal, in palm heights


def _params(rng: np.random.Generator, labels: np.ndarray):
    """Per-image geometry in the hand frame (palm centred at 0, fingers towards -y, palm height 1)."""
    n = labels.shape[0]
    curl = _CURL[labels] + 0.25 * rng.standard_normal((n, 5))
    spread = _SPREAD[labels] + 0.05 * rng.standard_normal(n)
    thumb = _THUMB[labels] + 0.15 * rng.standard_normal(n)
    lengths = _LENGTH * (1.0 + 0.08 * rng.standard_normal((n, 5)))
    angles = _BASE_ANGLES[None] * (1.0 + 3.0 * spread[:, None])
    angles[:, 0] = -thumb
    roots = np.stack([np.array([-0.5, -0.33, -0.06, 0.2, 0.42]), np.array([0.05, -0.5, -0.55, -0.5, -0.42])], -1)
    direc = lambda a: np.stack([np.sin(a), -np.cos(a)], -1)
    mid = roots[None] + (0.55 * lengths)[..., None] * direc(angles)
    # the distal segment bends by the curl angle towards the palm (+y); foreshortened by cos(curl)
    tip_dir = direc(angles) * np.cos(curl)[..., None] + np.array([0.0, 0.9]) * np.sin(curl)[..., None]
    tips = mid + (0.45 * lengths)[..., None] * tip_dir
    radius = np.array([0.13, 0.11, 0.115, 0.11, 0.095]) * (1.0 + 0.05 * rng.standard_normal((n, 5)))
    view = np.stack([rng.uniform(-1.2, 1.2, n), rng.uniform(-1.2, 1.2, n), rng.uniform(-np.pi, np.pi, n)], -1)
    scale = rng.uniform(0.36, 0.46, n)
    offset = 0.06 * rng.standard_normal((n, 2))
    shade = np.concatenate([np.full((n, 1), 0.55), 0.65 + 0.05 * np.arange(5) + np.zeros((n, 1)),
                            0.8 + 0.04 * np.arange(5) + np.zeros((n, 1))], 1) * rng.uniform(0.8, 1.2, (n, 11))
    blur = rng.uniform(0.6, 1.4, n)
    return dict(roots=np.broadcast_to(roots, (n, 5, 2)), mid=mid, tips=tips, radius=radius, view=view,
                scale=scale, offset=offset, shade=shade, blur=blur)


_CANVAS = 256  # hand-frame canvas: 1 palm height = _CANVAS / 4 pixels, origin at the centre


def _draw(i: int, g: dict, size: int) -> np.ndarray:
    """Draw image i of the parameter set g: hand frame canvas, then the view as one affine warp."""
    unit = _CANVAS / 4.0
    to_px = lambda p: (int(round(p[0] * unit * 16 + _CANVAS / 2 * 16)), int(round(p[1] * unit * 16 + _CANVAS / 2 * 16)))
    canvas = np.zeros((_CANVAS, _CANVAS), np.float32)
    sh = g["shade"][i]
    cv2.ellipse(canvas, to_px((0.0, 0.0)), (int(0.47 * unit * 16), int(0.62 * unit * 16)), 0, 0, 360,
                float(sh[0]), -1, cv2.LINE_AA, 4)
    for seg, (a, b) in enumerate(((g["roots"], g["mid"]), (g["mid"], g["tips"]))):
        for f in range(5):
            r = g["radius"][i, f] * (1.0 if seg == 0 else 0.92)
            cv2.line(canvas, to_px(a[i, f]), to_px(b[i, f]), float(sh[1 + 5 * seg + f]),
                     max(1, int(round(2 * r * unit))), cv2.LINE_AA, 4)
    yaw, pitch, roll = g["view"][i]
    fore = np.array([max(np.cos(yaw), 0.35), max(np.cos(pitch), 0.35)])
    c, s = np.cos(roll), np.sin(roll)
    # output pixel u (centred, in image widths) = R(roll) diag(scale fore) hand-frame point + offset
    A = np.array([[c, -s], [s, c]]) @ np.diag(g["scale"][i] * fore) * (size / unit)
    t = size / 2 + g["offset"][i] * size - A @ np.array([_CANVAS / 2, _CANVAS / 2])
    img = cv2.warpAffine(canvas, np.hstack([A, t[:, None]]), (size, size), flags=cv2.INTER_AREA)
    yy, xx = np.mgrid[0:size, 0:size] / size - 0.5
    img *= 0.85 + 0.3 * (xx * c + yy * s)  # a soft illumination gradient
    return cv2.GaussianBlur(img, (0, 0), float(g["blur"][i]))


def hand_images(n: int, seed: int = 0, size: int = 64, noise_std: float = 0.03):
    """n procedural hand images: (images (n, size, size) float32 in [0, 1], labels (n,) int32,
    view angles (n, 3) = (yaw, pitch, roll) in radians)."""
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, N_CLASSES, n).astype(np.int32)
    g = _params(rng, labels)
    imgs = np.stack([_draw(i, g, size) for i in range(n)])  # drawing is OpenCV, one call per part
    hand = imgs > 0.02
    noise = rng.standard_normal(imgs.shape, dtype=np.float32)  # pixel noise on the hand only
    imgs = np.clip(imgs + noise_std * noise * hand, 0.0, 1.0).astype(np.float32)
    return imgs, labels, g["view"].astype(np.float32)


def features(n: int, seed: int = 0, size: int = 64, n_bins: int = 4, n_levels: int = 3,
             block: int = 65536, cache: bool = True):
    """HOG (GRASP: B bins, L levels) of n procedural hands: (features (n, D) float32, labels, euler).

    Generated block by block (memory O(block)), cached as .npz under cache_dir("hog_features").
    """
    from hog_jax import HOGConfig, hog

    path = cache_dir("hog_features") / f"hands_n{n}_s{seed}_px{size}_B{n_bins}_L{n_levels}_v1.npz"
    if cache and path.exists():
        with np.load(path) as z:
            return z["x"], z["y"], z["o"]
    cfg = HOGConfig(n_bins=n_bins, n_levels=n_levels)
    xs, ys, os_ = [], [], []
    for i, start in enumerate(range(0, n, block)):
        m = min(block, n - start)
        imgs, y, o = hand_images(m, seed=seed * 100_003 + i, size=size)
        xs.append(np.asarray(hog(imgs, cfg)))
        ys.append(y)
        os_.append(o)
    x, y, o = np.concatenate(xs), np.concatenate(ys), np.concatenate(os_)
    if cache:
        write_npz(path, x=x, y=y, o=o)
    return x, y, o
