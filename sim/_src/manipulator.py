"""A Barrett-WAM-like 7-DoF arm carrying a robot hand of MAP §III, at the table of the demonstration
scene (`sim.scenes.TableSpec`), with a few free objects to pick and place; MJCF written here. Inverse
kinematics: `sim.robot.solve_ik`.

The arm (WAM proportions and joint limits): a base on a pedestal whose top is level with the table
top, standing at the table's near edge (where the demonstrator sat, `BASE_POS`) and facing the table
(-y). Shoulder 0.346 m above the base: J1 yaw (base z), J2 pitch, J3 upper-arm twist, meeting in one
point (a spherical shoulder); upper arm 0.55 m along z with the WAM's 0.045 m elbow offset; J4 elbow
(pitch); forearm 0.30 m; J5 forearm twist, J6 wrist pitch, J7 wrist roll meeting in one point (a
spherical wrist); flange 0.06 m beyond it. Zero pose: the arm points straight up. The robot hand
fragment (the one of the grasp scenes, `sim.hands.grasp_model`) sits on the flange with its wrist
stub: the hand frame (origin at the palm surface centre, +z the palm normal) is 0.12 m along the
flange's z, unrotated, so the palm faces away from the wrist. Site "palm_centre" (the hand frame) is
what `sim.robot.solve_ik` places.

Control: one position actuator per arm joint ("arm1" ... "arm7", WAM-like PD gains, force-limited)
then the hand's finger actuators. Every arm and hand body has gravcomp="1" (MuJoCo applies the
negated weight at each body's centre of mass, a passive force outside the actuator limits), so the
position servos only fight what the arm carries and a held pose does not sag.

Collisions: arm and hand touch the table and the objects, objects touch each other and the table,
nothing in the robot touches itself. The table's collision surface is a plane at the top's height (MJX's
JAX implementation has no cylinder-box pair): the visual box below it is not collidable, so an object
pushed past the edge lands on that plane's infinite extension, not the floor.
"""
from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from lfd_common import as_array, check_choice
from sim._src.grasp_objects import GRASP_CLASSES, GRASP_OBJECTS
from sim._src.person_scene import TableSpec
from sim._src.robot_hands import (LS_ITERATIONS, SOLVER_ITERATIONS, TIMESTEP_S, hand_body_xml,
    hand_joint_qpos, hand_spec)

__all__ = ["ARM_JOINTS", "BASE_POS", "HOME_Q", "JOINT_RANGE", "ManipulatorLayout", "manipulator_model",
           "manipulator_qpos", "manipulator_scene_xml"]

SHOULDER_M, UPPER_ARM_M, ELBOW_OFFSET_M, FOREARM_M, WRIST_M = 0.346, 0.55, 0.045, 0.30, 0.06
HAND_MOUNT_M = 0.12   # flange to the palm surface: the hand fragment's wrist stub
ARM_JOINTS: tuple[str, ...] = tuple(f"arm{k}" for k in range(1, 8))
# the WAM's joint limits (rad); J5's range is the WAM's, off-centre about its zero
JOINT_RANGE = np.array([[-2.6, 2.6], [-2.0, 2.0], [-2.8, 2.8], [-0.9, 3.1], [-4.76, 1.24], [-1.6, 1.6],
                        [-3.0, 3.0]])
# WAM-like joint-space PD (libbarrett's default kp), dampings near critical for these link inertias,
# torque limits (N m), armature (reflected rotor inertia, kg m^2); shoulder and elbow large, wrist small
_KP = (900.0, 2500.0, 600.0, 500.0, 50.0, 50.0, 8.0)
_KV = (60.0, 100.0, 30.0, 30.0, 1.5, 1.5, 0.3)
_FORCE = (150.0, 150.0, 80.0, 80.0, 20.0, 20.0, 5.0)
_ARMATURE = (0.1, 0.1, 0.05, 0.05, 0.01, 0.01, 0.005)
BASE_POS = np.array([-0.2, 0.07, 0.75])   # pedestal top, at the near edge of the default table
# the hand above the table in front of the robot, palm down (radians, `ARM_JOINTS` order)
HOME_Q = np.array([0.0, 0.75, 0.0, 1.9, 0.0, 0.5, 0.0])
# default objects (grasp classes of `sim.grasping.GRASP_OBJECTS`) and where they stand (x, y, world): the
# demonstration scene's object slots
DEFAULT_OBJECTS: tuple[int, ...] = (1, 4, 10)
DEFAULT_OBJECT_XY = np.array([[-0.20, -0.42], [0.0, -0.33], [-0.40, -0.26]])
# Contact bits, (contype, conaffinity): robot (2, 0), objects (4, 6), table (8, 6): robot-object,
# robot-table, object-object and object-table pairs collide (iff (ct1 & ca2) | (ct2 & ca1)).
_ROBOT_BITS = 'contype="2" conaffinity="0"'
_OBJECT_BITS = 'contype="4" conaffinity="6"'
_TABLE_BITS = 'contype="8" conaffinity="6"'
_OBJECT_RGBA = ("0.85 0.2 0.2 1", "0.2 0.6 0.85 1", "0.95 0.75 0.2 1", "0.3 0.75 0.35 1")


