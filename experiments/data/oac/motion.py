"""Hand and object trajectories, the stereo camera, measured hand positions."""
from __future__ import annotations

import math

import numpy as np

from hog_jax.video import StereoCamera
from hog_jax.video import project as stereo_project
from hog_jax.video import triangulate as stereo_triangulate
from lfd_common import axis_angle_to_matrix as rotation_about, check_int  # rotation_about(axis (3,), angle (...)) -> (..., 3, 3)
from experiments.data.oac.grips import grip_of
from experiments.data.oac.settings import BASELINE_M, FOCAL_PX, IMAGE_SIZE_PX, N_CLASSES, OACSettings, Person, TABLE_Z_M


# ----------------------------------------------------------------------------------------- geometry
def _frame(z_axis: np.ndarray, x_hint: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) whose columns are x, y, z with z = `z_axis` and x as close to `x_hint` as possible."""
    z = z_axis / np.linalg.norm(z_axis)
    x = x_hint - (x_hint @ z) * z
    x = x / np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def min_jerk(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def _bump(s: np.ndarray) -> np.ndarray:
    """Smooth 0 -> 1 -> 0 over s in [0, 1] (zero with zero slope at both ends)."""
    s = np.clip(s, 0.0, 1.0)
    return np.sin(np.pi * s) ** 2


# World: z up, the person's face centroid above the origin, the person faces -y (the camera).
# x is the camera's right (the person's left); the right hand works on the -x side.
def face_point(person: Person) -> np.ndarray:
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
    face = face_point(person)
    rest = face + person.size * np.array([_REST[cls][0], _REST[cls][1], 0.0])
    rest[2] = TABLE_Z_M + grip_of(cls, person).rest_height_m
    rest += 0.015 * rng.standard_normal(3) * np.array([1, 1, 0])
    target = face + person.size * (_TARGET[cls] + person.target_m[cls] + 0.012 * rng.standard_normal(3))
    if cls == 2:  # the pouring place scales with the person's reach; the face targets do not
        target = rest + person.amplitude * (1.0 + 0.03 * rng.standard_normal()) * (target - rest)
    hold = np.clip(person.hold + 0.04 * rng.standard_normal(), 0.2, 0.6)
    t_in = 0.5 * (1 - hold) * (1.0 + 0.1 * rng.standard_normal())
    t_out = t_in + hold
    go, back = min_jerk(s / t_in), min_jerk((s - t_out) / (1 - t_out))
    phase = np.clip((s - t_in) / hold, 0.0, 1.0)
    path = go - back  # 0 at rest, 1 at the target
    arc = person.arc_m + 0.015 * rng.standard_normal(3)
    transport = 4 * go * (1 - go) - 4 * back * (1 - back)  # bulge out, and back along the mirrored arc
    pos = rest + path[:, None] * (target - rest) + transport[:, None] * arc * person.size * person.amplitude
    roll = person.roll_rad + 0.1 * rng.standard_normal()
    base = _frame(_AXIS[cls], -_PALM[cls])
    base = base @ rotation_about(np.array([0.0, 0.0, 1.0]), roll)
    tilt = person.tilt * (1.0 + 0.1 * rng.standard_normal())
    act = _bump(phase)
    if cls == 0:    # scanning: a slow yaw sweep with the binoculars at the eyes
        sweep = np.deg2rad(10.0) * tilt * np.sin(2 * np.pi * (phase + rng.uniform())) * act
        rots = rotation_about(np.array([0.0, 0.0, 1.0]), sweep) @ base
    elif cls == 1:  # drinking: the cup's top tilts towards the face (+y), about the world x axis
        rots = rotation_about(np.array([1.0, 0.0, 0.0]), -np.deg2rad(65.0) * tilt * act) @ base
    else:           # pouring: the spout side (+x of the part) goes down, about the world y axis
        rots = rotation_about(np.array([0.0, 1.0, 0.0]), np.deg2rad(75.0) * tilt * act) @ base
    # a small wrist tremor on every class
    rots = rotation_about(np.array([0.0, 1.0, 0.0]), np.deg2rad(2.0) * np.sin(2 * np.pi * 1.3 * s + rng.uniform(0, 6))) @ rots
    return pos, rots


def camera_pose(person: Person) -> tuple[np.ndarray, np.ndarray]:
    """Left camera centre (3,) and rotation (3, 3) (columns: image x right, image y down, optical axis)."""
    face = face_point(person)
    centre = face + np.array([0.0, -person.camera_dist_m, -0.05]) + person.camera_m
    look = face + np.array([0.0, -0.2, -0.2])
    fwd = (look - centre) / np.linalg.norm(look - centre)
    right = np.cross(fwd, np.array([0.0, 0.0, 1.0]))
    right /= np.linalg.norm(right)
    down = np.cross(fwd, right)
    return centre, np.stack([right, down, fwd], axis=1)


# The data set's pair: principal point at (W / 2, H / 2), as the recordings were generated.
CAMERA = StereoCamera(FOCAL_PX, BASELINE_M, *IMAGE_SIZE_PX, cx=IMAGE_SIZE_PX[0] / 2, cy=IMAGE_SIZE_PX[1] / 2)


def project(points: np.ndarray, centre: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Pinhole projection of world points (..., 3) to pixels (..., 2) of the camera at `centre`, `rot`
    (640 x 480, f = 525: `CAMERA`'s left view)."""
    return stereo_project(CAMERA, (points - centre) @ rot).left


def triangulate(left_px: np.ndarray, right_px: np.ndarray) -> np.ndarray:
    """Rectified-stereo triangulation: pixels (..., 2) in both images -> points (..., 3) in the left camera frame.

    The simulated centroids carry independent noise, so their disparity may reach 0 or below; the data
    set clamps it at 1 px (a far point) rather than drop the frame, by moving the right pixel."""
    right = np.array(right_px, dtype=float)
    right[..., 0] = np.minimum(right[..., 0], np.asarray(left_px, float)[..., 0] - 1.0)
    return stereo_triangulate(CAMERA, left_px, right).xyz


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
    face = np.broadcast_to(face_point(person), hand.shape)
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
