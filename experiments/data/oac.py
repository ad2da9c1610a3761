"""Simulated OAC recordings (ECCV 2008 §5, LfD 2009 §V): three object-action complexes performed by
10 persons x 5 repetitions, seen by a small-baseline stereo camera.

Classes (action, object, the grasp of `sim.grasp_objects` the hand takes):
    0 look through binoculars   (grasp 1, Large Diameter around the right barrel)
    1 drink from cup            (grasp 4, Abducted Thumb around the cup body; or, for about 3 persons
                                 in 10, grasp 2, Small Diameter around the cup's handle)
    2 pour from pitcher         (grasp 2, Small Diameter around the handle)
Two actions look alike in hand position ("look through" and "drink from" both bring the hand to the
face; the hand centroid differs by a few centimetres, less than persons differ) and two objects look
alike (cup and pitcher: same white ceramic, a cylinder with a handle; after the square-normalised,
one-level object HOG of §5 their size difference is gone).

A recording is pre-segmented (pick-up to put-down): the grasped object is lifted from the table,
brought to the action's target (eyes / mouth / above a glass at chest height), the action is
performed (scanning with the binoculars, tilting the cup towards the face, tilting the pitcher to
pour), and the object is put back. Minimum-jerk transport with a person-specific arc, timing, reach
amplitude, target offsets, hold time and tilt; repetition-to-repetition jitter on all of them.

Persons (7 men and 3 women, as the papers) differ in body size (which scales the face height, the
reach and the hand; the hand model is scaled with it), speed, amplitude and style (arc, target
offsets, tilt, wrist roll, whether they hold the cup by its handle). Cameras: a rectified stereo pair (baseline 12 cm, f = 525 px, 640 x 480)
1.4-1.8 m in front of the person, its pose jittered per person.

Per frame t (T frames at `fps`, padded to the longest sequence, `lengths` gives the true ones):
    pos2d (2,)  hand-mask centroid minus face-mask centroid in the left image, pixels (x right, y down)
    pos3d (3,)  the same two centroids triangulated from left and right image, metres, camera frame
    hand_hog    HOG (B = 4, L = `hand_levels`) of the segmented hand image: the human hand model of
                `sim.human_hand` (scaled to the person) in the object's grasp (`sim.human_grasps`),
                rendered with MuJoCo from the camera's view; the mask is what skin segmentation
                gives (hand pixels, plus the face's when the two touch in the image; the object in
                front occludes the hand), with a one-pixel boundary error (erosion / dilation) and
                motion blur over the exposure; cropped to the mask's bounding square, grey levels
                with camera noise
    object_hog  HOG (B = 4, L = `object_levels`, 1 as in §5) of the object window: a fixed window,
                placed relative to the hand and shaped to the object's bounding box in the first
                frame (as ECCV §3), rescaled to a square (§5), object pixels only (the hand occludes)
Centroid measurement noise is what skin segmentation gives: a slowly varying (AR(1)) offset of a few
pixels per blob, larger when the hand blob touches the face blob (the papers separate merged blobs
with an alpha-beta filter). Most of that error is common to the left and right image; the 1 px
that is not makes the stereo depth noisy (about 6 cm per blob at 1.6 m), as LfD Fig. 7b shows.

Rendering: two small views per frame (hand, object window), each an RGB and a segmentation pass of
MuJoCo's offscreen renderer (shadows off), at `image_px` square, aimed from the left camera at the
hand / the object window (about 20 ms per frame on a 2-core CPU; every frame at `fps` is rendered);
the generated set is cached under `lfd_common.cache_dir("oac")` keyed by every setting. `generate(OACSettings(...))` -> `OACData`.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import sys
from typing import NamedTuple

import numpy as np

import sim  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
from lfd_common import cache_dir, check_int, check_real, write_npz

CLASSES: tuple[str, ...] = ("look through binoculars", "drink from cup", "pour from pitcher")
ACTIONS: tuple[str, ...] = ("look through", "drink from", "pour from")
OBJECTS: tuple[str, ...] = ("binoculars", "cup", "pitcher")
N_CLASSES = 3
_VERSION = "oac-v3"

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


# ----------------------------------------------------------------------------------------- geometry
def _rot(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) about unit `axis` (3,) by `angle` (...,) radians (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = np.asarray(angle)[..., None, None]
    return np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * (k @ k)


def _frame(z_axis: np.ndarray, x_hint: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) whose columns are x, y, z with z = `z_axis` and x as close to `x_hint` as possible."""
    z = z_axis / np.linalg.norm(z_axis)
    x = x_hint - (x_hint @ z) * z
    x = x / np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def _min_jerk(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def _bump(s: np.ndarray) -> np.ndarray:
    """Smooth 0 -> 1 -> 0 over s in [0, 1] (zero with zero slope at both ends)."""
    s = np.clip(s, 0.0, 1.0)
    return np.sin(np.pi * s) ** 2


# World: z up, the person's face centroid above the origin, the person faces -y (the camera).
# x is the camera's right (the person's left); the right hand works on the -x side.
def _face(person: Person) -> np.ndarray:
    return np.array([0.0, 0.0, TABLE_Z_M + 0.45 * person.size])


# Per class, relative to the face (metres, scaled by the person's size): where the grasped part rests
# on the table and where it is during the action; the grasped axis at rest and at the target; the
# direction (world) of the palm as seen from the grasped axis.
_REST = np.array([[-0.20, -0.38], [-0.20, -0.35], [-0.24, -0.40]])  # (x, y); z: on the table
_TARGET = np.array([
    [-0.035, -0.13, 0.02],   # right barrel in front of the right eye
    [-0.020, -0.10, -0.07],  # cup at the mouth
    [0.020, -0.38, -0.28],   # pitcher above a glass at chest height, in front
])
_AXIS = (np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]))
_PALM = (np.array([-1.0, 0.0, 0.2]), np.array([-1.0, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0]))


