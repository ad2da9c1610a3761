"""The grasp stage's closer view of the hand: a narrow-field (foveal) camera at the left camera's centre,
turned towards the tracked hand and rendered at the grasp moment only.

Body and hand live at different scales: in a 320 x 240 view of the whole person the hand is about 20
pixels across (10 at 160 x 120), too few for GRASP's HOG of a 64-pixel crop. A foveated head (a wide
pair for the body, a narrow camera that follows the tracked hand) sees the hand at a pixel size set by
the fovea's field of view alone, whatever the wide cameras' resolution, and renders only S x S pixels
where a high-resolution wide frame would render the whole scene at the hand's resolution. The fovea
is aimed with what the loop knows: the tracked hand's pixel in the left view and the left camera's
matrix (its centre and rotation); it turns by the smallest rotation that brings its optical axis onto
that pixel's ray, so that its image is the left view's, magnified, up to perspective. The hand's 3-D
position is not needed: the fovea's field of view is fixed.

Shapes: S the fovea's side (px).
"""
from __future__ import annotations

import re

import numpy as np

from experiments.data import video
from experiments.imitation.demonstrations import Demo, demo_track
from experiments.imitation.pipeline import Actors
from lfd_common import check_int, check_real, matrix_to_quat
from sim.scenes import PersonScene, ScenePose, StereoRig