def _joint(k: int) -> str:
    """Joint k (0-based) with its actuator's armature and limits; the axis is z for the twists (J1, J3,
    J5, J7) and y for the pitches (J2, J4, J6)."""
    axis = "0 0 1" if k % 2 == 0 else "0 1 0"
    lo, hi = JOINT_RANGE[k]
    return (f'<joint name="{ARM_JOINTS[k]}" axis="{axis}" range="{lo:g} {hi:g}" armature="{_ARMATURE[k]:g}" '
            f'damping="{0.05 * _KV[k]:.3g}"/>')


def _link(name: str, pos: str, k: int, geoms: str, inner: str) -> str:
    return f'<body name="{name}" pos="{pos}" gravcomp="1">{_joint(k)}{geoms}{inner}</body>'


def _arm_xml(hand_body: str) -> str:
    """The arm's body tree from the base (at the parent's origin, facing the parent's +x) to the hand."""
    grey, white = 'rgba="0.35 0.35 0.4 1"', 'rgba="0.85 0.85 0.88 1"'
    e, u, f = ELBOW_OFFSET_M, UPPER_ARM_M, FOREARM_M
    flange = (f'<body name="flange" pos="0 0 {WRIST_M:g}" gravcomp="1">'
              f'<geom name="flange" type="cylinder" size="0.04 0.01" pos="0 0 -0.01" {_ROBOT_BITS} {grey} mass="0.1"/>'
              f'<site name="flange" size="0.005"/>'
              f'<body name="hand_mount" pos="0 0 {HAND_MOUNT_M:g}">{hand_body}</body></body>')
    wrist = _link("link5", f"{-e:g} 0 {f:g}", 4, f'<geom name="link5" type="sphere" size="0.045" {_ROBOT_BITS} {grey} mass="0.5"/>',
                  _link("link6", "0 0 0", 5, f'<geom name="link6" type="capsule" fromto="0 -0.04 0 0 0.04 0" size="0.035" {_ROBOT_BITS} {grey} mass="0.5"/>',
                        _link("link7", "0 0 0", 6, f'<geom name="link7" type="cylinder" size="0.035 0.02" pos="0 0 0.03" {_ROBOT_BITS} {grey} mass="0.1"/>',
                              flange)))
    forearm = _link("link4", f"{e:g} 0 {u:g}", 3,
                    f'<geom name="elbow" type="capsule" fromto="0 -0.045 0 0 0.045 0" size="0.05" {_ROBOT_BITS} {grey} mass="0.4"/>'
                    f'<geom name="forearm" type="capsule" fromto="{-e:g} 0 0.06 {-e:g} 0 {f - 0.06:g}" size="0.04" {_ROBOT_BITS} {white} mass="0.8"/>',
                    wrist)
    upper = _link("link3", "0 0 0", 2,
                  f'<geom name="upper_arm" type="capsule" fromto="0 0 0.12 0 0 {u - 0.06:g}" size="0.05" {_ROBOT_BITS} {white} mass="2.2"/>',
                  forearm)
    shoulder = _link("link2", "0 0 0", 1,
                     f'<geom name="shoulder" type="capsule" fromto="0 -0.09 0 0 0.09 0" size="0.08" {_ROBOT_BITS} {grey} mass="3.9"/>',
                     upper)
    return (f'<geom name="base" type="cylinder" size="0.1 {SHOULDER_M / 2 - 0.04:g}" pos="0 0 {SHOULDER_M / 2 - 0.04:g}" '
            f'{_ROBOT_BITS} {grey} mass="10"/>'
            + _link("link1", f"0 0 {SHOULDER_M:g}", 0,
                    f'<geom name="link1" type="cylinder" size="0.09 0.05" pos="0 0 -0.05" {_ROBOT_BITS} {grey} mass="5"/>',
                    shoulder))


