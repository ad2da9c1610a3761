"""Offscreen views of the human hand in a grasp, and the rendered view database of GRASP §III-B.

* `look_at_rotation(camera_pos (3,), look_at (3,), up=(0, 0, 1))` -> (3, 3) world-from-camera
  rotation in MuJoCo's camera convention (columns: x right, y up, z backwards; the camera looks
  along -z).
* `sphere_camera(azimuth_deg, elevation_deg, distance, roll_deg=0, target=(0, 0, 0))` ->
  (camera_pos (3,), rotation (3, 3)): a camera on a sphere around `target` looking at it.
* `view_euler(azimuth_deg, elevation_deg, roll_deg=0)` -> (3,) radians: the orientation recorded for a
  view, as hog_jax's Z-Y'-X'' Euler angles (phi, theta, psi) = (azimuth, -elevation, roll) of the
  camera's viewing frame in the hand-object frame; `hog_jax.euler_to_quat` gives the quaternion.
* `view_grid(n_azimuth, n_elevation)` -> (azimuth_deg (V,), elevation_deg (V,)) over the half-sphere.
* `render_views(grasp, azimuth_deg (V,), elevation_deg (V,), options=ViewOptions(), ...)` ->
  (images (V, S, S) float32, masks (V, S, S) bool), cropped and centred; `ViewOptions` holds the
  camera distance (0.55 m), the render size (128 px), the crop size (64 px), the crop margin and the
  hand shape.
* `GraspRenderer(grasp, width=128, height=128, shape=DEFAULT_SHAPE, posture_deg=None,
  options=GraspSceneOptions())`: one MuJoCo model and GL context; `.render(camera_pos, rotation)` ->
  (H, W, 3) uint8, `.render_with_mask(...)` -> (rgb, hand mask (H, W) bool, object mask (H, W) bool),
  `.set_posture(posture_deg)`, `.set_object_offset(offset_world)`, `.set_object_rgba(rgba)`,
  `.set_lighting(ambient, diffuse, light_dir)` change the scene in place (no recompilation).
  `options` (`sim.hands.GraspSceneOptions`: with_object, object_offset, object_rgba, background_rgb,
  ambient, diffuse, light_dir, fovy_deg) goes to `sim.hands.grasp_scene_xml`. Use as a context
  manager (or call `.close()`).
* `render_grasp(grasp, camera_pos, look_at=None, rotation=None, width=128, height=128,
  shape=DEFAULT_SHAPE, posture_deg=None, options=GraspSceneOptions())` -> (H, W, 3) uint8: one image;
  give `look_at` (3,) or a `rotation` (3, 3) (or a 4x4 pose whose translation is ignored in favour of
  `camera_pos`).
* `hand_center(grasp, shape=DEFAULT_SHAPE)` -> (3,) world position of the palm centre (a look-at point).
* `crop_hand(rgb (H, W, 3), mask (H, W), out_size=64, margin=0.1)` -> (out_size, out_size) float32
  grayscale crop, background 0 (square box around the mask grown by `margin`, like `hog_jax.segment`).
* `view_database(grasps, n_azimuth=60, n_elevation=15, options=ViewOptions(), ...)` ->
  `ViewDatabase(images (N, S, S), labels (N,), euler (N, 3), quat (N, 4), azimuth_deg (N,),
  elevation_deg (N,))`, cached under `lfd_common.cache_dir("grasp_views")` keyed by every setting.

World frame = the grasped object's frame (object upright at the origin, see `sim.hands.hand_pose_in_world`).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import cv2
import mujoco
import numpy as np
from numpy.typing import ArrayLike

from hog_jax import euler_to_quat
from lfd_common import Cache, as_array, check_int, check_real
from sim._src.grasp_objects import GRASP_CLASSES, check_grasp_class
from sim._src.human_grasps import (GRASP_POSTURES, GraspSceneOptions, grasp_scene_xml, hand_pose_in_world,
    scene_qpos)
from sim._src.human_hand import DEFAULT_SHAPE, HandShape
from sim._src.render import setup_rendering

_VERSION = 1  # bump for what the source does not show (a MuJoCo upgrade that changes the images)
# The grasp postures and the hand model are in `sim`; `hog_jax` gives `euler_to_quat`.
_VIEWS = Cache("grasp_views", packages=("sim", "hog_jax", "lfd_common"), version=_VERSION)


def look_at_rotation(camera_pos: ArrayLike, look_at: ArrayLike, up: ArrayLike = (0.0, 0.0, 1.0)) -> np.ndarray:
    """The rotation of a camera at `camera_pos` looking at `look_at`, in MuJoCo's camera convention.

    Args:
        camera_pos: (3,) the camera's position (world).
        look_at: (3,) the point it looks at; must differ from `camera_pos`.
        up: (3,) the world's up direction (any right vector is used when looking straight along it).

    Returns:
        (3, 3) world-from-camera rotation: columns x right, y up, z backwards (the camera looks along
            -z).

    Raises:
        ValueError: an argument of the wrong shape, or `look_at` equal to `camera_pos`.
    """
    p = as_array(camera_pos, "camera_pos", shape=(3,))
    t = as_array(look_at, "look_at", shape=(3,))
    u = as_array(up, "up", shape=(3,))
    back = p - t
    if np.linalg.norm(back) < 1e-9:
        raise ValueError("look_at: must differ from camera_pos")
    z = back / np.linalg.norm(back)
    x = np.cross(u, z)
    if np.linalg.norm(x) < 1e-9:  # looking straight along `up`: any right vector will do
        x = np.cross([1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], 1)


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def view_euler(azimuth_deg: ArrayLike, elevation_deg: ArrayLike, roll_deg: ArrayLike = 0.0) -> np.ndarray:
    """The orientation recorded for a view: the hand orientation that GRASP §V regresses.

    hog_jax's Z-Y'-X'' Euler angles (phi, theta, psi) = (azimuth, -elevation, roll) of the viewing
    frame V = Rz(phi) Ry(theta) Rx(psi), whose x axis points from the hand to the camera and whose z
    axis is the image's up (see `sphere_camera`). theta stays in [-pi/2, pi/2] as
    `hog_jax.quat_to_euler` returns it.

    Args:
        azimuth_deg: (...) camera azimuths (degrees).
        elevation_deg: (...) camera elevations (degrees).
        roll_deg: (...) camera rolls about the optical axis (degrees).

    Returns:
        (..., 3) radians, the arguments broadcast together.
    """
    a, e, r = np.broadcast_arrays(azimuth_deg, elevation_deg, roll_deg)
    return np.radians(np.stack([a, -np.asarray(e, float), r], -1).astype(float))


def sphere_camera(azimuth_deg: float, elevation_deg: float, distance: float, roll_deg: float = 0.0,
                  target: ArrayLike = (0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """A camera on a sphere around `target`, looking at it (the views of GRASP §III-B).

    Args:
        azimuth_deg: the camera's azimuth about the vertical (degrees).
        elevation_deg: its elevation (degrees, in [-90, 90]).
        distance: the sphere's radius (m, > 0).
        roll_deg: the camera's roll about its optical axis (degrees).
        target: (3,) the sphere's centre (world).

    Returns:
        (camera_pos (3,), world-from-camera rotation (3, 3)).

    Raises:
        ValueError: an argument out of range, naming it.
    """
    az, el, roll = np.radians([check_real(azimuth_deg, "azimuth_deg"),
                               check_real(elevation_deg, "elevation_deg", min_value=-90.0, max_value=90.0),
                               check_real(roll_deg, "roll_deg")])
    distance = check_real(distance, "distance", min_value=0.0, exclusive_min=True)
    t = as_array(target, "target", shape=(3,))
    view = _rz(az) @ _ry(-el) @ _rx(roll)     # x: target -> camera, z: up (rolled)
    pos = t + distance * view[:, 0]
    # camera: z backwards = +view x, y up = view z, x right = y cross z
    rot = np.stack([np.cross(view[:, 2], view[:, 0]), view[:, 2], view[:, 0]], 1)
    return pos, rot


def _rotation_arg(rotation) -> np.ndarray:
    r = as_array(rotation, "rotation")
    if r.shape == (4, 4):
        r = r[:3, :3]
    if r.shape != (3, 3):
        raise ValueError(f"rotation: expected a (3, 3) rotation or a (4, 4) pose, got shape {r.shape}")
    if not np.allclose(r.T @ r, np.eye(3), atol=1e-5) or np.linalg.det(r) < 0:
        raise ValueError("rotation: expected a proper rotation matrix (orthonormal, det +1)")
    return r


class GraspRenderer:
    """One hand-in-grasp scene and an offscreen renderer for many camera poses (GRASP §III-B).

    Changing the posture, the object's offset or colour, or the lighting works in place, without
    compiling the model again. Use it as a context manager, or call `close`.

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).
        width: the image width (px, in [8, 2048]).
        height: the image height (px, in [8, 2048]).
        shape: the hand's anthropometry.
        posture_deg: (20,) joint angles in degrees; None: the grasp's own (`GRASP_POSTURES`).
        options: the scene (`sim.hands.GraspSceneOptions`: the object, the background, the lights).

    Raises:
        ValueError: an unknown grasp class or a bad size, posture or `options`.
        RuntimeError: the OpenGL backend cannot be loaded (`setup_rendering`).
    """

    def __init__(self, grasp: int, width: int = 128, height: int = 128, shape: HandShape = DEFAULT_SHAPE,
                 posture_deg: ArrayLike | None = None, options: GraspSceneOptions = GraspSceneOptions()):
        grasp = check_grasp_class(grasp)
        self.width = check_int(width, "width", min_value=8, max_value=2048)
        self.height = check_int(height, "height", min_value=8, max_value=2048)
        xml = grasp_scene_xml(grasp, shape, options, max_image_size=max(self.width, self.height, 64))
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        joints = GRASP_POSTURES[grasp].joints_deg if posture_deg is None else posture_deg
        self.data.qpos[:] = scene_qpos(joints)
        mujoco.mj_forward(self.model, self.data)
        self._cam = self.model.camera("view").id
        names = [self.model.body(b).name for b in range(self.model.nbody)]
        self._object_body = names.index("object") if "object" in names else -1
        self._object_pos0 = self.model.body_pos[self._object_body].copy() if options.with_object else None
        self._hand_geom = (self.model.geom_bodyid > 0) & (self.model.geom_bodyid != self._object_body)
        self._object_geom = self.model.geom_bodyid == self._object_body
        setup_rendering()
        self._renderer = mujoco.Renderer(self.model, height=self.height, width=self.width)

    def set_posture(self, posture_deg: ArrayLike) -> None:
        """Put the hand's 20 joints at a posture.

        Args:
            posture_deg: (20,) joint angles in degrees, checked against the human ranges.

        Raises:
            ValueError: a posture of the wrong shape or outside the ranges.
        """
        self.data.qpos[:] = scene_qpos(posture_deg)

    def set_object_offset(self, offset_world: ArrayLike) -> None:
        """Move the object away from its grasped pose.

        Args:
            offset_world: (3,) metres, in the world frame (the object's frame).

        Raises:
            ValueError: the renderer has no object, or the offset has the wrong shape.
        """
        if self._object_pos0 is None:
            raise ValueError("offset_world: this renderer has no object (with_object=False)")
        self.model.body_pos[self._object_body] = self._object_pos0 + as_array(offset_world, "offset_world", shape=(3,))

    def set_object_rgba(self, rgba: ArrayLike) -> None:
        """Colour the object.

        Args:
            rgba: (4,) RGBA in [0, 1].

        Raises:
            ValueError: a colour of the wrong shape or out of range.
        """
        self.model.geom_rgba[self._object_geom] = as_array(rgba, "rgba", shape=(4,), min_value=0.0, max_value=1.0)

    def set_lighting(self, ambient: float, diffuse: float, light_dir: ArrayLike) -> None:
        """Set the lights.

        Args:
            ambient: the headlight's ambient level, in [0, 1].
            diffuse: the key light's diffuse level, in [0, 1] (the headlight's is half of it).
            light_dir: (3,) the key light's direction (world frame), not zero.

        Raises:
            ValueError: a level out of range or a zero direction.
        """
        a = check_real(ambient, "ambient", min_value=0.0, max_value=1.0)
        dif = check_real(diffuse, "diffuse", min_value=0.0, max_value=1.0)
        ldir = as_array(light_dir, "light_dir", shape=(3,))
        if np.linalg.norm(ldir) < 1e-9:
            raise ValueError("light_dir: must not be the zero vector")
        self.model.vis.headlight.ambient[:] = a
        self.model.vis.headlight.diffuse[:] = 0.5 * dif
        self.model.light_diffuse[0] = dif
        self.model.light_dir[0] = ldir / np.linalg.norm(ldir)

    def _place(self, camera_pos, rotation):
        pos = as_array(camera_pos, "camera_pos", shape=(3,))
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, _rotation_arg(rotation).ravel())
        self.model.cam_pos[self._cam] = pos
        self.model.cam_quat[self._cam] = quat
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def render(self, camera_pos: ArrayLike, rotation: ArrayLike) -> np.ndarray:
        """Render the scene from one camera pose.

        Args:
            camera_pos: (3,) the camera's position (world).
            rotation: (3, 3) world-from-camera rotation (`look_at_rotation`), or a (4, 4) pose whose
                translation is ignored.

        Returns:
            (H, W, 3) uint8 image.

        Raises:
            ValueError: a position of the wrong shape or a matrix that is not a rotation.
        """
        self._place(camera_pos, rotation)
        self._renderer.update_scene(self.data, camera=self._cam)
        return self._renderer.render().copy()

    def render_with_mask(self, camera_pos: ArrayLike,
                         rotation: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Render the scene from one camera pose, with the hand's and the object's pixels.

        Args:
            camera_pos: (3,) the camera's position (world).
            rotation: (3, 3) world-from-camera rotation, or a (4, 4) pose.

        Returns:
            (rgb (H, W, 3) uint8, hand mask (H, W) bool, object mask (H, W) bool), the masks from the
                renderer's segmentation pass.

        Raises:
            ValueError: a position of the wrong shape or a matrix that is not a rotation.
        """
        rgb = self.render(camera_pos, rotation)
        self._renderer.enable_segmentation_rendering()
        try:
            self._renderer.update_scene(self.data, camera=self._cam)
            seg = self._renderer.render()
        finally:
            self._renderer.disable_segmentation_rendering()
        is_geom = seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
        ids = np.clip(seg[..., 0], 0, self.model.ngeom - 1)
        return rgb, is_geom & self._hand_geom[ids], is_geom & self._object_geom[ids]

    def close(self) -> None:
        """Free the GL context."""
        self._renderer.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def hand_center(grasp: int, shape: HandShape = DEFAULT_SHAPE) -> np.ndarray:
    """The palm centre of the hand in a grasp: a natural point for cameras to look at.

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).
        shape: the hand's anthropometry.

    Returns:
        (3,) its world position (the object's frame).

    Raises:
        ValueError: an unknown grasp class.
    """
    pos, quat = hand_pose_in_world(grasp)
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, quat)
    return pos + r.reshape(3, 3) @ np.array([0.55 * shape.palm_length, 0.0, -0.5 * shape.palm_thickness])