def object_trajectory(cls: int, person: Person, rng: np.random.Generator, n_frames: int):
    """Pose of the grasped part over the recording: positions (T, 3) m (world) and rotations (T, 3, 3).

    Columns of the rotation: the grasped part's x axis (pointing away from the palm), y, and z (the
    grasped axis: barrel, cup axis, handle).
    """
    cls = check_int(cls, "cls", min_value=0, max_value=N_CLASSES - 1)
    n_frames = check_int(n_frames, "n_frames", min_value=4)
    s = np.linspace(0.0, 1.0, n_frames)
    face = _face(person)
    rest = face + person.size * np.array([_REST[cls][0], _REST[cls][1], 0.0])
    rest[2] = TABLE_Z_M + grip_of(cls, person).rest_height_m
    rest += 0.015 * rng.standard_normal(3) * np.array([1, 1, 0])
    target = face + person.size * (_TARGET[cls] + person.target_m[cls] + 0.012 * rng.standard_normal(3))
    if cls == 2:  # the pouring place scales with the person's reach; the face targets do not
        target = rest + person.amplitude * (1.0 + 0.03 * rng.standard_normal()) * (target - rest)
    hold = np.clip(person.hold + 0.04 * rng.standard_normal(), 0.2, 0.6)
    t_in = 0.5 * (1 - hold) * (1.0 + 0.1 * rng.standard_normal())
    t_out = t_in + hold
    go, back = _min_jerk(s / t_in), _min_jerk((s - t_out) / (1 - t_out))
    phase = np.clip((s - t_in) / hold, 0.0, 1.0)
    path = go - back  # 0 at rest, 1 at the target
    arc = person.arc_m + 0.015 * rng.standard_normal(3)
    transport = 4 * go * (1 - go) - 4 * back * (1 - back)  # bulge out, and back along the mirrored arc
    pos = rest + path[:, None] * (target - rest) + transport[:, None] * arc * person.size * person.amplitude
    roll = person.roll_rad + 0.1 * rng.standard_normal()
    base = _frame(_AXIS[cls], -_PALM[cls])
    base = base @ _rot(np.array([0.0, 0.0, 1.0]), roll)
    tilt = person.tilt * (1.0 + 0.1 * rng.standard_normal())
    act = _bump(phase)
    if cls == 0:    # scanning: a slow yaw sweep with the binoculars at the eyes
        sweep = np.deg2rad(10.0) * tilt * np.sin(2 * np.pi * (phase + rng.uniform())) * act
        rots = _rot(np.array([0.0, 0.0, 1.0]), sweep) @ base
    elif cls == 1:  # drinking: the cup's top tilts towards the face (+y), about the world x axis
        rots = _rot(np.array([1.0, 0.0, 0.0]), -np.deg2rad(65.0) * tilt * act) @ base
    else:           # pouring: the spout side (+x of the part) goes down, about the world y axis
        rots = _rot(np.array([0.0, 1.0, 0.0]), np.deg2rad(75.0) * tilt * act) @ base
    # a small wrist tremor on every class
    rots = _rot(np.array([0.0, 1.0, 0.0]), np.deg2rad(2.0) * np.sin(2 * np.pi * 1.3 * s + rng.uniform(0, 6))) @ rots
    return pos, rots