def _actuators_xml() -> str:
    return "".join(f'<position name="{n}" joint="{n}" kp="{kp:g}" kv="{kv:g}" forcerange="-{fr:g} {fr:g}" '
                   f'ctrlrange="{lo:g} {hi:g}"/>'
                   for n, kp, kv, fr, (lo, hi) in zip(ARM_JOINTS, _KP, _KV, _FORCE, JOINT_RANGE))


def _objects_xml(objects: Sequence[int], object_xy: np.ndarray, top_z: float) -> str:
    bodies = []
    for k, (g, (x, y)) in enumerate(zip(objects, object_xy)):
        obj = GRASP_OBJECTS[g]
        z = top_z + obj.rest_height_m
        bodies.append(f'<body name="object{k}" pos="{x:.4f} {y:.4f} {z:.4f}"><freejoint name="object{k}"/>'
                      + obj.geom_xml(name=f"object{k}", rgba=_OBJECT_RGBA[k % len(_OBJECT_RGBA)],
                                     extra=f'{_OBJECT_BITS} condim="6"') + "</body>")
    return "".join(bodies)


def manipulator_scene_xml(hand: str = "barrett", table: TableSpec = TableSpec(), base_pos: ArrayLike = BASE_POS,
                          objects: Sequence[int] = DEFAULT_OBJECTS, object_xy: ArrayLike | None = None) -> str:
    """MJCF of the arm with a robot hand on its pedestal at the table, with free objects on the table.

    Args:
        hand: "barrett" or "karlsruhe".
        table: the table (the demonstration scene's by default).
        base_pos: (3,) the pedestal top (world m).
        objects: one free object per grasp class listed (bodies and free joints "object0", ...),
            standing upright on the table.
        object_xy: (K, 2) where the objects stand (world m); None: the demonstration slots.

    Returns:
        The MJCF text.

    Raises:
        ValueError: an unknown hand or grasp class, a `table` that is not a `TableSpec`, or positions
            of the wrong shape; more objects than default slots without `object_xy`.
    """
    hand = hand_spec(hand).name
    if not isinstance(table, TableSpec):
        raise ValueError(f"table: expected a TableSpec, got {type(table).__name__}")
    base = as_array(base_pos, "base_pos", shape=(3,))
    objects = tuple(check_choice(g, "objects", GRASP_CLASSES) for g in objects)
    xy = DEFAULT_OBJECT_XY[:len(objects)] if object_xy is None else as_array(object_xy, "object_xy",
                                                                                  shape=(len(objects), 2))
    if len(xy) < len(objects):
        raise ValueError(f"object_xy: {len(objects)} objects need positions, the default has {len(xy)}")
    hand_body, hand_act, equalities = hand_body_xml(hand)
    t = table
    depth, mid_y = (t.near_y - t.far_y) / 2, (t.near_y + t.far_y) / 2
    bx, by, bz = base
    return f"""<mujoco model="manipulator_{hand}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{TIMESTEP_S}" integrator="implicitfast" cone="elliptic" impratio="1"
          iterations="{SOLVER_ITERATIONS}" ls_iterations="{LS_ITERATIONS}"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <default><geom solref="0.004 1" solimp="0.95 0.99 0.001" friction="1 0.01 0.001"/></default>
  <worldbody>
    <light pos="0 -1 2.5" dir="0 0.4 -1" diffuse="0.8 0.8 0.8"/>
    <camera name="front" pos="{bx:.3f} -1.9 1.6" xyaxes="1 0 0 0 0.5 0.866"/>
    <geom name="floor" type="plane" size="3 3 0.1" rgba="0.4 0.4 0.42 1" contype="0" conaffinity="0"/>
    <geom name="table_body" type="box" pos="0 {mid_y:.4f} {t.top_z / 2 - 0.001:.4f}"
          size="{t.half_width:.4f} {depth:.4f} {t.top_z / 2 - 0.001:.4f}" rgba="{" ".join(f"{c:.3f}" for c in t.table_rgb)} 1"
          contype="0" conaffinity="0"/>
    <geom name="table" type="plane" pos="0 {mid_y:.4f} {t.top_z:.4f}" size="{t.half_width:.4f} {depth:.4f} 0.1"
          rgba="{" ".join(f"{c:.3f}" for c in t.table_rgb)} 1" {_TABLE_BITS} condim="4"/>
    <geom name="pedestal" type="cylinder" pos="{bx:.4f} {by:.4f} {bz / 2:.4f}" size="0.12 {bz / 2:.4f}"
          rgba="0.3 0.3 0.32 1" contype="0" conaffinity="0"/>
    <body name="base" pos="{bx:.4f} {by:.4f} {bz:.4f}" xyaxes="0 -1 0 1 0 0">
      {_arm_xml(hand_body)}
    </body>
    {_objects_xml(objects, xy, t.top_z)}
  </worldbody>
  <equality>{equalities}</equality>
  <actuator>{_actuators_xml()}{hand_act}</actuator>
</mujoco>"""


