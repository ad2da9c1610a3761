"""A domain-randomised view database and training scenes for grasp recognition, and the
validation hand.

`database` builds the grasp recognition study's view database (`DatabaseOptions`, its presets'
values in `DATABASE_PRESETS`): GRASP's grid of rendered views, the randomised views below, crops
degraded to a small hand (`degrade_crops`).

GRASP's database (`sim.grasp_views.view_database`) shows one hand in one exact posture per grasp. Test
images show another hand, on its way to the grasp, with its joints a little off. `randomized_views`
renders, for each grasp, views of randomly drawn hands (`random_hand`: anthropometry and skin tone),
each view with its own random posture along the reach, lighting, camera distance and aim, blur and
noise, from a random viewpoint on the upper half-sphere; every view is labelled with its grasp and
its camera orientation (`sim.grasp_views.view_euler`) and cropped by the renderer's hand mask like the
database. `randomized_scenes` renders whole frames of such hands holding or reaching for objects of
random colours in front of clutter, for a recogniser that sees the held object (it segments them as it
segments its queries). The ranges below were set from general anthropometry and imaging, before any
test image was looked at; the choices among configurations are made on a validation set drawn with
`VALIDATION_SHAPE` and its own seed, never with the test hand (`sim.human_hand.TEST_SHAPE`).

Shapes: V views, S crop pixels.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import cv2
import jax
import jax.numpy as jnp
import numpy as np

from hog_jax import euler_to_quat
from experiments.data.grasp_tests import clutter_background
from lfd_common import Cache, check_int, check_real
from sim.grasping import GRASP_CLASSES
from sim.grasping import GraspRenderer, ViewDatabase, crop_hand, hand_center, sphere_camera, view_euler
from sim.grasping import ViewOptions, view_database
from sim.hands import posture
from sim.hands import DEFAULT_SHAPE, HandShape, clip_posture

# a hand neither the database's nor the test's: short fingers, thick, narrow palm, a medium skin tone
VALIDATION_SHAPE = HandShape(
    finger_lengths=((0.043, 0.030, 0.026), (0.042, 0.024, 0.021), (0.046, 0.028, 0.022),
                    (0.044, 0.027, 0.021), (0.035, 0.019, 0.018)),
    finger_radius=0.0105, palm_length=0.090, palm_width=0.080, palm_thickness=0.033,
    skin_rgba=(0.78, 0.56, 0.44, 1.0))

_LIGHT_TONE, _DARK_TONE = np.array([0.96, 0.80, 0.70]), np.array([0.42, 0.27, 0.19])
_JOINT_NOISE_DEG = 15.0
_REACH_OBJECT_DISTANCE_M = 0.15
_VERSION = 1


def random_hand(rng: np.random.Generator) -> HandShape:
    """A random adult hand about the database hand: overall size x U(0.88, 1.12) (roughly the 5th to 95th
    percentile of adult hand length), each finger's length x U(0.94, 1.06) more, finger radius
    x U(0.8, 1.2), palm width x U(0.9, 1.1), thickness x U(0.8, 1.2), skin tone uniform between a light
    and a dark tone."""
    size = rng.uniform(0.88, 1.12)
    lengths = np.asarray(DEFAULT_SHAPE.finger_lengths) * size * rng.uniform(0.94, 1.06, (5, 1))
    tone = _LIGHT_TONE + rng.uniform() * (_DARK_TONE - _LIGHT_TONE)
    return HandShape(finger_lengths=tuple(map(tuple, lengths)),
                     finger_radius=DEFAULT_SHAPE.finger_radius * rng.uniform(0.8, 1.2),
                     palm_length=DEFAULT_SHAPE.palm_length * size,
                     palm_width=DEFAULT_SHAPE.palm_width * size * rng.uniform(0.9, 1.1),
                     palm_thickness=DEFAULT_SHAPE.palm_thickness * rng.uniform(0.8, 1.2),
                     skin_rgba=(*tone, 1.0))


def _random_pose(renderer: GraspRenderer, rng: np.random.Generator, grasp: int, shape: HandShape, reach: float):
    """Set a random posture `reach` of the way along the reach (0: the relaxed hand, 1: the grasp) with
    joint noise, the object that far from the hand, random lighting; -> (camera position, rotation,
    azimuth_deg, elevation_deg) of a random viewpoint on the upper half-sphere."""
    joints = posture(grasp, reach) + rng.uniform(-_JOINT_NOISE_DEG, _JOINT_NOISE_DEG, 20)
    renderer.set_posture(clip_posture(joints))
    direction = -hand_center(grasp, shape)
    renderer.set_object_offset(direction / np.linalg.norm(direction) * (1.0 - reach) * _REACH_OBJECT_DISTANCE_M)
    renderer.set_lighting(rng.uniform(0.15, 0.55), rng.uniform(0.3, 1.0),
                          [rng.uniform(-1, 1), rng.uniform(-1, 1), -rng.uniform(0.2, 1.0)])
    azimuth, elevation = rng.uniform(0.0, 360.0), rng.uniform(0.0, 90.0)
    target = hand_center(grasp, shape) + rng.normal(0.0, 0.02, 3)
    return (*sphere_camera(azimuth, elevation, rng.uniform(0.5, 0.8), target=target), azimuth, elevation)


def _random_view(renderer: GraspRenderer, rng: np.random.Generator, grasp: int, shape: HandShape, out_size: int):
    """One randomised view: (crop (S, S), mask (S, S), azimuth_deg, elevation_deg)."""
    camera, rotation, azimuth, elevation = _random_pose(renderer, rng, grasp, shape, rng.uniform())
    rgb, hand, _ = renderer.render_with_mask(camera, rotation)
    img = cv2.GaussianBlur(rgb.astype(np.float32), (0, 0), rng.uniform(0.1, 1.0))
    img += rng.normal(0.0, rng.uniform(0.0, 6.0), img.shape)
    crop, mask = crop_hand(np.clip(img, 0, 255), hand, out_size)
    return crop, mask, azimuth, elevation


# `sim` holds the grasp postures, the database hand and the renderer; `grasp_tests` the clutter.
_SETS = Cache("grasp_views", packages=("experiments.data.grasp_database", "experiments.data.grasp_tests", "sim",
                                       "hog_jax", "lfd_common"), version=_VERSION)


def _cached(name: str, settings: dict, build):
    """`build()`, stored under cache_dir("grasp_views") by `name`, `settings` and the source it runs, and
    reused while they match."""
    return _SETS.get(build, set=name, **settings)


def _hand_renders(seed: int, stream: int, n_views: int, n_hands: int, size: int, progress, desc: str):
    """For each grasp in turn, `n_views` times: (row, grasp, rng, renderer, hand shape), the views of a
    grasp spread over `n_hands` random hands (one MuJoCo model each), the rows consecutive; the grasp's
    random stream is `default_rng([seed, stream, grasp])`. `progress(iterable, total, desc)` wraps the
    hands of each grasp."""
    row = 0
    for g in GRASP_CLASSES:
        rng = np.random.default_rng([seed, stream, g])
        per_hand = np.diff(np.linspace(0, n_views, n_hands + 1).astype(int))
        loop = range(n_hands) if progress is None else progress(range(n_hands), n_hands, f"{desc}, grasp {g}")
        for h in loop:
            shape = random_hand(rng)
            with GraspRenderer(g, size, size, shape) as renderer:
                for _ in range(per_hand[h]):
                    yield row, g, rng, renderer, shape
                    row += 1


def randomized_views(n_views_per_grasp: int, n_hands_per_grasp: int, seed: int = 0, render_size: int = 128,
                     out_size: int = 64, progress=None) -> ViewDatabase:
    """`n_views_per_grasp` randomised views of each grasp, spread over `n_hands_per_grasp` random hands
    (see the module docstring), as a `sim.grasp_views.ViewDatabase`; cached under
    `cache_dir("grasp_views")` keyed by every argument. `progress(iterable, total, desc)` wraps the
    per-grasp loops."""
    n_views = check_int(n_views_per_grasp, "n_views_per_grasp", min_value=1, max_value=1_000_000)
    n_hands = check_int(n_hands_per_grasp, "n_hands_per_grasp", min_value=1, max_value=n_views)
    settings = dict(n_views=n_views, n_hands=n_hands, seed=seed, render_size=render_size, out_size=out_size)

    def build():
        images = np.zeros((len(GRASP_CLASSES) * n_views, out_size, out_size), np.float32)
        masks = np.zeros(images.shape, bool)
        az, el = np.zeros(len(images)), np.zeros(len(images))
        for row, g, rng, renderer, shape in _hand_renders(seed, 20, n_views, n_hands, render_size, progress,
                                                          "randomised views"):
            images[row], masks[row], az[row], el[row] = _random_view(renderer, rng, g, shape, out_size)
        euler = view_euler(az, el).astype(np.float32)
        return ViewDatabase(images=images, masks=masks, euler=euler, quat=np.asarray(euler_to_quat(euler)),
                            labels=np.repeat(np.arange(len(GRASP_CLASSES), dtype=np.int32), n_views),
                            azimuth_deg=az, elevation_deg=el)

    return _cached(f"randomized_{n_views}x{n_hands}_{out_size}px", settings, build)


class SceneSet(NamedTuple):
    """frames (N, H, W, 3) uint8 whole camera frames; labels (N,) int32 indices into GRASP_CLASSES;
    euler (N, 3) radians (`sim.grasp_views.view_euler`), quat (N, 4); reach (N,) how far along the reach
    (1: the grasp completed); foreground (N, H, W) bool, where the renderer drew the hand or the object
    (the rest is the pasted clutter: what a realism step may replace, `lfd_jax.grasp.paste_backgrounds`)."""

    frames: np.ndarray
    labels: np.ndarray
    euler: np.ndarray
    quat: np.ndarray
    reach: np.ndarray
    foreground: np.ndarray


def randomized_scenes(n_per_grasp: int, n_hands_per_grasp: int, seed: int = 0, frame_size: int = 160,
                      completed_share: float = 0.5, progress=None) -> SceneSet:
    """Whole frames of randomly drawn hands (`random_hand`) holding or reaching for their grasp's object,
    for a recogniser that sees what is around the hand: each frame as `randomized_views` (posture along
    the reach with joint noise, lighting, camera), the grasp completed with probability `completed_share`
    (else a reach fraction uniform in [0, 1]), the object in a random colour (each channel uniform in
    [0, 1]), in front of random clutter (`grasp_tests.clutter_background`, this function's own seeds),
    blurred and noisy. Cached under `cache_dir("grasp_views")` keyed by every argument."""
    n_views = check_int(n_per_grasp, "n_per_grasp", min_value=1, max_value=1_000_000)
    n_hands = check_int(n_hands_per_grasp, "n_hands_per_grasp", min_value=1, max_value=n_views)
    size = check_int(frame_size, "frame_size", min_value=32, max_value=1024)
    share = check_real(completed_share, "completed_share", min_value=0.0, max_value=1.0)
    settings = dict(n_views=n_views, n_hands=n_hands, seed=seed, frame_size=size, completed_share=share)

    def build():
        frames = np.zeros((len(GRASP_CLASSES) * n_views, size, size, 3), np.uint8)
        foreground = np.zeros(frames.shape[:3], bool)
        az, el, reach = (np.zeros(len(frames)) for _ in range(3))
        for row, g, rng, renderer, shape in _hand_renders(seed, 22, n_views, n_hands, size, progress, "scenes"):
            reach[row] = 1.0 if rng.uniform() < share else rng.uniform()
            camera, rotation, az[row], el[row] = _random_pose(renderer, rng, g, shape, reach[row])
            renderer.set_object_rgba([*rng.uniform(0.0, 1.0, 3), 1.0])
            rgb, hand, obj = renderer.render_with_mask(camera, rotation)
            foreground[row] = hand | obj
            background = clutter_background(rng, size).astype(np.float32)
            img = np.where(foreground[row][..., None], rgb.astype(np.float32), background)
            img = cv2.GaussianBlur(img, (0, 0), rng.uniform(0.1, 1.2))
            img += rng.normal(0.0, rng.uniform(0.0, 8.0), img.shape)
            frames[row] = np.clip(np.round(img), 0, 255).astype(np.uint8)
        euler = view_euler(az, el).astype(np.float32)
        return SceneSet(frames, np.repeat(np.arange(len(GRASP_CLASSES), dtype=np.int32), n_views), euler,
                        np.asarray(euler_to_quat(euler)), reach, foreground)

    return _cached(f"scenes_{n_views}x{n_hands}_{size}px", settings, build)


def concatenate_databases(*dbs: ViewDatabase) -> ViewDatabase:
    """One `ViewDatabase` of the rows of all `dbs`, in order."""
    if not dbs:
        raise ValueError("dbs: need at least one database")
    return ViewDatabase(*(np.concatenate([getattr(d, f) for d in dbs]) for f in ViewDatabase._fields))


def degrade_crops(images: np.ndarray, masks: np.ndarray, pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """Crops (N, S, S) and masks as a camera that saw the hand `pixels` across would give them: resampled
    (linear, antialiased) down to pixels x pixels and back up to S x S, as `hog_jax.segment` resamples a
    small box; masks through the same path, thresholded at 0.5. ValueError naming the argument."""
    images = np.asarray(images, np.float32)
    if images.ndim != 3 or images.shape[1] != images.shape[2]:
        raise ValueError(f"images: expected (N, S, S) crops, got shape {images.shape}")
    if np.shape(masks) != images.shape:
        raise ValueError(f"masks: expected the images' shape {images.shape}, got {np.shape(masks)}")
    side = images.shape[1]
    if isinstance(pixels, bool) or not isinstance(pixels, (int, np.integer)) or not 1 <= pixels <= side:
        raise ValueError(f"pixels: expected an int in [1, {side}], got {pixels!r}")

    def through(x):
        small = jax.image.resize(jnp.asarray(x, jnp.float32), (len(x), pixels, pixels), "linear", antialias=True)
        return jax.image.resize(small, (len(x), side, side), "linear", antialias=True)

    m = masks.astype(np.float32)
    return np.asarray(through(images * m)), np.asarray(through(m)) > 0.5


@dataclasses.dataclass(frozen=True)
class DatabaseOptions:
    """The grasp recognition study's view database (`database`); the defaults are GRASP's (60 x 15
    views per grasp, §V)."""

    seed: int = 0
    n_azimuth: int = 60
    n_elevation: int = 15
    render_size: int = 128
    crop_size: int = 64
    n_random_views: int = 0          # domain-randomised views per grasp added to the grid (0: none) ...
    random_pool: int = 8100          # ... drawn at random from a rendered pool of this many per grasp
    n_random_hands: int = 30         # random hands per grasp the pool is spread over
    db_pixels: int = 0               # crops degraded to a hand this many pixels across (0: as rendered)

    def __post_init__(self):
        for name in ("n_azimuth", "n_elevation", "render_size", "crop_size", "random_pool", "n_random_hands"):
            check_int(getattr(self, name), name, min_value=1)
        check_int(self.seed, "seed", min_value=0)
        check_int(self.n_random_views, "n_random_views", min_value=0, max_value=self.random_pool)
        check_int(self.db_pixels, "db_pixels", min_value=0, max_value=self.crop_size)


# The database fields of the grasp recognition study's presets (its `config.PRESETS` take them from here;
# the imitation loop's grasp stage builds the database of a preset by name).
DATABASE_PRESETS: dict[str, dict] = {
    "quick": {"n_azimuth": 30, "n_elevation": 8},
    "paper": {},
    "best": {"n_random_views": 8100},
}


def grid_views(n_azimuth: int, n_elevation: int, render_size: int = 128, crop_size: int = 64,
               progress=None) -> ViewDatabase:
    """GRASP's grid database (`sim.grasping.view_database`): every grasp class from an azimuth x
    elevation grid, `render_size` renders cropped to `crop_size`. `progress(iterable, total, desc)`
    wraps the per-grasp loops."""
    return view_database(GRASP_CLASSES, n_azimuth, n_elevation,
                         ViewOptions(render_size=render_size, out_size=crop_size), progress=progress)


def database(options: DatabaseOptions, progress=None) -> ViewDatabase:
    """The grid database, plus `options.n_random_views` domain-randomised views per grasp, a seeded random
    subset of a pool of `options.random_pool` per grasp (one rendered pool serves every size); with
    `options.db_pixels`, every crop degraded to that resolution (`degrade_crops`).
    `progress(iterable, total, desc)` wraps the rendering loops."""
    if not isinstance(options, DatabaseOptions):
        raise ValueError(f"options: expected DatabaseOptions, got {type(options).__name__}")
    cfg = options
    db = grid_views(cfg.n_azimuth, cfg.n_elevation, cfg.render_size, cfg.crop_size, progress)
    if cfg.n_random_views:
        pool = randomized_views(cfg.random_pool, cfg.n_random_hands, cfg.seed, cfg.render_size, cfg.crop_size,
                                progress=progress)
        rng = np.random.default_rng([cfg.seed, 21])
        rows = np.concatenate([g * cfg.random_pool + np.sort(rng.choice(cfg.random_pool, cfg.n_random_views,
                                                                        replace=False))
                               for g in range(len(GRASP_CLASSES))])
        db = concatenate_databases(db, type(pool)(*(a[rows] for a in pool)))
    if not cfg.db_pixels:
        return db
    images, masks = degrade_crops(db.images, db.masks, cfg.db_pixels)
    return db._replace(images=images, masks=masks)


__all__ = ["DATABASE_PRESETS", "VALIDATION_SHAPE", "DatabaseOptions", "SceneSet", "concatenate_databases", "database",
           "degrade_crops", "grid_views", "random_hand", "randomized_scenes", "randomized_views"]
