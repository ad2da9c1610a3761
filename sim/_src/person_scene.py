"""The table-top demonstration scene (LFD §III, LEVELSET §3): a seated person (`PersonLook`)
at a table with the objects they handle and some distractors, a textured wall behind, a rectified
stereo camera pair in front; MJCF written here, rendered with MuJoCo's offscreen renderer, with a
ground-truth part per pixel from MuJoCo's segmentation rendering.

World frame: z up, the table top at `TableSpec.top_z`, the person behind the table facing -y (the
cameras), x the cameras' right. Everything that moves is a mocap body; a frame is a `ScenePose`.

Parts (the per-pixel ground truth of `PersonScene.render`, `PART_NAMES`): 0 background (wall, table,
floor, distractors), 1 person (clothing, hair), 2 hand (the right hand, `sim.hands.hand_body_xml`), 3 other
skin (the left hand, bare forearms), 4 face (head skin, eyes, mouth, neck), 5 + k object k.
`PART_LABELS` maps them to the segmentation classes 0 background, 1 person, 2 hand skin (both hands
and bare forearms), 3 face skin, 4 + k object k.

Cameras (`StereoRig`): pinhole, square pixels, principal point at the image centre; pixel (column i,
row j) has its centre at (i, j) (so the principal point is ((W - 1) / 2, (H - 1) / 2)); the right
camera sits `baseline_m` along the left camera's image x axis with the same orientation (a
rectified pair: equal rows, disparity f B / Z).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from lfd_common import as_array, check_int, check_real, matrix_to_quat
from sim._src.human_hand import hand_defaults_xml
from sim._src.person_body import PART_PREFIXES, PersonLook, look_assets_xml, person_body_xml, segment_pose
from sim._src.render import setup_rendering
from sim._src.scenes import offscreen_visual_xml

__all__ = ["PART_LABELS", "PART_NAMES", "PersonScene", "ScenePose", "StereoRig", "TableSpec", "geom_parts",
           "person_scene_xml"]

MAX_OBJECTS = 8
PART_NAMES: tuple[str, ...] = PART_PREFIXES + tuple(f"object{k}" for k in range(MAX_OBJECTS))
PART_LABELS: np.ndarray = np.array([0, 1, 2, 2, 3] + [4 + k for k in range(MAX_OBJECTS)], np.uint8)
_OBJ_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)


@dataclass(frozen=True)
class StereoRig:
    """A rectified stereo pair of pinhole cameras (checked when the object is made).

    The right camera sits `baseline_m` along the left camera's image x axis with the same orientation.

    Attributes:
        centre: (3,) the left camera's centre (world).
        rotation: (3, 3) its rotation in the world (columns: image x right, image y down, optical axis).
        baseline_m: the baseline (m, > 0).
        width: the image width (px, in [8, 4096]).
        height: the image height (px, in [8, 4096]).
        focal_px: the focal length (px, > 0).

    Raises:
        ValueError: a field out of its range, or a rotation that is not a proper rotation.
    """

    centre: tuple[float, float, float]
    rotation: tuple[tuple[float, float, float], ...]
    baseline_m: float = 0.12
    width: int = 320
    height: int = 240
    focal_px: float = 262.5

    def __post_init__(self):
        c = as_array(self.centre, "centre", shape=(3,))
        r = as_array(self.rotation, "rotation", shape=(3, 3))
        if not (np.allclose(r.T @ r, np.eye(3), atol=1e-6) and np.linalg.det(r) > 0):
            raise ValueError("rotation: expected a proper rotation matrix (orthonormal, det +1)")
        object.__setattr__(self, "centre", tuple(float(v) for v in c))
        object.__setattr__(self, "rotation", tuple(tuple(float(v) for v in row) for row in r))
        check_real(self.baseline_m, "baseline_m", min_value=0.0, exclusive_min=True)
        check_int(self.width, "width", min_value=8, max_value=4096)
        check_int(self.height, "height", min_value=8, max_value=4096)
        check_real(self.focal_px, "focal_px", min_value=0.0, exclusive_min=True)

    def intrinsics(self) -> np.ndarray:
        """The cameras' intrinsic matrix.

        Returns:
            The (3, 3) matrix K, for square pixels and the principal point at the image centre
                ((W - 1) / 2, (H - 1) / 2).
        """
        return np.array([[self.focal_px, 0.0, (self.width - 1) / 2], [0.0, self.focal_px, (self.height - 1) / 2],
                         [0.0, 0.0, 1.0]])

    def centres(self) -> np.ndarray:
        """The two cameras' centres.

        Returns:
            (2, 3) world points: left, right.
        """
        c, r = np.array(self.centre), np.array(self.rotation)
        return np.stack([c, c + self.baseline_m * r[:, 0]])

    def projection_matrices(self) -> np.ndarray:
        """The two cameras' projection matrices.

        Returns:
            P (2, 3, 4) of the left and right camera: homogeneous world point -> homogeneous pixel.
        """
        rot_wc = np.array(self.rotation).T
        return np.stack([self.intrinsics() @ np.hstack([rot_wc, -rot_wc @ c[:, None]]) for c in self.centres()])

    def to_camera(self, points: ArrayLike) -> np.ndarray:
        """World points in the left camera's frame.

        Args:
            points: (..., 3) world points.

        Returns:
            (..., 3) the points in the left camera's frame (x right, y down, z forward).
        """
        return (np.asarray(points, float) - np.array(self.centre)) @ np.array(self.rotation)

    def camera_xml(self) -> str:
        """The pair as MJCF cameras.

        Returns:
            The `<camera>` elements "left" and "right" (MuJoCo's convention: x right, y up).
        """
        r = np.array(self.rotation)
        fovy = np.degrees(2 * np.arctan(self.height / (2 * self.focal_px)))
        xy = " ".join(f"{v:.6f}" for v in np.concatenate([r[:, 0], -r[:, 1]]))  # MuJoCo: x right, y up
        return "".join(f'<camera name="{name}" pos="{" ".join(f"{v:.6f}" for v in c)}" xyaxes="{xy}" fovy="{fovy:.6f}"/>'
                       for name, c in zip(("left", "right"), self.centres()))


@dataclass(frozen=True)
class TableSpec:
    """The table (a solid box standing on the floor) and the wall behind the person, in metres.

    Attributes:
        top_z: the table top's height.
        near_y: the edge at the person.
        far_y: the edge at the cameras.
        half_width: half the table's width (along x).
        wall_y: where the wall stands.
        table_rgb: the table's colour (RGB in [0, 1]).
        wall_rgb: the wall's colour.
    """

    top_z: float = 0.75
    near_y: float = -0.15        # the edge at the person
    far_y: float = -0.85         # the edge at the cameras
    half_width: float = 0.9
    wall_y: float = 0.9
    table_rgb: tuple[float, float, float] = (0.55, 0.38, 0.22)
    wall_rgb: tuple[float, float, float] = (0.72, 0.74, 0.70)


class ScenePose(NamedTuple):
    """Poses of the scene's moving parts, world frame, metres; one frame, or T frames with a leading T
    axis on every field.

    Attributes:
        trunk_pos: (3,) the face centre.
        trunk_rot: (3, 3) the trunk's rotation.
        r_shoulder: (3,) the right shoulder's joint centre.
        r_elbow: (3,) the right elbow's.
        r_wrist: (3,) the right wrist's.
        r_hand_rot: (3, 3) the right hand's frame.
        fingers: (20,) the right hand's joint angles (radians).
        l_shoulder: (3,) the left shoulder's joint centre.
        l_elbow: (3,) the left elbow's.
        l_wrist: (3,) the left wrist's.
        l_hand_rot: (3, 3) the left hand's frame.
        object_pos: (K, 3) each object's body position.
        object_rot: (K, 3, 3) each object's body rotation.
    """

    trunk_pos: np.ndarray
    trunk_rot: np.ndarray
    r_shoulder: np.ndarray
    r_elbow: np.ndarray
    r_wrist: np.ndarray
    r_hand_rot: np.ndarray
    fingers: np.ndarray
    l_shoulder: np.ndarray
    l_elbow: np.ndarray
    l_wrist: np.ndarray
    l_hand_rot: np.ndarray
    object_pos: np.ndarray
    object_rot: np.ndarray


def _rgb(c) -> str:
    return " ".join(f"{float(x):.4f}" for x in c)


def person_scene_xml(look: PersonLook, rig: StereoRig, objects: Sequence[str], distractors: Sequence[str] = (),
                     table: TableSpec = TableSpec(), shadows: bool = True) -> str:
    """MJCF of the demonstration scene: the person, the table, the objects and the stereo cameras.

    Args:
        look: the person.
        rig: the stereo pair (cameras "left" and "right").
        objects: the geoms (MJCF text) of each object in its body frame (mocap bodies "object0", ...);
            1 to 8 of them.
        distractors: geoms (MJCF text, world coordinates) that never move.
        table: the table and the wall.
        shadows: the key light casts shadows.

    Returns:
        The MJCF text.

    Raises:
        ValueError: no or too many objects, or a `rig` that is not a `StereoRig`.
    """
    if not 1 <= len(objects) <= MAX_OBJECTS:
        raise ValueError(f"objects: expected 1 to {MAX_OBJECTS} objects, got {len(objects)}")
    if not isinstance(rig, StereoRig):
        raise ValueError(f"rig: expected a StereoRig, got {type(rig).__name__}")
    t = table
    depth = (t.near_y - t.far_y) / 2
    tab, wall = _rgb(t.table_rgb), _rgb(t.wall_rgb)
    wall2 = _rgb(np.clip(np.array(t.wall_rgb) * 0.88, 0, 1))
    dark = _rgb(np.array(t.table_rgb) * 0.75)
    objs = "".join(f'<body name="object{k}" mocap="true">{g}</body>' for k, g in enumerate(objects))
    dist = "".join(f'<body name="distractor{i}">{g}</body>' for i, g in enumerate(distractors))
    return f"""<mujoco model="person_scene">
  <compiler angle="radian"/>
  <option gravity="0 0 0"/>
  {offscreen_visual_xml(max(rig.width, rig.height), ambient=0.3, diffuse=0.25, offsamples=0)}
  <visual><quality shadowsize="{2048 if shadows else 0}" numslices="16" numstacks="8" numquads="1"/>
    <map znear="0.02" zfar="20"/></visual>
  <asset>
    <texture name="wall" type="2d" builtin="checker" rgb1="{wall}" rgb2="{wall2}" mark="random" random="0.02"
             markrgb="{_rgb(np.array(t.wall_rgb) * 0.6)}" width="256" height="256"/>
    <material name="wall" texture="wall" texrepeat="6 3" specular="0"/>
    <texture name="wood" type="2d" builtin="flat" rgb1="{tab}" rgb2="{tab}" mark="random" random="0.05"
             markrgb="{dark}" width="256" height="256"/>
    <material name="wood" texture="wood" texrepeat="3 3" specular="0.1"/>
    <texture name="floor" type="2d" builtin="checker" rgb1="0.35 0.33 0.3" rgb2="0.28 0.27 0.25" width="64" height="64"/>
    <material name="floor" texture="floor" texrepeat="8 8"/>
    {look_assets_xml(look)}
  </asset>
  <default>{hand_defaults_xml(look.hand)}</default>
  <worldbody>
    <light name="key" directional="true" castshadow="{'true' if shadows else 'false'}" dir="0.35 0.6 -1"
           diffuse="0.55 0.55 0.52" specular="0.15 0.15 0.15"/>
    <light name="fill" directional="true" castshadow="false" dir="-0.5 0.3 -0.4" diffuse="0.25 0.25 0.27"
           specular="0 0 0"/>
    {rig.camera_xml()}
    <geom name="background.floor" type="plane" size="4 4 0.1" material="floor" contype="0" conaffinity="0"/>
    <geom name="background.wall" type="plane" size="4 2 0.1" pos="0 {t.wall_y:.4f} 2" zaxis="0 -1 0" material="wall"
          contype="0" conaffinity="0"/>
    <geom name="background.table" type="box" pos="0 {(t.near_y + t.far_y) / 2:.4f} {t.top_z / 2:.4f}"
          size="{t.half_width:.4f} {depth:.4f} {t.top_z / 2:.4f}" material="wood" contype="0" conaffinity="0"/>
    {dist}
    {objs}
    {person_body_xml(look)}
  </worldbody>
</mujoco>"""


def geom_parts(model: mujoco.MjModel) -> np.ndarray:
    """Part id (ngeom,) of every geom (`PART_NAMES`): geoms inside the body "r_hand" are the hand,
    inside "object<k>" object k; others by their name's prefix ("person.chest"), else background."""
    parent = model.body_parentid
    body_part = np.full(model.nbody, -1, int)
    for b in range(1, model.nbody):  # parents come first
        name = model.body(b).name
        if name == "r_hand":
            body_part[b] = PART_NAMES.index("hand")
        elif name.startswith("object") and name[6:].isdigit():
            body_part[b] = PART_NAMES.index(name)
        else:
            body_part[b] = body_part[parent[b]]
    parts = np.zeros(model.ngeom, int)
    for g in range(model.ngeom):
        prefix = model.geom(g).name.split(".")[0]
        own = body_part[model.geom_bodyid[g]]
        parts[g] = own if own >= 0 else (PART_PREFIXES.index(prefix) if prefix in PART_PREFIXES else 0)
    return parts


class PersonScene:
    """A compiled demonstration scene with one offscreen renderer per view, reused across frames.

    `set_pose(pose)` places a frame, `set_lighting(scale)` scales every light, `render()` returns RGB
    (2, H, W, 3) uint8 and parts (2, H, W) uint8 of the left and right view; `centres()` the right
    hand's centre of volume (3,) and each object's (K, 3), world metres. Close it (or use `with`).

    Args:
        xml: the scene's MJCF (`person_scene_xml`).
        rig: the stereo pair it was written with.

    Raises:
        RuntimeError: the OpenGL backend cannot be loaded (`setup_rendering`).
    """

    def __init__(self, xml: str, rig: StereoRig):
        setup_rendering()
        self.rig = rig
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        self.n_objects = sum(self.model.body(b).name.startswith("object") for b in range(self.model.nbody))
        self._parts = np.append(geom_parts(self.model), 0).astype(np.uint8)  # segmentation id -1 -> background
        self._mocap = {self.model.body(b).name: int(self.model.body_mocapid[b])
                       for b in range(self.model.nbody) if self.model.body_mocapid[b] >= 0}
        self._hand_body = self.model.body("r_hand").id
        self._object_bodies = [self.model.body(f"object{k}").id for k in range(self.n_objects)]
        self._light = (self.model.light_diffuse.copy(), self.model.light_specular.copy(),
                       np.array(self.model.vis.headlight.ambient), np.array(self.model.vis.headlight.diffuse))
        self._renderers = []
        for _ in range(2):
            self._renderers.append(mujoco.Renderer(self.model, rig.height, rig.width))

    def _place(self, name: str, pos: np.ndarray, quat: np.ndarray):
        i = self._mocap[name]
        self.data.mocap_pos[i] = pos
        self.data.mocap_quat[i] = quat

    def set_pose(self, pose: ScenePose) -> None:
        """Place one frame and update the kinematics.

        Args:
            pose: one frame (a `ScenePose` without the T axis).
        """
        self._place("trunk", pose.trunk_pos, matrix_to_quat(np.asarray(pose.trunk_rot, float)))
        for side in ("r", "l"):
            shoulder, elbow, wrist = (getattr(pose, f"{side}_{j}") for j in ("shoulder", "elbow", "wrist"))
            self._place(f"{side}_upper", *segment_pose(shoulder, elbow))
            self._place(f"{side}_fore", *segment_pose(elbow, wrist))
        self._place("r_hand_mount", pose.r_wrist, matrix_to_quat(np.asarray(pose.r_hand_rot, float)))
        self._place("l_hand", pose.l_wrist, matrix_to_quat(np.asarray(pose.l_hand_rot, float)))
        quats = matrix_to_quat(np.asarray(pose.object_rot, float))
        for k in range(self.n_objects):
            self._place(f"object{k}", pose.object_pos[k], quats[k])
        self.data.qpos[:] = pose.fingers
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def set_lighting(self, scale: float) -> None:
        """Scale every light (and the headlight), each clipped to [0, 1].

        Args:
            scale: the factor on every light's modelled intensity.
        """
        diffuse, specular, ambient, head = self._light
        self.model.light_diffuse[:] = np.clip(diffuse * scale, 0, 1)
        self.model.light_specular[:] = np.clip(specular * scale, 0, 1)
        self.model.vis.headlight.ambient[:] = np.clip(ambient * scale, 0, 1)
        self.model.vis.headlight.diffuse[:] = np.clip(head * scale, 0, 1)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """The centres of volume (uniform density) of the right hand's and each object's geoms.

        Returns:
            (right hand (3,), objects (K, 3)), world metres.
        """
        return self.data.subtree_com[self._hand_body].copy(), self.data.xipos[self._object_bodies].copy()

    def render(self) -> tuple[np.ndarray, np.ndarray]:
        """Render both views, with the ground-truth part of every pixel.

        Returns:
            (RGB (2, H, W, 3) uint8, parts (2, H, W) uint8 (`PART_NAMES`)) of the left and right view.
        """
        h, w = self.rig.height, self.rig.width
        rgb, parts = np.empty((2, h, w, 3), np.uint8), np.empty((2, h, w), np.uint8)
        for v, (renderer, camera) in enumerate(zip(self._renderers, ("left", "right"))):
            renderer.update_scene(self.data, camera=camera)
            renderer.render(out=rgb[v])
            renderer.enable_segmentation_rendering()
            try:
                seg = renderer.render()
            finally:
                renderer.disable_segmentation_rendering()
            parts[v] = self._parts[np.where(seg[..., 1] == _OBJ_GEOM, seg[..., 0], -1)]
        return rgb, parts

    def close(self) -> None:
        """Free the renderers' GL contexts."""
        for renderer in self._renderers:
            renderer.close()
        self._renderers = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