def render_grasp(grasp: int, camera_pos: ArrayLike, look_at: ArrayLike | None = None,
                 rotation: ArrayLike | None = None, width: int = 128, height: int = 128,
                 shape: HandShape = DEFAULT_SHAPE, posture_deg: ArrayLike | None = None,
                 options: GraspSceneOptions = GraspSceneOptions()) -> np.ndarray:
    """One image of the hand in a grasp, holding its object unless `options.with_object` is False.

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).
        camera_pos: (3,) the camera's position (world).
        look_at: (3,) the point the camera looks at (world up = +z); give this or `rotation`.
        rotation: (3, 3) world-from-camera rotation or a (4, 4) pose; give this or `look_at`.
        width: the image width (px).
        height: the image height (px).
        shape: the hand's anthropometry.
        posture_deg: (20,) joint angles in degrees; None: the grasp's own.
        options: the scene (`sim.hands.GraspSceneOptions`).

    Returns:
        (H, W, 3) uint8 image.

    Raises:
        ValueError: neither or both of `look_at` and `rotation`, or other bad input, naming it.
    """
    if (look_at is None) == (rotation is None):
        raise ValueError("look_at: give exactly one of look_at and rotation")
    rot = _rotation_arg(rotation) if rotation is not None else look_at_rotation(camera_pos, look_at)
    with GraspRenderer(grasp, width, height, shape, posture_deg, options) as r:
        return r.render(camera_pos, rot)