@dataclass(frozen=True)
class ManipulatorLayout:
    """Where things are in a compiled manipulator scene (numpy ints); K objects, D hand DoF.

    Attributes:
        hand: "barrett" or "karlsruhe".
        arm_qpos: (7,) qpos index of each arm joint.
        arm_dof: (7,) qvel index of each arm joint.
        arm_ctrl: (7,) actuator index of each arm joint.
        hand_ctrl: (D,) actuator index of each hand DoF.
        palm_site: the site the IK places ("palm_centre").
        flange_site: the flange's site.
        object_qpos: (K,) start of each object's free joint (7) in qpos.
        object_body: (K,) body id of each object.
    """

    hand: str
    arm_qpos: np.ndarray
    arm_dof: np.ndarray
    arm_ctrl: np.ndarray
    hand_ctrl: np.ndarray
    palm_site: int
    flange_site: int
    object_qpos: np.ndarray
    object_body: np.ndarray


def scene_layout(model: mujoco.MjModel, hand: str) -> ManipulatorLayout:
    """The layout of a model compiled from `manipulator_scene_xml(hand, ...)`."""
    spec = hand_spec(hand)
    joints = [model.joint(n) for n in ARM_JOINTS]
    n_obj = sum(model.body(b).name.startswith("object") for b in range(model.nbody))
    return ManipulatorLayout(
        hand=spec.name,
        arm_qpos=np.array([int(j.qposadr[0]) for j in joints]),
        arm_dof=np.array([int(j.dofadr[0]) for j in joints]),
        arm_ctrl=np.array([model.actuator(n).id for n in ARM_JOINTS]),
        hand_ctrl=np.array([model.actuator(d).id for d in spec.dofs]),
        palm_site=model.site("palm_centre").id,
        flange_site=model.site("flange").id,
        object_qpos=np.array([int(model.joint(f"object{k}").qposadr[0]) for k in range(n_obj)]),
        object_body=np.array([model.body(f"object{k}").id for k in range(n_obj)]),
    )


@functools.lru_cache(maxsize=4)
def _default_model(hand: str) -> tuple[mujoco.MjModel, ManipulatorLayout]:
    model = mujoco.MjModel.from_xml_string(manipulator_scene_xml(hand))
    return model, scene_layout(model, hand)


def manipulator_model(hand: str = "barrett", **scene: Any) -> tuple[mujoco.MjModel, ManipulatorLayout]:
    """Compile the manipulator scene of `manipulator_scene_xml`.

    The default scene's model is cached (do not modify it; `copy.copy` it to change parameters).

    Args:
        hand: "barrett" or "karlsruhe".
        **scene: `manipulator_scene_xml`'s other arguments (table, base_pos, objects, object_xy).

    Returns:
        (model, layout).

    Raises:
        ValueError: bad input to `manipulator_scene_xml`.
    """
    hand = hand_spec(hand).name
    if not scene:
        return _default_model(hand)
    model = mujoco.MjModel.from_xml_string(manipulator_scene_xml(hand, **scene))
    return model, scene_layout(model, hand)


def manipulator_qpos(model: mujoco.MjModel, layout: ManipulatorLayout, q_arm: ArrayLike = HOME_Q,
                     hand_targets: ArrayLike | None = None) -> np.ndarray:
    """A pose of the manipulator scene: the arm, the fingers, the objects where the model puts them.

    Args:
        model: the compiled scene (`manipulator_model`).
        layout: its layout.
        q_arm: (7,) arm joint angles (rad).
        hand_targets: (D,) hand DoF targets, with their couplings satisfied; None: the first preshape's
            open shape.

    Returns:
        (nq,) qpos.

    Raises:
        ValueError: joint vectors of the wrong shape.
    """
    q_arm = as_array(q_arm, "q_arm", shape=(7,))
    spec = hand_spec(layout.hand)
    if hand_targets is None:
        hand_targets = next(iter(spec.preshapes.values()))[0]
    hand_targets = as_array(hand_targets, "hand_targets", shape=(len(spec.dofs),))
    qpos = hand_joint_qpos(model, layout.hand, hand_targets)
    qpos[layout.arm_qpos] = q_arm
    return qpos