def camera_pose(person: Person) -> tuple[np.ndarray, np.ndarray]:
    """Left camera centre (3,) and rotation (3, 3) (columns: image x right, image y down, optical axis)."""
    face = _face(person)
    centre = face + np.array([0.0, -person.camera_dist_m, -0.05]) + person.camera_m
    look = face + np.array([0.0, -0.2, -0.2])
    fwd = (look - centre) / np.linalg.norm(look - centre)
    right = np.cross(fwd, np.array([0.0, 0.0, 1.0]))
    right /= np.linalg.norm(right)
    down = np.cross(fwd, right)
    return centre, np.stack([right, down, fwd], axis=1)


def project(points: np.ndarray, centre: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Pinhole projection of world points (..., 3) to pixels (..., 2) of a 640 x 480, f = 525 camera."""
    cam = (points - centre) @ rot
    c = np.array(IMAGE_SIZE_PX, float) / 2
    return FOCAL_PX * cam[..., :2] / cam[..., 2:3] + c


def triangulate(left_px: np.ndarray, right_px: np.ndarray) -> np.ndarray:
    """Rectified-stereo triangulation: pixels (..., 2) in both images -> points (..., 3) in the left camera frame."""
    c = np.array(IMAGE_SIZE_PX, float) / 2
    disparity = np.maximum(left_px[..., 0] - right_px[..., 0], 1.0)
    z = FOCAL_PX * BASELINE_M / disparity
    xy = (left_px - c) * (z / FOCAL_PX)[..., None]
    return np.concatenate([xy, z[..., None]], axis=-1)


def _ar1(rng: np.random.Generator, n: int, dims: int, rho: float = 0.8) -> np.ndarray:
    """Unit-variance AR(1) noise (n, dims)."""
    e = rng.standard_normal((n, dims))
    out = np.empty_like(e)
    out[0] = e[0]
    for t in range(1, n):  # n is a few dozen frames; runs once per recording, not in a hot path
        out[t] = rho * out[t - 1] + math.sqrt(1 - rho**2) * e[t]
    return out


def measured_positions(hand: np.ndarray, person: Person, rng: np.random.Generator, settings: OACSettings):
    """Hand-minus-face centroids as measured: pos2d (T, 2) px in the left image and pos3d (T, 3) m (stereo).

    hand (T, 3): true hand centre in the world. Each blob centroid (hand, face) gets AR(1) segmentation
    noise, larger while the hand blob touches the face blob; most of it is the same in the left and
    right image (the blob has the same shape in both), a smaller part (`stereo_noise_px`) is not,
    and that part sets the depth noise.
    """
    centre, rot = camera_pose(person)
    right_centre = centre + BASELINE_M * rot[:, 0]
    face = np.broadcast_to(_face(person), hand.shape)
    n = hand.shape[0]
    near = np.linalg.norm(project(hand, centre, rot) - project(face, centre, rot), axis=-1) \
        < 0.1 * FOCAL_PX / person.camera_dist_m  # the hand blob touches the face blob
    sigma_hand = (settings.centroid_noise_px + settings.merge_noise_px * near)[:, None]
    common = {"hand": sigma_hand * _ar1(rng, n, 2), "face": settings.centroid_noise_px * _ar1(rng, n, 2)}
    px = {}
    for name, cam in (("left", centre), ("right", right_centre)):
        px[name] = {k: project(p, cam, rot) + common[k] + settings.stereo_noise_px * _ar1(rng, n, 2)
                    for k, p in (("hand", hand), ("face", face))}
    pos2d = px["left"]["hand"] - px["left"]["face"]
    pos3d = (triangulate(px["left"]["hand"], px["right"]["hand"])
             - triangulate(px["left"]["face"], px["right"]["face"]))
    return pos2d, pos3d


# ------------------------------------------------------------------------------------------ objects
_DARK = "0.13 0.13 0.14 1"
_RIM = "0.3 0.3 0.32 1"
_CERAMIC = "0.9 0.9 0.86 1"
# MJCF geoms of each object in its grasped-part frame: z the grasped axis, x away from the palm.
_OBJECT_GEOMS: tuple[str, ...] = (
    # binoculars: the right barrel is grasped; the left one is 7.5 cm away; eyepieces at -z (the face)
    f"""<geom type="cylinder" size="0.036 0.055" rgba="{_DARK}"/>
        <geom type="cylinder" size="0.036 0.055" pos="0.075 0 0" rgba="{_DARK}"/>
        <geom type="cylinder" size="0.039 0.008" pos="0 0 0.055" rgba="{_RIM}"/>
        <geom type="cylinder" size="0.039 0.008" pos="0.075 0 0.055" rgba="{_RIM}"/>
        <geom type="cylinder" size="0.019 0.016" pos="0 0 -0.07" rgba="{_RIM}"/>
        <geom type="cylinder" size="0.019 0.016" pos="0.075 0 -0.07" rgba="{_RIM}"/>
        <geom type="box" size="0.02 0.012 0.035" pos="0.0375 0 -0.01" rgba="{_DARK}"/>
        <geom type="cylinder" size="0.011 0.013" pos="0.0375 0.012 -0.03" euler="1.5708 0 0" rgba="{_RIM}"/>""",
    # cup: a ceramic cylinder held around its body, the handle away from the palm
    f"""<geom type="cylinder" size="0.034 0.045" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.036 0.004" pos="0 0 0.043" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0.032 0 0.028 0.058 0 0.022" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0.058 0 0.022 0.058 0 -0.018" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0.058 0 -0.018 0.032 0 -0.025" rgba="{_CERAMIC}"/>""",
    # pitcher: the same ceramic, held by its handle; body, rim and spout away from the palm
    f"""<geom type="capsule" size="0.011" fromto="0 0 -0.05 0 0 0.05" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.009" fromto="0 0 0.05 0.045 0 0.068" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.009" fromto="0 0 -0.05 0.045 0 -0.062" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.062 0.1" pos="0.105 0 0" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.065 0.005" pos="0.105 0 0.097" rgba="{_CERAMIC}"/>
        <geom type="box" size="0.025 0.016 0.01" pos="0.172 0 0.092" euler="0 -0.5 0" rgba="{_CERAMIC}"/>""",
)
_CUP_BY_HANDLE_GEOMS = f"""<geom type="capsule" size="0.007" fromto="0 0 -0.02 0 0 0.02" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0 0 0.02 0.026 0 0.028" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0 0 -0.02 0.026 0 -0.025" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.034 0.045" pos="0.058 0 0" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.036 0.004" pos="0.058 0 0.043" rgba="{_CERAMIC}"/>"""


class _Grip(NamedTuple):
    """How an object is held: the Cutkosky grasp, the object's geoms in the grasped-part frame, the
    object window's centre (3,) in that frame and radius (m), and the grasped part's height above the
    table at rest (m)."""

    grasp: int
    geoms: str
    centre_m: np.ndarray
    radius_m: float
    rest_height_m: float


_GRIPS: tuple[_Grip, ...] = (
    _Grip(1, _OBJECT_GEOMS[0], np.array([0.0375, 0.0, 0.0]), 0.10, 0.036),  # binoculars, right barrel
    _Grip(4, _OBJECT_GEOMS[1], np.array([0.01, 0.0, 0.0]), 0.075, 0.045),   # cup, around the body
    _Grip(2, _OBJECT_GEOMS[2], np.array([0.09, 0.0, 0.0]), 0.17, 0.10),     # pitcher, by the handle
    _Grip(2, _CUP_BY_HANDLE_GEOMS, np.array([0.045, 0.0, 0.0]), 0.075, 0.045),  # cup, by the handle
)


def grip_of(cls: int, person: Person) -> _Grip:
    """The person's way of holding the object of class `cls` (some hold the cup by its handle)."""
    return _GRIPS[3] if cls == 1 and person.cup_by_handle else _GRIPS[cls]



def _hand_shape(person: Person):
    """The person's hand: `sim.human_hand.DEFAULT_SHAPE` scaled by sqrt(body size), skin tone varied."""
    from sim.human_hand import DEFAULT_SHAPE, HandShape

    k = math.sqrt(person.size)
    tone = 1.0 - 0.25 * (person.size * 7.0 % 1.0)  # a deterministic per-person skin tone
    skin = tuple(float(c) for c in np.clip(np.array(DEFAULT_SHAPE.skin_rgba[:3]) * tone, 0, 1)) + (1.0,)
    return HandShape(finger_lengths=tuple(tuple(v * k for v in row) for row in DEFAULT_SHAPE.finger_lengths),
                     finger_radius=DEFAULT_SHAPE.finger_radius * k, palm_length=DEFAULT_SHAPE.palm_length * k,
                     palm_width=DEFAULT_SHAPE.palm_width * k, palm_thickness=DEFAULT_SHAPE.palm_thickness * k,
                     skin_rgba=skin)


def _quat(rot: np.ndarray) -> np.ndarray:
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot, float).ravel())
    return q


