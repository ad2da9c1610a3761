"""The six human reference grasps (Cutkosky 1, 2, 4, 9, 10, 12 of GRASP and MAP), as data, with their
scene and their hand-object contacts.

* `GRASP_POSTURES: dict[int, GraspPosture]`: per grasp class, `joints_deg` (20,) in `JOINT_NAMES`
  order, `object_pos` (3,) metres and `object_quat` (4,) (w, x, y, z): the pose of the object
  (`GRASP_OBJECTS[grasp]`) in the hand frame of the human hand (origin at the wrist, +x to the
  fingers, +y to the thumb, palm facing -z). Tuned for `DEFAULT_SHAPE`.
* `posture(grasp, stage=1.0)` -> (20,) degrees: `stage` 0 is the relaxed hand
  (`NEUTRAL_POSTURE_DEG`), 1 the grasp, linear in between (reach-to-grasp snapshots, GRASP §VII).
* `hand_pose_in_world(grasp)` -> (pos (3,), quat (4,)): where the hand is in the scene's world frame,
  which is the object's frame: the object stands upright (its z axis up) at the origin.
* `grasp_scene_xml(grasp, shape=DEFAULT_SHAPE, options=GraspSceneOptions(), max_image_size=640)` ->
  MJCF string: the hand (root fixed; its 20 joints are the model's qpos, set them with
  `scene_qpos(posture_deg)`) + the object (black by default, GRASP §III-B; body "object", geom
  "object") + a fixed camera named "view" (`sim.grasping.GraspRenderer` moves it).
  `GraspSceneOptions.object_offset` shifts the object in the hand frame (metres), e.g. away from the
  palm while reaching.
* Rendering (camera pose, images of the hand with or without the object) is in `sim.grasping`:
  `render_grasp(grasp, camera_pos, look_at=None, rotation=None, width, height, shape, posture_deg,
  options)` -> (H, W, 3) uint8.
* `scene_qpos(posture_deg)` -> (20,) radians for the scene's qpos (the hand's 20 joints only).
* `grasp_contacts(grasp, shape=DEFAULT_SHAPE, posture_deg=None)` -> `GraspContacts(parts (C,) geom
  names of the hand, positions (C, 3) and normals (C, 3) in the object frame (normals point out of the
  object, towards the hand), penetration (C,) metres, >= 0)`, from native MuJoCo `mj_forward`.
* `grasp_plausibility(grasp, shape=DEFAULT_SHAPE)` -> dict: `n_contacts`, `n_parts`,
  `fingers_in_contact` (tuple of finger names, "palm" for palm geoms), `max_penetration_mm`.

How the postures were made: starting from a hand-set pre-shape per grasp, each finger was closed along
its own joint direction by bisection until its deepest point entered the object by about 1 mm
(`mj_geomDistance`), and object positions were set so that the palm touches in the power grasps. The
numbers below are the result, rounded to 0.1 degree; `grasp_plausibility` reports how well they hold.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from lfd_common import as_array, check_int, check_real, matrix_to_quat, quat_to_matrix
from sim._src.grasp_objects import GRASP_OBJECTS, check_grasp_class
from sim._src.human_hand import (DEFAULT_SHAPE, FINGERS, N_JOINTS, NEUTRAL_POSTURE_DEG, HandShape,
    hand_body_xml, hand_defaults_xml, posture_qpos)
from sim._src.scenes import offscreen_visual_xml

__all__ = ["GRASP_POSTURES", "GraspContacts", "GraspPosture", "GraspSceneOptions", "grasp_contacts",
           "grasp_plausibility", "grasp_scene_xml", "hand_pose_in_world", "posture", "scene_qpos"]


@dataclass(frozen=True)
class GraspPosture:
    """A human reference grasp: the hand's joint angles and the object's pose in the hand frame.

    Attributes:
        joints_deg: (20,) joint angles in degrees, `JOINT_NAMES` order.
        object_pos: (3,) the object's position in the hand frame (m).
        object_quat: (4,) its orientation in the hand frame (w, x, y, z).
    """

    joints_deg: tuple[float, ...]
    object_pos: tuple[float, float, float]
    object_quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)


_AXIS_Y = (0.70710678, -0.70710678, 0.0, 0.0)  # object z axis along the hand's +y (across the palm)

# fmt: off
GRASP_POSTURES: dict[int, GraspPosture] = {
    # thumb: cmc_abd cmc_flex mcp ip | index, middle, ring, little: mcp_abd mcp pip dip
    1: GraspPosture((-8.0, -5.4, -2.8, -2.8,  0.0, 42.4, 53.1, 31.8,  0.0, 46.2, 57.7, 34.6,  0.0, 43.7, 54.7, 32.8,  0.0, 35.5, 44.4, 26.6),
                    (0.0700, 0.0000, -0.0542), _AXIS_Y),
    2: GraspPosture((-10.9, -0.1, -0.9, -0.9,  0.0, 44.3, 66.4, 44.3,  0.0, 52.0, 77.9, 52.0,  0.0, 45.5, 68.3, 45.5,  0.0, 32.0, 48.0, 32.0),
                    (0.0850, 0.0000, -0.0291), _AXIS_Y),
    4: GraspPosture((-20.0, 12.2, -3.2, -3.2,  0.0, 48.8, 58.6, 39.0,  0.0, 53.4, 64.1, 42.7,  0.0, 50.8, 60.9, 40.6,  0.0, 40.5, 48.6, 32.4),
                    (0.0750, 0.0000, -0.0442), _AXIS_Y),
    9: GraspPosture((-3.5, 22.2, 14.8, 14.8,  0.0, 37.6, 42.3, 23.5,  0.0, 38.3, 51.0, 31.9,  0.0, 65.0, 85.0, 50.0,  0.0, 70.0, 85.0, 50.0),
                    (0.1069, 0.0310, -0.0755)),
    10: GraspPosture((14.2, 10.6, 7.1, 7.1,  -10.0, 49.2, 49.2, 24.6,  0.0, 49.5, 49.5, 24.7,  10.0, 46.4, 46.4, 23.2,  20.0, 40.2, 40.2, 20.1),
                     (0.0700, 0.0000, -0.0573)),
    12: GraspPosture((21.3, 11.6, 7.7, 7.7,  -12.0, 35.9, 26.9, 9.0,  0.0, 36.7, 27.5, 9.2,  10.0, 34.2, 25.7, 8.6,  22.0, 33.4, 25.1, 8.4),
                     (0.0900, 0.0000, -0.0700)),
}
# fmt: on


def posture(grasp: int, stage: float = 1.0) -> np.ndarray:
    """The hand's joint angles on the way from the relaxed hand to a grasp (GRASP §VII snapshots).

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).
        stage: 0 is the relaxed hand (`NEUTRAL_POSTURE_DEG`), 1 the grasp's posture, linear between.

    Returns:
        (20,) joint angles in degrees, `JOINT_NAMES` order.

    Raises:
        ValueError: an unknown grasp class or a stage outside [0, 1].
    """
    grasp = check_grasp_class(grasp)
    stage = check_real(stage, "stage", min_value=0.0, max_value=1.0)
    target = np.asarray(GRASP_POSTURES[grasp].joints_deg)
    return NEUTRAL_POSTURE_DEG + stage * (target - NEUTRAL_POSTURE_DEG)


def hand_pose_in_world(grasp: int) -> tuple[np.ndarray, np.ndarray]:
    """Where the hand of a reference grasp is, in the frame of the object it holds.

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).

    Returns:
        (pos (3,), quat (4,) w x y z) of the hand frame in the scene's world frame, which is the
            object's frame: the object upright at the origin.

    Raises:
        ValueError: an unknown grasp class.
    """
    g = GRASP_POSTURES[check_grasp_class(grasp)]
    q = np.asarray(g.object_quat, float)
    r_ho = quat_to_matrix(q / np.linalg.norm(q))   # object axes in the hand frame
    r_wh = r_ho.T                                  # hand axes in the world (= object) frame
    pos = -r_wh @ np.asarray(g.object_pos)
    return pos, matrix_to_quat(r_wh)


def _rgb(value, name: str, n: int) -> str:
    arr = as_array(value, name, shape=(n,), min_value=0.0, max_value=1.0)
    return " ".join(f"{v:.4f}" for v in arr)


@dataclass(frozen=True)
class GraspSceneOptions:
    """How the scene of a hand in a grasp (`grasp_scene_xml`) looks, and what the hand holds.

    Fields are checked when the object is made. Change one with `dataclasses.replace(options, ...)`.

    Attributes:
        with_object: put the grasp's object in the hand.
        object_offset: (3,) moves the object in the hand frame (m, each in [-1, 1]), e.g. away from
            the palm while reaching.
        object_rgba: the object's colour (RGBA in [0, 1]; black, as in GRASP §III-B).
        background_rgb: the flat background colour (RGB in [0, 1]; the renderer's clear colour is
            black, so a skybox of this colour is added).
        ambient: the headlight's ambient level, in [0, 1].
        diffuse: the key light's diffuse level, in [0, 1] (the headlight's is half of it).
        light_dir: (3,) the key light's direction (world), not zero.
        fovy_deg: the camera's vertical field of view (degrees, in [1, 120]).
        object_joint: give the object a free joint (7 more qpos after the hand's 20, at rest where it
            is placed), so that collision detection also reports the palm's contacts (MuJoCo skips
            pairs of bodies that are both fixed to the world, as the hand's root and a jointless
            object are).

    Raises:
        ValueError: a field out of its range or of the wrong shape, naming the field.
    """

    with_object: bool = True
    object_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    object_rgba: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    background_rgb: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ambient: float = 0.35
    diffuse: float = 0.65
    light_dir: tuple[float, float, float] = (0.3, -0.4, -1.0)
    fovy_deg: float = 30.0
    object_joint: bool = False

    def __post_init__(self):
        for name in ("with_object", "object_joint"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"{name}: expected a bool, got {getattr(self, name)!r}")
            object.__setattr__(self, name, bool(getattr(self, name)))
        ldir = as_array(self.light_dir, "light_dir", shape=(3,))
        if np.linalg.norm(ldir) < 1e-9:
            raise ValueError("light_dir: must not be the zero vector")
        checked = dict(
            object_offset=as_array(self.object_offset, "object_offset", shape=(3,), min_value=-1.0, max_value=1.0),
            object_rgba=as_array(self.object_rgba, "object_rgba", shape=(4,), min_value=0.0, max_value=1.0),
            background_rgb=as_array(self.background_rgb, "background_rgb", shape=(3,), min_value=0.0,
                                    max_value=1.0),
            light_dir=ldir)
        for name, value in checked.items():
            object.__setattr__(self, name, tuple(float(v) for v in value))
        object.__setattr__(self, "ambient", check_real(self.ambient, "ambient", min_value=0.0, max_value=1.0))
        object.__setattr__(self, "diffuse", check_real(self.diffuse, "diffuse", min_value=0.0, max_value=1.0))
        object.__setattr__(self, "fovy_deg", check_real(self.fovy_deg, "fovy_deg", min_value=1.0, max_value=120.0))


def grasp_scene_xml(grasp: int, shape: HandShape = DEFAULT_SHAPE, options: GraspSceneOptions = GraspSceneOptions(),
                    max_image_size: int = 640) -> str:
    """MJCF of the human hand in a reference grasp, holding its object, with a camera named "view".

    The hand's joints start at zero: set `data.qpos[:] = scene_qpos(posture_deg)` before `mj_forward`.
    The world frame is the object's (see the module docstring).

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).
        shape: the hand's anthropometry.
        options: the object, its offset and colour, the background, the lights and the camera's field
            of view (`GraspSceneOptions`).
        max_image_size: the offscreen buffer's side (px, in [16, 4096]), at least the largest image
            rendered.

    Returns:
        The MJCF text.

    Raises:
        ValueError: an unknown grasp class, `options` not a `GraspSceneOptions`, or a bad
            `max_image_size`.
    """
    grasp = check_grasp_class(grasp)
    if not isinstance(options, GraspSceneOptions):
        raise ValueError(f"options: expected a GraspSceneOptions, got {type(options).__name__}")
    offset = np.asarray(options.object_offset)
    ambient, diffuse, fovy = options.ambient, options.diffuse, options.fovy_deg
    ldir = np.asarray(options.light_dir)
    size = check_int(max_image_size, "max_image_size", min_value=16, max_value=4096)
    hand_pos, hand_quat = hand_pose_in_world(grasp)
    r_wh = quat_to_matrix(hand_quat)
    obj_pos = r_wh @ offset
    obj = GRASP_OBJECTS[grasp]
    obj_xml = ""
    if options.with_object:
        geom = obj.geom_xml(rgba=_rgb(options.object_rgba, "object_rgba", 4),
                            extra='contype="0" conaffinity="1" material="matte"')
        joint = "<freejoint/>" if options.object_joint else ""
        obj_xml = f'<body name="object" pos="{obj_pos[0]:.5f} {obj_pos[1]:.5f} {obj_pos[2]:.5f}">{joint}{geom}</body>'
    bg = _rgb(options.background_rgb, "background_rgb", 3)
    return f"""<mujoco model="grasp_{grasp}">
  <compiler angle="radian"/>
  <option gravity="0 0 0"/>
  {offscreen_visual_xml(size, ambient, 0.5 * diffuse)}
  <asset>
    <texture name="sky" type="skybox" builtin="flat" rgb1="{bg}" rgb2="{bg}" width="8" height="8"/>
    <material name="matte" specular="0" shininess="0"/>
  </asset>
  <default>{hand_defaults_xml(shape)}</default>
  <worldbody>
    <light name="key" directional="true" castshadow="false" dir="{ldir[0]:.4f} {ldir[1]:.4f} {ldir[2]:.4f}" diffuse="{diffuse:.3f} {diffuse:.3f} {diffuse:.3f}" specular="0.1 0.1 0.1"/>
    <camera name="view" pos="0 0 1" fovy="{fovy:.3f}"/>
    {hand_body_xml(shape, pos=hand_pos, quat=hand_quat)}
    {obj_xml}
  </worldbody>