def camera_of(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(K (3, 3), rotation (3, 3) camera -> world (columns: image x right, image y down, optical axis),
    centre (3,) world) of a finite camera matrix P (3, 4) = K R^T [I | -c]. ValueError naming `P`."""
    P = np.asarray(P, np.float64)
    if P.shape != (3, 4) or not np.isfinite(P).all():
        raise ValueError(f"P: expected a finite (3, 4) camera matrix, got shape {P.shape}")
    centre = -np.linalg.solve(P[:, :3], P[:, 3])
    q, r = np.linalg.qr(np.linalg.inv(P[:, :3]))  # inv(K R^T) = R inv(K): orthogonal times upper triangular
    signs = np.sign(np.diag(r))
    rot, k_inv = q * signs, signs[:, None] * r
    K = np.linalg.inv(k_inv)
    return K / K[2, 2], rot, centre


def fovea_rig(P_left: np.ndarray, hand_rc, size: int, fov_deg: float) -> StereoRig:
    """The foveal camera aimed at the tracked hand (module docstring) as the left camera of a
    `sim.scenes.StereoRig` (its right camera is not used).

    Args:
        P_left: (3, 4) the left camera's matrix.
        hand_rc: (2,) the tracked hand (row, column) in the left view.
        size: S, the fovea's side (px, 8 to 1024).
        fov_deg: its field of view across the side (degrees, in (0, 89]).

    Returns:
        The rig: the left camera's centre, the rotation whose optical axis is the tracked pixel's ray,
        S x S pixels, focal (S / 2) / tan(fov / 2).

    Raises:
        ValueError: naming the argument.
    """
    size = check_int(size, "size", min_value=8, max_value=1024)
    fov = check_real(fov_deg, "fov_deg", min_value=0.0, max_value=89.0, exclusive_min=True)
    rc = np.asarray(hand_rc, np.float64)
    if rc.shape != (2,) or not np.isfinite(rc).all():
        raise ValueError(f"hand_rc: expected a finite (row, column), got {hand_rc!r}")
    K, rot, centre = camera_of(P_left)
    ray = np.linalg.solve(K, [rc[1], rc[0], 1.0])
    ray /= np.linalg.norm(ray)
    axis = np.cross([0.0, 0.0, 1.0], ray)  # the smallest turn of the optical axis onto the ray (camera frame)
    s, c = np.linalg.norm(axis), ray[2]
    turn = np.eye(3)
    if s > 1e-12:
        k = axis / s
        kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        turn = np.eye(3) + s * kx + (1 - c) * kx @ kx
    focal = size / 2 / np.tan(np.radians(fov) / 2)
    return StereoRig(centre=tuple(centre), rotation=tuple(map(tuple, rot @ turn)), width=size, height=size,
                     focal_px=float(focal))


def _with_buffer(xml: str, size: int) -> str:
    """The scene's MJCF with an offscreen buffer of at least size x size."""
    width = int(re.search(r'offwidth="(\d+)"', xml).group(1))
    if width >= size:
        return xml
    return re.sub(r'offwidth="\d+" offheight="\d+"', f'offwidth="{size}" offheight="{size}"', xml, count=1)


class Fovea:
    """The foveal camera of the demonstrations of `settings` (their lighting and camera noise):
    `view(demo, frame, P_left, hand_rc)` renders it aimed at the tracked hand at that frame of the
    demonstration. One person's scene is compiled at a time, when first needed; close it (or use `with`).

    Args:
        settings: the recordings' `experiments.data.video.VideoSettings`.
        size: S, the fovea's side (px, 8 to 1024).
        fov_deg: its field of view (degrees).
    """

    def __init__(self, settings: video.VideoSettings, size: int, fov_deg: float):
        self.settings, self.actors = settings, Actors(settings)
        self.size = check_int(size, "size", min_value=8, max_value=1024)
        self.fov_deg = check_real(fov_deg, "fov_deg", min_value=0.0, max_value=89.0, exclusive_min=True)
        self.person, self.scene, self.demo, self.track = None, None, None, None

    def _scene(self, demo: Demo) -> PersonScene:
        if self.person != demo.person:
            self.close()
            who = self.actors(demo)
            # the renderers take their size from the rig; `view` aims the camera
            rig = fovea_rig(who.rig.projection_matrices()[0], ((who.rig.height - 1) / 2, (who.rig.width - 1) / 2),
                            self.size, self.fov_deg)
            self.scene, self.person = PersonScene(_with_buffer(who.xml, self.size), rig), demo.person
        return self.scene

    def movement(self, demo: Demo):
        """The demonstration's kinematics (`demonstrations.demo_track`; the last one's kept)."""
        if self.demo is not demo:
            self.demo, self.track = demo, demo_track(self.actors(demo), demo, self.settings)
        return self.track

    def pose(self, demo: Demo, frame: int) -> PersonScene:
        """The scene of the demonstration's person, posed and lit as at `frame` of its movement."""
        scene, track = self._scene(demo), self.movement(demo)
        frame = check_int(frame, "frame", min_value=0, max_value=len(track.light) - 1)
        scene.set_lighting(float(track.light[frame]))
        scene.set_pose(ScenePose(*(f[frame] for f in track.pose)))
        return scene

    def hand_rc(self, demo: Demo, frame: int, P_left: np.ndarray) -> np.ndarray:
        """The hand's centre of volume at `frame` (the renderer's truth) projected by `P_left`: (row,
        col) (2,)."""
        x = np.asarray(P_left, np.float64) @ np.append(self.pose(demo, frame).centres()[0], 1.0)
        return x[1::-1] / x[2]

    def view(self, demo: Demo, frame: int, P_left: np.ndarray, hand_rc,
             noise: bool = True) -> tuple[np.ndarray, np.ndarray, StereoRig]:
        """The fovea at `frame` of `demo` aimed at `hand_rc` (row, column) of the left view of camera
        `P_left`.

        Returns:
            (RGB (S, S, 3) uint8 with the settings' camera noise unless `noise` is False, parts (S, S)
            uint8 (`sim.scenes.PART_NAMES`: ground truth, for tests), the fovea's rig).

        Raises:
            ValueError: naming the argument.
        """
        rig = fovea_rig(P_left, hand_rc, self.size, self.fov_deg)
        model = self._scene(demo).model
        cam = model.camera("left").id
        model.cam_pos[cam] = rig.centre
        # MuJoCo's camera: image y up, looking along -z
        model.cam_quat[cam] = matrix_to_quat(np.asarray(rig.rotation) * np.array([1.0, -1.0, -1.0]))
        model.cam_fovy[cam] = np.degrees(2 * np.arctan(self.size / (2 * rig.focal_px)))
        rgb, parts = self.pose(demo, frame).render()  # posing runs the kinematics: the camera's frame follows
        image = rgb[0]
        if noise and self.settings.pixel_noise:
            rng = np.random.default_rng([self.settings.seed, 51, demo.seed, frame])  # a stream of the fovea's own
            image = np.clip(np.rint(image + self.settings.pixel_noise * rng.standard_normal(image.shape)), 0,
                            255).astype(np.uint8)
        return image, parts[0], rig

    def close(self) -> None:
        """Free the open scene's GL contexts."""
        if self.scene is not None:
            self.scene.close()
        self.person, self.scene = None, None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


__all__ = ["Fovea", "camera_of", "fovea_rig"]
