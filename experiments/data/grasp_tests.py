"""Test images for grasp recognition (GRASP §VII), rendered as a stand-in for the paper's real camera
images: a different hand, perturbed postures, other lighting, a cluttered coloured background, camera
noise and blur. The images are full frames: the experiment segments them with `hog_jax.segment`.

Shapes: N images, H x W frame pixels.

* `sequence_set(seed, ...)` -> the paper's X: per grasp two reach-to-grasp sequences from two
  viewpoints that are not on the database grid, three snapshots each (stage 0 "starting to reach":
  posture 15 % of the way from the relaxed hand, object 15 cm away; stage 1 "about to grasp": 70 %,
  object 4 cm away; stage 2 "grasp completed"): 6 x 2 x 3 = 36 images. X' = stages 1-2 (24), X'' =
  stage 2 (12).
* `random_set(n, seed, ...)`: n images with random grasp, stage, viewpoint on the upper half-sphere
  and all the nuisances, for tight confidence intervals.
* `skin_training_pixels(seed, ...)`: (skin RGB, background RGB) pixels to fit the skin colour model:
  skin from hands of three tones that are *not* the test hand's tone (lighter, database, darker),
  background from clutter drawn with another seed (and the black objects).

The hand in every test image is `TEST_SHAPE` (longer, thinner fingers, wider and flatter palm, darker
skin); finger joints are perturbed uniformly by up to `joint_noise_deg` (15) and clipped to the
human ranges; lighting (ambient, key light level and direction), object colour (dark), camera
distance (0.55-0.75 m) and aim (2 cm jitter), noise (2-8 grey levels) and blur (sigma 0.3-1.2 px)
are random. Sets are cached under `lfd_common.cache_dir("grasp_tests")` keyed by every argument.
"""
from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

from lfd_common import Cache, check_int, check_real
from sim.grasping import GRASP_CLASSES
from hog_jax import euler_to_quat
from sim.grasping import GraspRenderer, hand_center, sphere_camera, view_euler
from sim.hands import posture
from sim.hands import DEFAULT_SHAPE, TEST_SHAPE, HandShape, clip_posture

STAGES: tuple[str, ...] = ("starting to reach", "about to grasp", "grasp completed")
_STAGE_POSTURE = (0.15, 0.7, 1.0)      # fraction of the way from the relaxed hand to the grasp
_STAGE_OBJECT_DISTANCE_M = (0.15, 0.04, 0.0)
_VERSION = 1


class GraspTestSet(NamedTuple):
    """frames (N, H, W, 3) uint8; labels (N,) int32 indices into GRASP_CLASSES; euler (N, 3) radians
    (`sim.grasp_views.view_euler`), quat (N, 4); stage (N,) int32 (index into STAGES); hand_masks
    (N, H, W) bool, the renderer's hand mask (for diagnostics only: the experiment segments by skin)."""

    frames: np.ndarray
    labels: np.ndarray
    euler: np.ndarray
    quat: np.ndarray
    stage: np.ndarray
    hand_masks: np.ndarray


