"""A domain-randomised view database for grasp recognition (issue 20), and the validation hand.

GRASP's database (`sim.grasp_views.view_database`) shows one hand in one exact posture per grasp. Test
images show another hand, on its way to the grasp, with its joints a little off. `randomized_views`
renders, for each grasp, views of randomly drawn hands (`random_hand`: anthropometry and skin tone),
each view with its own random posture along the reach, lighting, camera distance and aim, blur and
noise, from a random viewpoint on the upper half-sphere; every view is labelled with its grasp and
its camera orientation (`sim.grasp_views.view_euler`) and cropped by the renderer's hand mask like the
database. The ranges below were set from general anthropometry and imaging, before any test image
was looked at; the choices among configurations are made on a validation set drawn with
`VALIDATION_SHAPE` and its own seed, never with the test hand (`sim.human_hand.TEST_SHAPE`).

Shapes: V views, S crop pixels.
"""
from __future__ import annotations

import hashlib
import json

import cv2
import numpy as np

from hog_jax import euler_to_quat
from lfd_common import cache_dir, check_int, load_arrays, save_arrays
from sim.grasp_objects import GRASP_CLASSES
from sim.grasp_views import GraspRenderer, ViewDatabase, crop_hand, hand_center, sphere_camera, view_euler
from sim.human_grasps import GRASP_POSTURES, posture
from sim.human_hand import DEFAULT_SHAPE, HandShape, clip_posture

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


def _random_view(renderer: GraspRenderer, rng: np.random.Generator, grasp: int, shape: HandShape, out_size: int):
    """One randomised view: (crop (S, S), mask (S, S), azimuth_deg, elevation_deg)."""
    reach = rng.uniform()  # 0: the relaxed hand, 1: the grasp
    joints = posture(grasp, reach) + rng.uniform(-_JOINT_NOISE_DEG, _JOINT_NOISE_DEG, 20)
    renderer.set_posture(clip_posture(joints))
    direction = -hand_center(grasp, shape)
    renderer.set_object_offset(direction / np.linalg.norm(direction) * (1.0 - reach) * _REACH_OBJECT_DISTANCE_M)
    renderer.set_lighting(rng.uniform(0.15, 0.55), rng.uniform(0.3, 1.0),
                          [rng.uniform(-1, 1), rng.uniform(-1, 1), -rng.uniform(0.2, 1.0)])
    azimuth, elevation = rng.uniform(0.0, 360.0), rng.uniform(0.0, 90.0)
    target = hand_center(grasp, shape) + rng.normal(0.0, 0.02, 3)
    rgb, hand, _ = renderer.render_with_mask(*sphere_camera(azimuth, elevation, rng.uniform(0.5, 0.8), target=target))
    img = cv2.GaussianBlur(rgb.astype(np.float32), (0, 0), rng.uniform(0.1, 1.0))
    img += rng.normal(0.0, rng.uniform(0.0, 6.0), img.shape)
    crop, mask = crop_hand(np.clip(img, 0, 255), hand, out_size)
    return crop, mask, azimuth, elevation


def randomized_views(n_views_per_grasp: int, n_hands_per_grasp: int, seed: int = 0, render_size: int = 128,
                     out_size: int = 64, progress=None) -> ViewDatabase:
    """`n_views_per_grasp` randomised views of each grasp, spread over `n_hands_per_grasp` random hands
    (see the module docstring), as a `sim.grasp_views.ViewDatabase`; cached under
    `cache_dir("grasp_views")` keyed by every argument. `progress(iterable, total, desc)` wraps the
    per-grasp loops."""
    n_views = check_int(n_views_per_grasp, "n_views_per_grasp", min_value=1, max_value=1_000_000)
    n_hands = check_int(n_hands_per_grasp, "n_hands_per_grasp", min_value=1, max_value=n_views)
    settings = dict(n_views=n_views, n_hands=n_hands, seed=seed, render_size=render_size, out_size=out_size,
                    postures=repr(GRASP_POSTURES), default=repr(DEFAULT_SHAPE), version=_VERSION)
    key = hashlib.sha1(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]
    path = cache_dir("grasp_views") / f"randomized_{n_views}x{n_hands}_{out_size}px_{key}.npz"
    if path.exists():
        arrays, _, _ = load_arrays(path, "sim.ViewDatabase")
        return ViewDatabase(**{f: arrays[f] for f in ViewDatabase._fields})
    images = np.zeros((len(GRASP_CLASSES) * n_views, out_size, out_size), np.float32)
    masks = np.zeros(images.shape, bool)
    az, el = np.zeros(len(images)), np.zeros(len(images))
    for gi, g in enumerate(GRASP_CLASSES):
        rng = np.random.default_rng([seed, 20, g])
        per_hand = np.diff(np.linspace(0, n_views, n_hands + 1).astype(int))
        loop = range(n_hands) if progress is None else progress(range(n_hands), n_hands, f"randomised views, grasp {g}")
        row = gi * n_views
        for h in loop:  # one MuJoCo model per hand
            shape = random_hand(rng)
            with GraspRenderer(g, render_size, render_size, shape) as renderer:
                for _ in range(per_hand[h]):
                    images[row], masks[row], az[row], el[row] = _random_view(renderer, rng, g, shape, out_size)
                    row += 1
    euler = view_euler(az, el).astype(np.float32)
    db = ViewDatabase(images=images, masks=masks, labels=np.repeat(np.arange(len(GRASP_CLASSES), dtype=np.int32), n_views),
                      euler=euler, quat=np.asarray(euler_to_quat(euler)), azimuth_deg=az, elevation_deg=el)
    save_arrays(path, "sim.ViewDatabase", db._asdict(), config=settings)
    return db


def concatenate_databases(*dbs: ViewDatabase) -> ViewDatabase:
    """One `ViewDatabase` of the rows of all `dbs`, in order."""
    if not dbs:
        raise ValueError("dbs: need at least one database")
    return ViewDatabase(*(np.concatenate([getattr(d, f) for d in dbs]) for f in ViewDatabase._fields))


__all__ = ["VALIDATION_SHAPE", "concatenate_databases", "random_hand", "randomized_views"]