def _grip(cls: int, person: Person) -> tuple[np.ndarray, np.ndarray]:
    """Hand pose (position (3,), rotation (3, 3)) in the grasped-part frame (x away from the palm).

    `sim.human_grasps` gives the hand in the frame of the grasp's own object (z its axis); that frame
    is turned about z so that the palm centre lies on the -x side, and the hand is moved out with
    its scale (a bigger hand holds the same object with its wrist further away).
    """
    import mujoco

    from sim.human_grasps import hand_pose_in_world

    pos, quat = hand_pose_in_world(grip_of(cls, person).grasp)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, quat)
    rot = rot.reshape(3, 3)
    shape = _hand_shape(person)
    palm = pos + rot @ np.array([0.5 * shape.palm_length, 0.0, -0.5 * shape.palm_thickness])
    alpha = math.pi - math.atan2(palm[1], palm[0])  # turn the palm direction onto -x
    fix = _rot(np.array([0.0, 0.0, 1.0]), alpha)
    return fix @ pos * math.sqrt(person.size), fix @ rot


def scene_xml(cls: int, person: Person, image_px: int) -> str:
    """MJCF: the person's head (skin) and one mocap body (the grasped part's frame) holding the object's
    geoms and the person's hand."""
    from sim.human_hand import hand_body_xml, hand_defaults_xml

    shape = _hand_shape(person)
    hand_pos, hand_rot = _grip(cls, person)
    head = _face(person) + np.array([0.0, 0.06, 0.0]) * person.size  # the face surface is in front
    skin = " ".join(f"{c:.4f}" for c in shape.skin_rgba)
    return f"""<mujoco model="oac_{cls}">
  <compiler angle="radian"/>
  <option gravity="0 0 0"/>
  <visual>
    <global offwidth="{image_px}" offheight="{image_px}"/>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.3 0.3 0.3" specular="0.05 0.05 0.05"/>
    <quality shadowsize="0" offsamples="0"/>
  </visual>
  <default>{hand_defaults_xml(shape)}</default>
  <worldbody>
    <light name="key" directional="true" castshadow="false" dir="0.3 0.5 -1" diffuse="0.6 0.6 0.6" specular="0.1 0.1 0.1"/>
    <body name="head" pos="{head[0]:.4f} {head[1]:.4f} {head[2]:.4f}">
      <geom type="ellipsoid" size="{0.075 * person.size:.4f} {0.085 * person.size:.4f} {0.11 * person.size:.4f}" rgba="{skin}"/>
    </body>
    <body name="grasped" mocap="true">
      <body name="object">{grip_of(cls, person).geoms}</body>
      {hand_body_xml(shape, pos=hand_pos, quat=_quat(hand_rot))}
    </body>
  </worldbody>
</mujoco>"""


