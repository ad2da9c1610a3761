"""Class names, camera constants, the data set settings, persons and the data container."""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from lfd_common import check_int, check_real


CLASSES: tuple[str, ...] = ("look through binoculars", "drink from cup", "pour from pitcher")
ACTIONS: tuple[str, ...] = ("look through", "drink from", "pour from")
OBJECTS: tuple[str, ...] = ("binoculars", "cup", "pitcher")
N_CLASSES = 3
VERSION = "oac-v3"

# Camera (both views share intrinsics; rectified pair, right camera along the left camera's x axis).
FOCAL_PX = 525.0
IMAGE_SIZE_PX = (640, 480)
BASELINE_M = 0.12
TABLE_Z_M = 0.75


@dataclasses.dataclass(frozen=True)
class OACSettings:
    """Every setting of the generator (all of them key the cache)."""

    seed: int = 0
    n_persons: int = 10
    n_repetitions: int = 5
    fps: float = 10.0
    duration_s: float = 4.0          # mean recording length (pick-up to put-down) at speed 1
    image_px: int = 48               # side of the rendered hand / object views
    object_px: int = 32              # side of the square-normalised object crop
    hand_levels: int = 3             # HOG pyramid levels of the hand (ECCV: L = 3)
    object_levels: int = 1           # HOG pyramid levels of the object (ECCV §5: L = 1)
    n_bins: int = 4                  # HOG orientation bins (B = 4)
    centroid_noise_px: float = 2.5   # std of the segmentation centroid error per blob (same in both images)
    stereo_noise_px: float = 1.0     # std of the part of that error that differs between left and right
    merge_noise_px: float = 6.0      # extra std while hand and face blobs touch
    pixel_noise: float = 0.03        # grey-level camera noise (images in [0, 1])
    exposure_s: float = 0.03         # shutter time: motion blur of the hand and object views

    def __post_init__(self):
        check_int(self.seed, "seed")
        check_int(self.n_persons, "n_persons", min_value=1, max_value=100)
        check_int(self.n_repetitions, "n_repetitions", min_value=1, max_value=100)
        check_real(self.fps, "fps", min_value=1.0, max_value=60.0)
        check_real(self.duration_s, "duration_s", min_value=1.0, max_value=30.0)
        check_int(self.image_px, "image_px", min_value=16, max_value=256)
        check_int(self.object_px, "object_px", min_value=8, max_value=256)
        check_int(self.hand_levels, "hand_levels", min_value=1, max_value=5)
        check_int(self.object_levels, "object_levels", min_value=1, max_value=5)
        check_int(self.n_bins, "n_bins", min_value=2, max_value=16)
        for name in ("centroid_noise_px", "stereo_noise_px", "merge_noise_px", "pixel_noise", "exposure_s"):
            check_real(getattr(self, name), name, min_value=0.0)


class Person(NamedTuple):
    """Anthropometry and style of one demonstrator (all arrays are scalars or small vectors)."""

    female: bool
    size: float            # body scale (1 = average man)
    speed: float           # > 1 is faster
    amplitude: float       # reach scale (how far the object travels)
    arc_m: np.ndarray      # (3,) mid-path bulge of the transport
    target_m: np.ndarray   # (3, 3) per-class offset of the action target
    hold: float            # fraction of the recording spent in the action
    tilt: float            # scale of the drinking / pouring tilt
    roll_rad: float        # wrist roll about the grasped axis
    cup_by_handle: bool    # holds the cup by its handle (Small Diameter) instead of around its body
    camera_m: np.ndarray   # (3,) camera position offset
    camera_dist_m: float   # camera distance to the face


class OACData(NamedTuple):
    """A simulated OAC data set: N recordings padded to T frames.

    action, object, person, repetition: (N,) int; lengths: (N,) int frames;
    pos2d (N, T, 2) px; pos3d (N, T, 3) m; hand_hog (N, T, Dh); object_hog (N, T, Do);
    hand_true (N, T, 3) m, the hand centre relative to the face in the world frame (for plots).
    Padding frames are zero.
    """

    action: np.ndarray
    object: np.ndarray
    person: np.ndarray
    repetition: np.ndarray
    lengths: np.ndarray
    pos2d: np.ndarray
    pos3d: np.ndarray
    hand_hog: np.ndarray
    object_hog: np.ndarray
    hand_true: np.ndarray


def draw_persons(rng: np.random.Generator, n: int) -> list[Person]:
    """n demonstrators; the last 30 % are women (7 men, 3 women for n = 10)."""
    n_women = int(round(0.3 * n))
    persons = []
    for i in range(n):
        female = i >= n - n_women
        persons.append(Person(
            female=female,
            size=float(np.clip((0.93 if female else 1.0) + 0.05 * rng.standard_normal(), 0.82, 1.15)),
            speed=float(np.exp(0.18 * rng.standard_normal())),
            amplitude=float(np.clip(1.0 + 0.1 * rng.standard_normal(), 0.8, 1.2)),
            arc_m=np.array([0.06, 0.03, 0.05]) * rng.standard_normal(3),
            target_m=0.025 * rng.standard_normal((N_CLASSES, 3)),
            hold=float(rng.uniform(0.3, 0.5)),
            tilt=float(np.clip(1.0 + 0.2 * rng.standard_normal(), 0.6, 1.4)),
            roll_rad=float(0.25 * rng.standard_normal()),
            cup_by_handle=bool(rng.uniform() < 0.3),
            camera_m=np.array([0.15, 0.0, 0.08]) * rng.standard_normal(3),
            camera_dist_m=float(rng.uniform(1.4, 1.8)),
        ))
    return persons