</mujoco>"""


def scene_qpos(posture_deg: ArrayLike) -> np.ndarray:
    """The grasp scene's qpos for a hand posture.

    Args:
        posture_deg: (20,) joint angles in degrees, `JOINT_NAMES` order.

    Returns:
        (20,) the scene's qpos in radians (the hand's 20 joints only).

    Raises:
        ValueError: a posture of the wrong shape or outside the joint ranges.
    """
    return posture_qpos(posture_deg)


class GraspContacts(NamedTuple):
    """The C contacts between the hand and the object of a grasp.

    Attributes:
        parts: (C,) the hand geoms' names ("palm_index", "thumb_distal", ...).
        positions: (C, 3) contact positions in the object frame.
        normals: (C, 3) contact normals in the object frame, out of the object (towards the hand).
        penetration: (C,) penetration depths (m, >= 0).
    """

    parts: tuple[str, ...]
    positions: np.ndarray
    normals: np.ndarray
    penetration: np.ndarray


def _posture_or_default(grasp: int, posture_deg) -> np.ndarray:
    if posture_deg is None:
        return np.asarray(GRASP_POSTURES[grasp].joints_deg, float)
    return as_array(posture_deg, "posture_deg", shape=(N_JOINTS,))


def grasp_contacts(grasp: int, shape: HandShape = DEFAULT_SHAPE, posture_deg: ArrayLike | None = None) -> GraspContacts:
    """The contacts between the hand and a grasp's object, from MuJoCo's collision detection.

    These are the human contacts of MAP §IV-A's virtual-finger comparison (the paper tags them by hand).

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).
        shape: the hand's anthropometry.
        posture_deg: (20,) joint angles in degrees; None: the grasp's own (`GRASP_POSTURES`).

    Returns:
        The `GraspContacts` of native MuJoCo's `mj_forward`.

    Raises:
        ValueError: an unknown grasp class or a posture of the wrong shape or outside the ranges.
    """
    grasp = check_grasp_class(grasp)
    model = mujoco.MjModel.from_xml_string(grasp_scene_xml(grasp, shape, GraspSceneOptions(object_joint=True)))
    data = mujoco.MjData(model)
    data.qpos[:N_JOINTS] = scene_qpos(_posture_or_default(grasp, posture_deg))
    mujoco.mj_forward(model, data)
    obj_body = model.body("object").id
    r_wo, p_wo = data.xmat[obj_body].reshape(3, 3), data.xpos[obj_body]
    parts, pos, nrm, pen = [], [], [], []
    for c in data.contact[: data.ncon]:
        b1, b2 = model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]
        if obj_body not in (b1, b2):
            continue
        hand_geom, sign = (c.geom1, -1.0) if b2 == obj_body else (c.geom2, 1.0)  # normal: geom1 -> geom2
        parts.append(model.geom(hand_geom).name)
        pos.append(r_wo.T @ (c.pos - p_wo))
        nrm.append(r_wo.T @ (sign * c.frame[:3]))
        pen.append(max(-c.dist, 0.0))
    return GraspContacts(tuple(parts), np.reshape(pos, (-1, 3)), np.reshape(nrm, (-1, 3)), np.asarray(pen, float))


def _finger_of(part: str) -> str:
    return next((f for f in FINGERS if part.startswith(f)), "palm")


def grasp_plausibility(grasp: int, shape: HandShape = DEFAULT_SHAPE) -> dict:
    """How well a reference grasp holds: its contacts with the object, summarised.

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).
        shape: the hand's anthropometry.

    Returns:
        A dict: `n_contacts`, `n_parts` (hand geoms in contact), `fingers_in_contact` (a tuple of
            finger names, "palm" for palm geoms) and `max_penetration_mm`.

    Raises:
        ValueError: an unknown grasp class.
    """
    c = grasp_contacts(grasp, shape)
    fingers = tuple(f for f in FINGERS + ("palm",) if f in {_finger_of(p) for p in c.parts})
    return {"n_contacts": len(c.parts), "n_parts": len(set(c.parts)), "fingers_in_contact": fingers,
            "max_penetration_mm": float(1e3 * c.penetration.max()) if len(c.parts) else 0.0}