# ---------------------------------------------------------------------------------------- rendering
class _Views:
    """MuJoCo offscreen views of one (class, person) scene: square crops aimed from the left camera."""

    def __init__(self, cls: int, person: Person, image_px: int):
        import mujoco

        self.model = mujoco.MjModel.from_xml_string(scene_xml(cls, person, image_px))
        self.data = mujoco.MjData(self.model)
        self.renderer = mujoco.Renderer(self.model, image_px, image_px)
        hand = self.model.body("hand").id
        obj = self.model.body("object").id
        parents = self.model.body_parentid
        in_hand = np.zeros(self.model.nbody, bool)
        for b in range(self.model.nbody):  # bodies are ordered parents first
            in_hand[b] = b == hand or (b > 0 and in_hand[parents[b]])
        body = self.model.geom_bodyid
        self.hand_geoms = np.flatnonzero(in_hand[body])
        # geom label: 0 nothing, 1 hand, 2 object, 3 head; index -1 (background) maps to 0 (the extra slot)
        self.label = np.zeros(self.model.ngeom + 1, np.int8)
        self.label[self.hand_geoms] = 1
        self.label[np.flatnonzero(body == obj)] = 2
        self.label[np.flatnonzero(body == self.model.body("head").id)] = 3
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE

    def pose(self, pos: np.ndarray, rot: np.ndarray, qpos: np.ndarray) -> np.ndarray:
        """Place the grasped part at (pos, rot); return the hand centre (3,) (mean of its geom centres)."""
        import mujoco

        self.data.qpos[:] = qpos
        self.data.mocap_pos[0] = pos
        self.data.mocap_quat[0] = _quat(rot)
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.geom_xpos[self.hand_geoms].mean(axis=0)

    def render(self, eye: np.ndarray, lookat: np.ndarray, half_extent_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Grey image (P, P) in [0, 1] and labels (P, P) (0 none, 1 hand, 2 object, 3 head) of a view from
        `eye` towards `lookat` whose half field of view spans `half_extent_m` at the lookat distance."""
        offset = lookat - eye
        dist = float(np.linalg.norm(offset))
        self.camera.lookat[:] = lookat
        self.camera.distance = dist
        self.camera.azimuth = math.degrees(math.atan2(offset[1], offset[0]))
        self.camera.elevation = math.degrees(math.asin(offset[2] / dist))
        self.model.vis.global_.fovy = math.degrees(2 * math.atan(half_extent_m / dist))
        self.renderer.update_scene(self.data, camera=self.camera)
        rgb = self.renderer.render()
        self.renderer.enable_segmentation_rendering()
        self.renderer.update_scene(self.data, camera=self.camera)
        seg = self.renderer.render()
        self.renderer.disable_segmentation_rendering()
        geom = np.where(seg[..., 1] == 5, seg[..., 0], -1)  # mjOBJ_GEOM == 5
        return rgb.mean(axis=-1) / 255.0, self.label[geom]

    def close(self):
        self.renderer.close()


def _crop_square(image: np.ndarray, box: tuple[int, int, int, int], size: int) -> np.ndarray:
    """Cut rows box[0]:box[1], columns box[2]:box[3] (zero outside the image) and rescale to size x size
    (aspect normalised, §5)."""
    import cv2

    r0, r1, c0, c1 = box
    pad = max(0, -r0, -c0, r1 - image.shape[0], c1 - image.shape[1])
    padded = np.pad(np.asarray(image, np.float32), pad)
    cut = padded[r0 + pad:r1 + pad, c0 + pad:c1 + pad]
    return cv2.resize(np.ascontiguousarray(cut), (size, size), interpolation=cv2.INTER_AREA)


def _square_box(mask: np.ndarray) -> tuple[int, int, int, int]:
    """The square around the mask's bounding box (may extend past the image; `_crop_square` pads)."""
    r0, r1, c0, c1 = _bbox(mask)
    side = max(r1 - r0, c1 - c0)
    r, c = (r0 + r1 - side) // 2, (c0 + c1 - side) // 2
    return r, r + side, c, c + side


def _jitter_mask(mask: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Skin-segmentation boundary error: the mask eroded or dilated by one pixel, or unchanged (1/3 each)."""
    import cv2

    kind = rng.integers(3)
    if kind == 2:
        return mask
    op = cv2.erode if kind == 0 else cv2.dilate
    out = op(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    return out if out.any() else mask


def _bbox(mask: np.ndarray, margin: int = 1) -> tuple[int, int, int, int]:
    """Bounding box (r0, r1, c0, c1) of a boolean mask, grown by `margin`; the whole image if empty."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return 0, mask.shape[0], 0, mask.shape[1]
    h, w = mask.shape
    return (max(rows[0] - margin, 0), min(rows[-1] + 1 + margin, h),
            max(cols[0] - margin, 0), min(cols[-1] + 1 + margin, w))


def skin_segment(label: np.ndarray) -> np.ndarray:
    """The hand mask a skin-colour segmentation gives: the skin pixels (hand and face, labels 1 and 3)
    connected to the hand; when the hand touches the face in the image, the face joins the mask."""
    import cv2

    skin = ((label == 1) | (label == 3)).astype(np.uint8)
    _, comp = cv2.connectedComponents(skin, connectivity=8)
    keep = np.unique(comp[label == 1])
    return np.isin(comp, keep[keep > 0])


def _motion_blur(image: np.ndarray, shift_px: np.ndarray) -> np.ndarray:
    """Average of `image` over a straight motion of `shift_px` (2,) pixels (x right, y down)."""
    import cv2

    steps = int(np.ceil(np.hypot(*shift_px)))
    if steps < 1:
        return image.astype(np.float32)
    size = 2 * steps + 1
    kernel = np.zeros((size, size), np.float32)
    for f in np.linspace(-0.5, 0.5, 2 * steps + 1):
        kernel[int(round(steps + f * shift_px[1])), int(round(steps + f * shift_px[0]))] += 1.0
    return cv2.filter2D(image.astype(np.float32), -1, kernel / kernel.sum(), borderType=cv2.BORDER_CONSTANT)


def record(views: _Views, cls: int, person: Person, rng: np.random.Generator, settings: OACSettings) -> dict:
    """Render one recording: hand and object images (T, P, P) / (T, S, S) with masks, positions, T."""
    from sim.human_grasps import GRASP_POSTURES
    from sim.human_hand import clip_posture, posture_qpos

    duration = settings.duration_s / person.speed * (1.0 + 0.08 * rng.standard_normal())
    n = max(int(round(duration * settings.fps)), 8)
    pos, rots = object_trajectory(cls, person, rng, n)
    grip = grip_of(cls, person)
    joints = clip_posture(np.asarray(GRASP_POSTURES[grip.grasp].joints_deg) + 4.0 * rng.standard_normal(20))
    qpos = posture_qpos(joints)
    eye, cam_rot = camera_pose(person)
    px, so = settings.image_px, settings.object_px
    hand_img, hand_mask = np.zeros((n, px, px), np.float32), np.zeros((n, px, px), bool)
    obj_img, obj_mask = np.zeros((n, so, so), np.float32), np.zeros((n, so, so), bool)
    hand = np.array([views.pose(pos[t], rots[t], qpos) for t in range(n)])
    # image motion during the exposure, in metres along the camera's image axes (x right, y down)
    blur_m = np.gradient(hand, axis=0) * settings.fps * settings.exposure_s @ cam_rot[:, :2]
    half_hand, half_obj = 0.16 * person.size, 1.2 * grip.radius_m
    window, box = None, None
    for t in range(n):  # one MuJoCo render per view and frame (the renderer is not batched)
        views.pose(pos[t], rots[t], qpos)
        grey, label = views.render(eye, hand[t], half_hand)
        blur = blur_m[t] * px / (2 * half_hand)
        mask = _motion_blur(skin_segment(label).astype(np.float32), blur) > 0.5
        mask = _jitter_mask(mask, rng)
        square = _square_box(mask)
        hand_img[t] = _crop_square(_motion_blur(grey, blur), square, px)
        hand_mask[t] = _crop_square(mask.astype(np.float32), square, px) > 0.5
        if window is None:  # the object window: placed relative to the hand, shaped in frame 0
            window = pos[0] + rots[0] @ grip.centre_m - hand[0]
        grey, label = views.render(eye, hand[t] + window, half_obj)
        if box is None:
            box = _bbox(label == 2)
        blur = blur_m[t] * px / (2 * half_obj)
        obj_img[t] = _crop_square(_motion_blur(grey, blur), box, so)
        obj_mask[t] = _crop_square(_motion_blur((label == 2).astype(np.float32), blur), box, so) > 0.5
    noise = settings.pixel_noise
    hand_img = np.clip(hand_img + noise * rng.standard_normal(hand_img.shape), 0, 1) * hand_mask
    obj_img = np.clip(obj_img + noise * rng.standard_normal(obj_img.shape), 0, 1) * obj_mask
    pos2d, pos3d = measured_positions(hand, person, rng, settings)
    return dict(n=n, hand_img=hand_img.astype(np.float32), hand_mask=hand_mask, obj_img=obj_img.astype(np.float32),
                obj_mask=obj_mask, pos2d=pos2d, pos3d=pos3d, hand_true=hand - _face(person))


def masked_hog(images: np.ndarray, masks: np.ndarray, n_bins: int, n_levels: int) -> np.ndarray:
    """HOG (F, D) of segmented images (F, P, P) with masks; a frame with (almost) no pixels gets zeros."""
    from hog_jax import HOGConfig, hog, hog_dim

    config = HOGConfig(n_bins=n_bins, n_levels=n_levels)
    ok = (masks.sum(axis=(1, 2)) >= 4) & (images.reshape(len(images), -1).max(axis=1) > 0)
    out = np.zeros((len(images), hog_dim(config)), np.float32)
    if ok.any():
        out[ok] = np.asarray(hog(images[ok], config, mask=masks[ok]))
    return out


def _cache_path(settings: OACSettings):
    """Keyed by every setting, this generator's source and the hand model's source and postures, so a
    change to the simulation never reuses stale renders."""
    import inspect

    import sim.human_grasps
    import sim.human_hand

    code = hashlib.sha1("".join(inspect.getsource(m) for m in (sys.modules[__name__], sim.human_hand,
                                                               sim.human_grasps)).encode()).hexdigest()
    key = json.dumps({"version": _VERSION, "code": code, **dataclasses.asdict(settings)}, sort_keys=True)
    digest = hashlib.sha1(key.encode()).hexdigest()[:16]
    return cache_dir("oac") / f"oac_{digest}.npz"


def generate(settings: OACSettings = OACSettings(), cache: bool = True, progress=None) -> OACData:
    """Simulate the OAC data set: every class x person x repetition (N = 3 * persons * repetitions).

    Deterministic from `settings.seed`; cached under `cache_dir("oac")` keyed by every setting.
    `progress`: optional wrapper of an iterable (e.g. `experiments.config.progress`) for a progress bar.
    """
    if not isinstance(settings, OACSettings):
        raise ValueError(f"settings: expected an OACSettings, got {type(settings).__name__}")
    path = _cache_path(settings)
    if cache and path.exists():
        with np.load(path) as z:
            return OACData(**{k: z[k] for k in OACData._fields})
    rng = np.random.default_rng(settings.seed)
    persons = draw_persons(rng, settings.n_persons)
    jobs = [(c, p) for p in range(settings.n_persons) for c in range(N_CLASSES)]
    recs, meta = [], []
    for c, p in (progress(jobs, desc="rendering OAC recordings") if progress else jobs):
        views = _Views(c, persons[p], settings.image_px)
        for r in range(settings.n_repetitions):
            sub = np.random.default_rng([settings.seed, c, p, r])
            recs.append(record(views, c, persons[p], sub, settings))
            meta.append((c, p, r))
        views.close()
    lengths = np.array([r["n"] for r in recs])
    hand_hog = masked_hog(np.concatenate([r["hand_img"] for r in recs]), np.concatenate([r["hand_mask"] for r in recs]),
                          settings.n_bins, settings.hand_levels)
    obj_hog = masked_hog(np.concatenate([r["obj_img"] for r in recs]), np.concatenate([r["obj_mask"] for r in recs]),
                         settings.n_bins, settings.object_levels)
    starts = np.concatenate([[0], np.cumsum(lengths)])
    n, t_max = len(recs), int(lengths.max())

    def pad(rows):
        out = np.zeros((n, t_max) + rows[0].shape[1:], np.float32)
        for i, row in enumerate(rows):
            out[i, : len(row)] = row
        return out

    meta = np.array(meta)
    data = OACData(
        action=meta[:, 0], object=meta[:, 0].copy(), person=meta[:, 1], repetition=meta[:, 2], lengths=lengths,
        pos2d=pad([r["pos2d"] for r in recs]), pos3d=pad([r["pos3d"] for r in recs]),
        hand_hog=pad([hand_hog[starts[i]:starts[i + 1]] for i in range(n)]),
        object_hog=pad([obj_hog[starts[i]:starts[i + 1]] for i in range(n)]),
        hand_true=pad([r["hand_true"] for r in recs]),
    )
    if cache:
        write_npz(path, **data._asdict())
    return data


def recording_images(settings: OACSettings, cls: int, person: int, repetition: int) -> dict:
    """Re-render one recording of `generate(settings)` (same seeds) and return its images and masks:
    hand_img / hand_mask (T, P, P), obj_img / obj_mask (T, S, S), pos2d (T, 2), pos3d (T, 3), n."""
    cls = check_int(cls, "cls", min_value=0, max_value=N_CLASSES - 1)
    person = check_int(person, "person", min_value=0, max_value=settings.n_persons - 1)
    repetition = check_int(repetition, "repetition", min_value=0, max_value=settings.n_repetitions - 1)
    persons = draw_persons(np.random.default_rng(settings.seed), settings.n_persons)
    views = _Views(cls, persons[person], settings.image_px)
    try:
        return record(views, cls, persons[person], np.random.default_rng([settings.seed, cls, person, repetition]),
                      settings)
    finally:
        views.close()