def clutter_background(rng: np.random.Generator, size: int) -> np.ndarray:
    """(size, size, 3) uint8: a random base colour with 12-30 random coloured rectangles and ellipses,
    slightly blurred (an office/lab scene out of focus)."""
    img = np.empty((size, size, 3), np.uint8)
    img[:] = rng.integers(0, 256, 3)
    for _ in range(int(rng.integers(12, 31))):
        colour = tuple(int(c) for c in rng.integers(0, 256, 3))
        c = rng.integers(0, size, 2)
        ax = rng.integers(size // 20 + 1, size // 3 + 2, 2)
        if rng.random() < 0.5:
            cv2.rectangle(img, (int(c[0] - ax[0]), int(c[1] - ax[1])), (int(c[0] + ax[0]), int(c[1] + ax[1])), colour, -1)
        else:
            cv2.ellipse(img, (int(c[0]), int(c[1])), (int(ax[0]), int(ax[1])), float(rng.uniform(0, 180)), 0, 360, colour, -1)
    return cv2.GaussianBlur(img, (0, 0), 1.5)


def _object_direction(grasp: int, shape: HandShape) -> np.ndarray:
    """Unit vector (world frame) from the palm centre to the grasped object's centre."""
    d = -hand_center(grasp, shape)  # the object is at the world origin
    return d / np.linalg.norm(d)


class Nuisances(NamedTuple):
    """Which of the test images' differences from the database are switched on (the ladder of the grasp study).

    posture: the reach stage's posture and object distance and the uniform joint noise (off: the grasp's
    exact posture, object grasped); photometric: random lighting, object colour, blur and camera noise
    (off: the database's lighting and black object, a clean image); clutter: the cluttered background
    (off: black). The hand shape is `shape` of the set. Every random draw is taken whether a nuisance is
    on or not, so images of the same seed differ only in the nuisances switched."""

    posture: bool = True
    photometric: bool = True
    clutter: bool = True


ALL_NUISANCES = Nuisances()


def _render_one(renderer: GraspRenderer, rng: np.random.Generator, grasp: int, stage: int, azimuth: float,
                elevation: float, frame: int, shape: HandShape, joint_noise_deg: float, with_clutter: bool,
                nuisances: Nuisances = ALL_NUISANCES):
    """One test frame: posture, object distance, lighting, camera, clutter, noise and blur."""
    joints = posture(grasp, _STAGE_POSTURE[stage]) + rng.uniform(-joint_noise_deg, joint_noise_deg, 20)
    renderer.set_posture(clip_posture(joints) if nuisances.posture else posture(grasp, 1.0))
    distance = _STAGE_OBJECT_DISTANCE_M[stage] if nuisances.posture else 0.0
    renderer.set_object_offset(_object_direction(grasp, shape) * distance)
    lighting = (rng.uniform(0.2, 0.5), rng.uniform(0.4, 0.9),
                [rng.uniform(-1, 1), rng.uniform(-1, 1), -rng.uniform(0.3, 1.0)])
    object_rgba = [*rng.uniform(0.0, 0.12, 3), 1.0]
    if nuisances.photometric:
        renderer.set_lighting(*lighting)
        renderer.set_object_rgba(object_rgba)
    target = hand_center(grasp, shape) + rng.normal(0.0, 0.02, 3)
    rgb, hand, obj = renderer.render_with_mask(*sphere_camera(azimuth, elevation, rng.uniform(0.55, 0.75), target=target))
    img = rgb.astype(np.float32)
    if with_clutter:
        background = clutter_background(rng, frame).astype(np.float32)
        if nuisances.clutter:
            img = np.where((hand | obj)[..., None], img, background)
    blur, noise = rng.uniform(0.3, 1.2), rng.normal(0.0, rng.uniform(2.0, 8.0), img.shape)
    if nuisances.photometric:
        img = cv2.GaussianBlur(img, (0, 0), blur)
        img += noise  # in place, in float32, as the sets were first rendered
    return np.clip(np.round(img), 0, 255).astype(np.uint8), hand


def _check_nuisances(nuisances: Nuisances) -> Nuisances:
    """`nuisances`, checked to be a `Nuisances` (a NamedTuple of bools, keyed by value)."""
    if not isinstance(nuisances, Nuisances):
        raise ValueError(f"nuisances: expected a Nuisances, got {type(nuisances).__name__}")
    return nuisances


# `sim` holds the grasp postures, the hands and the renderer.
_SETS = Cache("grasp_tests", packages=("experiments.data.grasp_tests", "sim", "hog_jax", "lfd_common"),
              version=_VERSION)


def _cached(name: str, settings: dict, build):
    """`build()`, stored under cache_dir("grasp_tests") by `name`, `settings` and the source it runs, and
    reused while they match."""
    return _SETS.get(build, set=name, **settings)


def _render_set(rng, grasp_idx, stages, azimuths, elevations, frame, shape, joint_noise_deg, nuisances, progress):
    n = len(grasp_idx)
    frames = np.zeros((n, frame, frame, 3), np.uint8)
    masks = np.zeros((n, frame, frame), bool)
    order = np.argsort(grasp_idx, kind="stable")  # one renderer (one model, one GL context) per grasp
    loop = order if progress is None else progress(order, n)
    renderer, current = None, None
    try:
        for i in loop:
            g = GRASP_CLASSES[grasp_idx[i]]
            if g != current:
                if renderer is not None:
                    renderer.close()
                renderer, current = GraspRenderer(g, frame, frame, shape), g
            frames[i], masks[i] = _render_one(renderer, rng, g, stages[i], azimuths[i], elevations[i], frame,
                                              shape, joint_noise_deg, True, nuisances)
    finally:
        if renderer is not None:
            renderer.close()
    euler = view_euler(azimuths, elevations)
    return GraspTestSet(frames, np.asarray(grasp_idx, np.int32), euler.astype(np.float32),
                        np.asarray(euler_to_quat(euler.astype(np.float32))), np.asarray(stages, np.int32), masks)


def sequence_set(seed: int = 0, frame_size: int = 160, shape: HandShape = TEST_SHAPE,
                 joint_noise_deg: float = 15.0, view_jitter_deg: float = 2.0, nuisances: Nuisances = ALL_NUISANCES,
                 progress=None) -> GraspTestSet:
    """GRASP's test set X (36 images, see the module docstring). Viewpoints: azimuth 3 deg off the
    database's 6-degree azimuth grid and elevation on the borders between its elevation bands, then
    jittered by up to `view_jitter_deg` (< 3, so it stays off the grid) per snapshot (the hand moves
    during the reach)."""
    frame_size = check_int(frame_size, "frame_size", min_value=32, max_value=1024)
    joint_noise_deg = check_real(joint_noise_deg, "joint_noise_deg", min_value=0.0, max_value=45.0)
    view_jitter_deg = check_real(view_jitter_deg, "view_jitter_deg", min_value=0.0, max_value=2.9)

    def build():
        rng = np.random.default_rng([seed, 5, 1])
        g_idx, stages, az, el = [], [], [], []
        for gi in range(len(GRASP_CLASSES)):
            for _ in range(2):
                a0 = 6.0 * rng.integers(0, 60) + 3.0
                e0 = 6.0 * rng.integers(1, 14)          # 6..78: between the bands centred at 3, 9, ..., 87
                for s in range(len(STAGES)):
                    g_idx.append(gi)
                    stages.append(s)
                    az.append(a0 + rng.uniform(-view_jitter_deg, view_jitter_deg))
                    el.append(e0 + rng.uniform(-view_jitter_deg, view_jitter_deg))
        return _render_set(rng, np.array(g_idx), np.array(stages), np.array(az), np.array(el), frame_size, shape,
                           joint_noise_deg, nuisances, progress)

    return _cached("X", dict(seed=seed, frame_size=frame_size, shape=shape, joint_noise_deg=joint_noise_deg,
                             view_jitter_deg=view_jitter_deg, nuisances=_check_nuisances(nuisances)), build)


def random_set(n: int, seed: int = 0, frame_size: int = 160, shape: HandShape = TEST_SHAPE,
               joint_noise_deg: float = 15.0, min_elevation_deg: float = 5.0, max_elevation_deg: float = 80.0,
               nuisances: Nuisances = ALL_NUISANCES, progress=None) -> GraspTestSet:
    """n random test images: grasp and stage uniform, viewpoint uniform in azimuth and in elevation
    within [min_elevation_deg, max_elevation_deg] (off the grid with probability 1)."""
    n = check_int(n, "n", min_value=1, max_value=100_000)
    frame_size = check_int(frame_size, "frame_size", min_value=32, max_value=1024)
    lo = check_real(min_elevation_deg, "min_elevation_deg", min_value=0.0, max_value=89.0)
    hi = check_real(max_elevation_deg, "max_elevation_deg", min_value=lo, max_value=89.0)
    joint_noise_deg = check_real(joint_noise_deg, "joint_noise_deg", min_value=0.0, max_value=45.0)

    def build():
        rng = np.random.default_rng([seed, 5, 2])
        g_idx = rng.integers(0, len(GRASP_CLASSES), n)
        stages = rng.integers(0, len(STAGES), n)
        return _render_set(rng, g_idx, stages, rng.uniform(0.0, 360.0, n), rng.uniform(lo, hi, n), frame_size,
                           shape, joint_noise_deg, nuisances, progress)

    return _cached(f"random{n}", dict(n=n, seed=seed, frame_size=frame_size, shape=shape, lo=lo, hi=hi,
                                      joint_noise_deg=joint_noise_deg, nuisances=_check_nuisances(nuisances)), build)


# skin tones for the skin colour model: lighter than, equal to and darker than the database hand,
# none of them the test hand's
_TRAINING_TONES = ((0.95, 0.78, 0.68, 1.0), DEFAULT_SHAPE.skin_rgba, (0.50, 0.33, 0.24, 1.0))


def skin_training_pixels(seed: int = 0, n_images: int = 12, frame_size: int = 96,
                         n_pixels: int = 20_000) -> tuple[np.ndarray, np.ndarray]:
    """(skin (n_pixels, 3), background (n_pixels, 3)) float32 RGB in [0, 255] for `fit_skin_model`.

    Skin: the (eroded) hand pixels of `n_images` renders of random grasps, views and lighting, with hands
    of the three `_TRAINING_TONES`. Background: clutter images and black objects (seed-independent of
    the test sets' clutter)."""
    n_images = check_int(n_images, "n_images", min_value=1, max_value=1000)
    n_pixels = check_int(n_pixels, "n_pixels", min_value=100)
    rng = np.random.default_rng([seed, 5, 3])
    skin, background = [], []
    for i in range(n_images):
        g = GRASP_CLASSES[i % len(GRASP_CLASSES)]
        shape = HandShape(skin_rgba=_TRAINING_TONES[i % len(_TRAINING_TONES)])
        with GraspRenderer(g, frame_size, frame_size, shape) as r:
            rgb, hand = _render_one(r, rng, g, 2, rng.uniform(0, 360), rng.uniform(5, 80), frame_size, shape,
                                    10.0, with_clutter=False)
        core = cv2.erode(hand.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        skin.append(rgb[core])
        background.append(clutter_background(rng, frame_size).reshape(-1, 3))
        background.append(rgb[~cv2.dilate(hand.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)])
    skin, background = np.concatenate(skin), np.concatenate(background)
    pick = lambda x: x[rng.choice(len(x), n_pixels, replace=len(x) < n_pixels)].astype(np.float32)
    return pick(skin), pick(background)


def stage_subsets(stage: np.ndarray) -> dict[str, np.ndarray]:
    """Boolean masks of GRASP's X (all), X' (without the most neutral snapshots) and X'' (completed)."""
    stage = np.asarray(stage)
    return {"X": np.ones(stage.shape, bool), "Xp": stage >= 1, "Xpp": stage == 2}


__all__ = ["ALL_NUISANCES", "GraspTestSet", "Nuisances", "STAGES", "clutter_background", "random_set", "sequence_set", "skin_training_pixels",
           "stage_subsets"]