def crop_hand(rgb: ArrayLike, mask: ArrayLike, out_size: int = 64,
              margin: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """A square crop around the hand, grey, 0 outside the hand (GRASP §III's hand image).

    The box is the mask's bounding box grown by `margin` of its larger side, as `hog_jax.segment`
    crops; an empty mask gives zeros.

    Args:
        rgb: (H, W, 3) image, values in [0, 255].
        mask: (H, W) bool: the hand's pixels.
        out_size: S, the crop's side (px, >= 4).
        margin: how much the box grows, as a fraction of its larger side (>= 0).

    Returns:
        (image (S, S) float32 grayscale in [0, 1], mask (S, S) bool).

    Raises:
        ValueError: an argument of the wrong shape or out of range, naming it.
    """
    rgb = as_array(rgb, "rgb", ndim=3, dtype=np.float32, min_value=0.0, max_value=255.0)
    mask = as_array(mask, "mask", shape=rgb.shape[:2], dtype=bool)
    size = check_int(out_size, "out_size", min_value=4)
    margin = check_real(margin, "margin", min_value=0.0)
    if not mask.any():
        return np.zeros((size, size), np.float32), np.zeros((size, size), bool)
    gray = (rgb @ np.array([0.299, 0.587, 0.114], np.float32)) / 255.0 * mask
    rows, cols = np.flatnonzero(mask.any(1)), np.flatnonzero(mask.any(0))
    top, bottom, left, right = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    side = int(np.ceil(max(bottom - top, right - left) * (1.0 + 2.0 * margin)))
    top, left = top + (bottom - top) // 2 - side // 2, left + (right - left) // 2 - side // 2
    pad = side
    g = np.pad(gray, pad)[top + pad: top + pad + side, left + pad: left + pad + side]
    m = np.pad(mask.astype(np.float32), pad)[top + pad: top + pad + side, left + pad: left + pad + side]
    img = cv2.resize(g, (size, size), interpolation=cv2.INTER_AREA)
    msk = cv2.resize(m, (size, size), interpolation=cv2.INTER_AREA) > 0.5
    return (img * msk).astype(np.float32), msk


class ViewDatabase(NamedTuple):
    """The rendered view database of GRASP §III-B: N hand crops with their grasp and view labels.

    Attributes:
        images: (N, S, S) float32 grayscale hand crops (background 0).
        masks: (N, S, S) bool hand masks.
        labels: (N,) int32 grasp class *indices* into the database's grasps (`GRASP_CLASSES` for the
            default database).
        euler: (N, 3) radians (azimuth, -elevation, roll), as `view_euler`.
        quat: (N, 4) (w, x, y, z) of the same rotation.
        azimuth_deg: (N,) camera azimuths.
        elevation_deg: (N,) camera elevations.
    """

    images: np.ndarray
    masks: np.ndarray
    labels: np.ndarray
    euler: np.ndarray
    quat: np.ndarray
    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray


def view_grid(n_azimuth: int, n_elevation: int) -> tuple[np.ndarray, np.ndarray]:
    """Camera directions over the upper half-sphere (GRASP §III-B's database views).

    Azimuths at k 360 / n_azimuth, elevations at the centres of n_elevation equal bands of [0, 90);
    60 x 15 gives GRASP's 6-degree steps.

    Args:
        n_azimuth: azimuths (in [1, 3600]).
        n_elevation: elevations (in [1, 900]).

    Returns:
        (azimuth_deg (V,), elevation_deg (V,)), V = n_azimuth * n_elevation.

    Raises:
        ValueError: a count out of range, naming it.
    """
    n_az = check_int(n_azimuth, "n_azimuth", min_value=1, max_value=3600)
    n_el = check_int(n_elevation, "n_elevation", min_value=1, max_value=900)
    az = np.arange(n_az) * 360.0 / n_az
    el = (np.arange(n_el) + 0.5) * 90.0 / n_el
    a, e = np.meshgrid(az, el, indexing="ij")
    return a.ravel(), e.ravel()


def _hand_mask_from_rgb(rgb: np.ndarray) -> np.ndarray:
    """Database renders have a black background and a black matte object: the hand is what is lit."""
    return rgb.max(-1) > 6


@dataclass(frozen=True)
class ViewOptions:
    """How the database views are rendered and cropped (`render_views`, `view_database`).

    Fields are checked when the object is made. Change one with `dataclasses.replace(options, ...)`.

    Attributes:
        distance: the cameras' distance from the palm centre (m, > 0).
        render_size: the rendered image's side (px, in [8, 2048]).
        out_size: the crop's side S (px, >= 4).
        margin: how much the crop box grows, as a fraction of its larger side (>= 0; `crop_hand`).
        shape: the hand's anthropometry (the database hand by default).

    Raises:
        ValueError: a field out of its range or of the wrong type, naming the field.
    """

    distance: float = 0.55
    render_size: int = 128
    out_size: int = 64
    margin: float = 0.1
    shape: HandShape = DEFAULT_SHAPE

    def __post_init__(self):
        object.__setattr__(self, "distance", check_real(self.distance, "distance", min_value=0.0,
                                                        exclusive_min=True))
        object.__setattr__(self, "render_size", check_int(self.render_size, "render_size", min_value=8,
                                                          max_value=2048))
        object.__setattr__(self, "out_size", check_int(self.out_size, "out_size", min_value=4))
        object.__setattr__(self, "margin", check_real(self.margin, "margin", min_value=0.0))
        if not isinstance(self.shape, HandShape):
            raise ValueError(f"shape: expected a HandShape, got {type(self.shape).__name__}")


def render_views(grasp: int, azimuth_deg: ArrayLike, elevation_deg: ArrayLike, options: ViewOptions = ViewOptions(),
                 progress: Callable | None = None,
                 scene: GraspSceneOptions = GraspSceneOptions()) -> tuple[np.ndarray, np.ndarray]:
    """Cropped views of a grasp from cameras on a sphere around the palm centre (GRASP §III-B).

    With the default `scene` the background and the object are black, so the hand is what is lit,
    and the hand mask is found from that.

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).
        azimuth_deg: (V,) camera azimuths (degrees).
        elevation_deg: (V,) camera elevations (degrees, in [-90, 90]).
        options: the camera distance, render size, crop size and margin, and the hand shape
            (`ViewOptions`).
        progress: `progress(iterable, total)` wraps the loop over views (e.g. a progress bar).
        scene: the scene (`sim.hands.GraspSceneOptions`).

    Returns:
        (images (V, S, S) float32, masks (V, S, S) bool).

    Raises:
        ValueError: bad input, naming the argument.
    """
    if not isinstance(options, ViewOptions):
        raise ValueError(f"options: expected a ViewOptions, got {type(options).__name__}")
    distance, render_size, out_size, margin, shape = (options.distance, options.render_size, options.out_size,
                                                      options.margin, options.shape)
    az = as_array(azimuth_deg, "azimuth_deg", ndim=1)
    el = as_array(elevation_deg, "elevation_deg", shape=az.shape, min_value=-90.0, max_value=90.0)
    centre = hand_center(grasp, shape)
    images = np.zeros((az.size, out_size, out_size), np.float32)
    masks = np.zeros((az.size, out_size, out_size), bool)
    loop = range(az.size) if progress is None else progress(range(az.size), az.size)
    with GraspRenderer(grasp, render_size, render_size, shape, options=scene) as renderer:
        for v in loop:
            rgb = renderer.render(*sphere_camera(az[v], el[v], distance, target=centre))
            images[v], masks[v] = crop_hand(rgb, _hand_mask_from_rgb(rgb), out_size, margin)
    return images, masks


def view_database(grasps: tuple[int, ...] = GRASP_CLASSES, n_azimuth: int = 60, n_elevation: int = 15,
                  options: ViewOptions = ViewOptions(), cache: bool = True,
                  progress: Callable | None = None) -> ViewDatabase:
    """The rendered view database of GRASP §III-B: every grasp seen from the half-sphere, cropped and centred.

    Cached as .npz under `cache_dir("grasp_views")`, keyed by every setting, the hand shape and the
    source of `sim`, `hog_jax` and `lfd_common` (which hold the grasp postures and the renderer).

    Args:
        grasps: the grasp classes (`GRASP_CLASSES`), not empty; `labels` index into them.
        n_azimuth: azimuths of the `view_grid`.
        n_elevation: elevations of the `view_grid`.
        options: the camera distance, render size, crop size and margin, and the hand shape
            (`ViewOptions`).
        cache: read and write the cache.
        progress: `progress(iterable, total, desc)` wraps the per-grasp loops.

    Returns:
        The `ViewDatabase`, grasps in the order given, each with V = n_azimuth * n_elevation views.

    Raises:
        ValueError: an unknown or empty list of grasp classes, or another bad argument, naming it.
    """
    if not isinstance(options, ViewOptions):
        raise ValueError(f"options: expected a ViewOptions, got {type(options).__name__}")
    distance, render_size, out_size, margin, shape = (options.distance, options.render_size, options.out_size,
                                                      options.margin, options.shape)
    grasps = tuple(check_grasp_class(g, "grasps") for g in grasps)
    if not grasps:
        raise ValueError("grasps: must not be empty")

    def build() -> ViewDatabase:
        az, el = view_grid(n_azimuth, n_elevation)
        parts = []
        for g in grasps:
            wrap = None if progress is None else (lambda it, total, g=g: progress(it, total, f"render grasp {g}"))
            parts.append(render_views(g, az, el, options, progress=wrap))
        euler = np.tile(view_euler(az, el), (len(grasps), 1))
        return ViewDatabase(images=np.concatenate([p[0] for p in parts]),
                            masks=np.concatenate([p[1] for p in parts]),
                            labels=np.repeat(np.arange(len(grasps), dtype=np.int32), az.size),
                            euler=euler.astype(np.float32), quat=np.asarray(euler_to_quat(euler.astype(np.float32))),
                            azimuth_deg=np.tile(az, len(grasps)), elevation_deg=np.tile(el, len(grasps)))

    return _VIEWS.get(build, enabled=cache, grasps=grasps, n_azimuth=n_azimuth, n_elevation=n_elevation,
                      distance=distance, render_size=render_size, out_size=out_size, margin=margin, shape=shape)
