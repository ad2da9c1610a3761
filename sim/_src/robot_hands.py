"""The grasp scenes of MAP §III: a robot hand (`HandSpec`) on a floating wrist, a table and the six
grasp objects, as MJCF written here, and where things are in the compiled model (`SceneLayout`).

Both hands sit on a floating wrist: three slide joints (world x, y, z) and three hinges composed as
R = Rz(a) Rx(b) Ry(c) (intrinsic), each driven by a force-limited position actuator. The chain is
singular only when the hand's y axis is vertical, which no grasp here asks for (y is the closing
direction of the Barrett fingers and the finger direction of the Karlsruhe hand; both stay horizontal).

Hand frame (both hands): origin at the centre of the palm surface, +z the palm normal (the approach
direction: the object lies at +z when the hand grasps it), x the axis a wrap closes around.

Geometry: every hand geom is a capsule, so every physics backend collides it with the grasp objects
(`GRASP_OBJECTS`: cylinders, spheres, a box) and the plane table (MJX-JAX 3.17 has capsule against
all of those). Collision bits: the hand touches objects and the table, objects touch the table, nothing
touches itself (contype/conaffinity below), so the fingers pass through each other but never through
an object. One geom per link, so a link is one contact-sensor target.

Contacts: elliptic friction cones, `impratio` 1 and hand friction 1.5 (rubber-like pads; an object
pair takes the larger coefficient). A larger `impratio` (10) stiffens friction but makes the Newton
solver need its whole default budget (100 iterations, 50 line-search steps) to stay stable; with 1,
8 and 8 suffice and MuJoCo's results do not change when they are raised (see `SOLVER_ITERATIONS`).
The slip of a held object is reported by `experiments.grasp_mapping`.

Sensors, per link (palm first): a `touch` sensor on a capsule site slightly larger than the link (the
tactile pads of MAP §III), and one `contact` sensor per object (`found pos normal`, deepest contact),
from which contact records and virtual fingers are computed. Per object a `framepos` and a `framequat`
sensor, and the palm's `framepos`/`framequat`. All of these are computed identically by MuJoCo and
MJX, so every backend hands the controller the same `sensordata` layout.

The scene holds all six grasp objects; the active one rests on the table at the work position and the
others are parked in the air far away with gravity compensation (`body_gravcomp` per simulation), so
one compiled model per hand serves every grasp class.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from sim._src.grasp_objects import GRASP_CLASSES, GRASP_OBJECTS
from sim._src.robot_hand_specs import HAND_NAMES, HANDS, Finger, HandSpec, hand_spec, preshape
from sim._src.scenes import checker_asset_xml

__all__ = ["HANDS", "HAND_NAMES", "LS_ITERATIONS", "MJX_MAX_CONTACTS", "SOLVER_ITERATIONS", "TIMESTEP_S",
           "WRIST_ACTUATORS", "Finger", "HandSpec", "SceneLayout", "grasp_model", "grasp_scene_xml",
           "hand_body_xml", "hand_joint_qpos", "hand_spec", "parked_position", "preshape", "scene_layout"]

# The floating wrist, world x, y, z slides then the a, b, c hinges: (joint, MJCF joint attributes,
# position actuator kp, kv, force limit).
_WRIST = (
    ("wrist_x", 'type="slide" axis="1 0 0" damping="20"', 2000, 80, 40),
    ("wrist_y", 'type="slide" axis="0 1 0" damping="20"', 2000, 80, 40),
    ("wrist_z", 'type="slide" axis="0 0 1" damping="20"', 2000, 80, 40),
    ("wrist_a", 'axis="0 0 1" damping="2" armature="0.01"', 200, 8, 20),
    ("wrist_b", 'axis="1 0 0" damping="2" armature="0.01"', 200, 8, 20),
    ("wrist_c", 'axis="0 1 0" damping="2" armature="0.01"', 200, 8, 20),
)
WRIST_ACTUATORS: tuple[str, ...] = tuple(w[0] for w in _WRIST)
TIMESTEP_S = 0.002
# Constraint solver caps, the same on every backend: with impratio 1 Newton converges within them (the
# sample grasps give the same outcomes with 8/8 as with MuJoCo's defaults 100/50), and MJX-JAX runs
# every line-search iteration of every world under `vmap` (a batched `lax.cond` evaluates both
# branches), so the default 50 would cost 50 evaluations per Newton iteration.
SOLVER_ITERATIONS, LS_ITERATIONS = 8, 8
# Contact bits: hand (2, 0), objects (4, 2), table (8, 6). Collide iff (ct1 & ca2) | (ct2 & ca1).
_HAND_BITS = 'contype="2" conaffinity="0" friction="1.5 0.01 0.001"'
_OBJECT_BITS = 'contype="4" conaffinity="2"'
_TABLE_BITS = 'contype="8" conaffinity="6"'
_PARK_X_M = 3.0  # parked objects float at x = 3 + k metres, z = 1 m
# MJX-JAX computes every candidate contact of every world, touching or not (94 for the Karlsruhe hand,
# 66 for the Barrett), and its Newton solver with elliptic cones builds a dense (4 ncon)^2 matrix per
# iteration, one block update per contact: keeping only the 32 deepest makes the program much smaller
# to trace and compile. MuJoCo finds at most 10 contacts at once in the whole `paper` sweep (either
# hand); `grasp_rollout` raises if 32 ever penetrate at once in an MJX world.
MJX_MAX_CONTACTS = 32


def _fmt(values) -> str:
    return " ".join(f"{v:.4g}" for v in values)


def _finger_xml(f: Finger, spec: HandSpec) -> tuple[str, list[str]]:
    """MJCF body chain of one finger, and its equality constraints."""
    l1, l2 = f.lengths
    lo, hi = spec.dof_range.get(f.flex_dof, (-0.2, 2.3))
    extra = ""
    if f.extra_joint == "spread":
        extra = (f'<joint name="{f.name}_spread" axis="0 0 {f.extra_sign:g}" range="-0.1 3.2" '
                 f'damping="0.05" armature="0.002"/>')
    elif f.extra_joint == "oppose":
        extra = '<joint name="thumb_rot" axis="0 0 -1" range="-0.1 1.7" damping="0.05" armature="0.002"/>'
    pad = f.radius + 0.003
    body = f"""
      <body name="{f.name}" pos="{_fmt(f.pos)}" xyaxes="{_fmt(f.xyaxes)}" gravcomp="1">
        {extra}
        <joint name="{f.name}_prox" axis="1 0 0" range="{lo:g} {hi:g}" damping="0.05" armature="0.002"/>
        <geom name="{f.name}_prox" type="capsule" fromto="0 0 0 0 0 {l1:g}" size="{f.radius:g}" {_HAND_BITS} rgba="0.35 0.35 0.4 1" mass="0.06"/>
        <site name="{f.name}_prox" type="capsule" fromto="0 0 0 0 0 {l1:g}" size="{pad:g}" rgba="0 0 0 0"/>
        <body name="{f.name}_dist" pos="0 0 {l1:g}" gravcomp="1">
          <joint name="{f.name}_dist" axis="1 0 0" range="-0.2 2.3" damping="0.05" armature="0.002"/>
          <geom name="{f.name}_dist" type="capsule" fromto="0 0 0 0 0 {l2:g}" size="{f.radius:g}" {_HAND_BITS} rgba="0.5 0.5 0.55 1" mass="0.04"/>
          <site name="{f.name}_dist" type="capsule" fromto="0 0 0 0 0 {l2:g}" size="{pad:g}" rgba="0 0 0 0"/>
          <site name="{f.name}_tip" pos="0 0 {l2:g}" size="0.004"/>
        </body>
      </body>"""
    equalities = []
    if f.distal_dof is None:
        c0, c1 = spec.distal_coupling
        equalities.append(f'<joint joint1="{f.name}_dist" joint2="{f.name}_prox" polycoef="{c0:g} {c1:g} 0 0 0" '
                          f'solref="0.005 1"/>')
    return body, equalities


def hand_body_xml(hand: str, joints_xml: str = "") -> tuple[str, str, str]:
    """The robot hand as an MJCF body fragment named "hand", to be placed inside a parent body.

    Every hand body has gravcomp="1": its weight is compensated, whatever carries it.

    Args:
        hand: "barrett" or "karlsruhe".
        joints_xml: MJCF that goes first in the body (the floating wrist's joints here; empty on an
            arm's flange, which places the hand with the parent's pose).

    Returns:
        (body MJCF, finger actuator MJCF, equality MJCF).

    Raises:
        ValueError: an unknown hand.
    """
    spec = hand_spec(hand)
    fingers, equalities = [], []
    for f in spec.fingers:
        body, eq = _finger_xml(f, spec)
        fingers.append(body)
        equalities += eq
    # the second spread joint follows the first (Barrett: one spread DoF for two fingers)
    spread = [f for f in spec.fingers if f.extra_joint == "spread"]
    for f in spread[1:]:
        equalities.append(f'<joint joint1="{f.name}_spread" joint2="{spread[0].name}_spread" '
                          f'polycoef="0 1 0 0 0" solref="0.005 1"/>')
    palm_pad = spec.palm_radius + 0.003
    hand = f"""
    <body name="hand" gravcomp="1">
      {joints_xml}
      <geom name="palm" type="capsule" fromto="{_fmt(spec.palm_fromto)}" size="{spec.palm_radius:g}" {_HAND_BITS} rgba="0.25 0.25 0.3 1" mass="0.6"/>
      <geom name="wrist" type="capsule" fromto="0 0 -0.05 0 0 -0.12" size="0.02" contype="0" conaffinity="0" rgba="0.3 0.3 0.35 1" mass="0.2"/>
      <site name="palm" type="capsule" fromto="{_fmt(spec.palm_fromto)}" size="{palm_pad:g}" rgba="0 0 0 0"/>
      <site name="palm_centre" pos="0 0 0" size="0.004"/>
      {"".join(fingers)}
    </body>"""
    joint_of = {}
    for f in spec.fingers:
        joint_of.setdefault(f.flex_dof, f"{f.name}_prox")
        if f.distal_dof:
            joint_of[f.distal_dof] = f"{f.name}_dist"
        if f.extra_dof:
            joint_of.setdefault(f.extra_dof, f"{f.name}_{f.extra_joint}" if f.extra_joint == "spread" else "thumb_rot")
    # Barrett: one flexion actuator per finger; a DoF shared by several joints drives the first and the
    # equality constraints carry the others
    hand_act = "".join(
        f'<position name="{d}" joint="{joint_of[d]}" kp="{spec.finger_kp:g}" kv="0.05" '
        f'forcerange="-{spec.finger_force:g} {spec.finger_force:g}"/>' for d in spec.dofs)
    return hand, hand_act, "".join(equalities)


def _hand_xml(spec: HandSpec) -> tuple[str, str, str]:
    """(hand body MJCF, actuator MJCF, equality MJCF) of `spec` on the floating wrist."""
    wrist_joints = "".join(f'<joint name="{n}" {attrs}/>' for n, attrs, *_ in _WRIST)
    hand, hand_act, equalities = hand_body_xml(spec.name, wrist_joints)
    wrist_act = "".join(f'<position name="{n}" joint="{n}" kp="{kp:g}" kv="{kv:g}" forcerange="-{f:g} {f:g}"/>'
                        for n, _, kp, kv, f in _WRIST)
    return hand, wrist_act + hand_act, equalities


def _sensor_xml(spec: HandSpec) -> str:
    touch = "".join(f'<touch name="touch_{ln}" site="{ln}"/>' for ln in spec.link_names)
    contact = "".join(
        f'<contact name="contact_{ln}_{g}" geom1="{ln}" geom2="object{g}" data="found pos normal" '
        f'reduce="mindist" num="1"/>' for ln in spec.link_names for g in GRASP_CLASSES)
    frames = "".join(f'<framepos name="pos_object{g}" objtype="body" objname="object{g}"/>'
                     f'<framequat name="quat_object{g}" objtype="body" objname="object{g}"/>'
                     for g in GRASP_CLASSES)
    palm = ('<framepos name="pos_palm" objtype="site" objname="palm_centre"/>'
            '<framequat name="quat_palm" objtype="site" objname="palm_centre"/>')
    return touch + contact + frames + palm


def grasp_scene_xml(hand: str) -> str:
    """MJCF of the robot hand on its floating wrist, a plane table at z = 0 and the six grasp objects.

    Object `object{g}` (g a grasp class) has a free joint; by default every object is parked in the air
    at x = 3 + k m (k its index in `GRASP_CLASSES`); a trial's starting qpos puts one on the table.

    Args:
        hand: "barrett" or "karlsruhe".

    Returns:
        The MJCF text.

    Raises:
        ValueError: an unknown hand.
    """
    spec = hand_spec(hand)
    hand_body, actuators, equalities = _hand_xml(spec)
    objects = []
    for k, g in enumerate(GRASP_CLASSES):
        obj = GRASP_OBJECTS[g]
        objects.append(f'<body name="object{g}" pos="{_PARK_X_M + k:g} 0 1" gravcomp="1"><freejoint name="object{g}"/>'
                       + obj.geom_xml(name=f"object{g}", rgba="0.1 0.1 0.1 1",
                                      extra=f'{_OBJECT_BITS} condim="4"') + "</body>")
    return f"""<mujoco model="grasp_{spec.name}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{TIMESTEP_S}" integrator="implicitfast" cone="elliptic" impratio="1"
          iterations="{SOLVER_ITERATIONS}" ls_iterations="{LS_ITERATIONS}"/>
  <custom>
    <!-- MJX-JAX only (MuJoCo ignores these): collide each hand link with the nearest object of each
         geom type only (the parked objects are metres away, so no contact is lost), and keep the
         MJX_MAX_CONTACTS deepest of the candidate contacts (see MJX_MAX_CONTACTS). -->
    <numeric name="max_geom_pairs" data="{len(spec.link_names)}"/>
    <numeric name="max_contact_points" data="{MJX_MAX_CONTACTS}"/>
  </custom>
  <visual><global offwidth="640" offheight="480"/></visual>
  <default><geom solref="0.004 1" solimp="0.95 0.99 0.001" friction="1 0.01 0.001"/></default>
  {checker_asset_xml(".75 .72 .65", ".68 .65 .58")}
  <worldbody>
    <light pos="0.3 -0.6 1.5" dir="-0.2 0.4 -1" diffuse="0.8 0.8 0.8"/>
    <light pos="-0.5 0.5 1.2" dir="0.4 -0.4 -1" diffuse="0.4 0.4 0.4"/>
    <camera name="front" pos="0.5 -0.5 0.45" xyaxes="0.707 0.707 0 -0.299 0.299 0.906"/>
    <geom name="table" type="plane" size="1.5 1.5 0.1" material="grid" {_TABLE_BITS} condim="4"/>
    {hand_body}
    {"".join(objects)}
  </worldbody>
  <equality>{equalities}</equality>
  <actuator>{actuators}</actuator>
  <sensor>{_sensor_xml(spec)}</sensor>
</mujoco>"""


@dataclass(frozen=True)
class SceneLayout:
    """Where things are in a compiled grasp scene's `qpos`, `ctrl` and `sensordata` (all numpy ints).

    L links (palm first), G objects (`GRASP_CLASSES` order), U actuators (6 wrist, then hand DoF).

    Attributes:
        hand: "barrett" or "karlsruhe".
        n_links: L.
        touch: (L,) sensordata index of each link's touch sensor.
        contact: (L, G) start of each (link, object) contact sensor: found, pos (3), normal (3).
        object_pos: (G,) start of each object's framepos (3).
        object_quat: (G,) start of each object's framequat (4).
        palm_pos: start of the palm's framepos (3).
        palm_quat: start of the palm's framequat (4).
        object_qpos: (G,) start of each object's free joint in qpos (7).
        object_body: (G,) body id of each object.
        wrist_qpos: (6,) qpos index of the wrist joints.
        hand_qpos: (n_dof,) qpos index of the joint each hand actuator drives.
        n_ctrl: U.
        link_finger: (L,) 0 palm, k finger k.
        fingertip_site: (F,) site ids of the fingertips.
    """

    hand: str
    n_links: int
    touch: np.ndarray
    contact: np.ndarray
    object_pos: np.ndarray
    object_quat: np.ndarray
    palm_pos: int
    palm_quat: int
    object_qpos: np.ndarray
    object_body: np.ndarray
    wrist_qpos: np.ndarray
    hand_qpos: np.ndarray
    n_ctrl: int
    link_finger: np.ndarray
    fingertip_site: np.ndarray


def scene_layout(model: mujoco.MjModel, hand: str) -> SceneLayout:
    """The `SceneLayout` of a model compiled from `grasp_scene_xml(hand)`."""
    spec = hand_spec(hand)

    def sensor(name: str) -> int:
        return int(model.sensor_adr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)])

    def qadr(joint: str) -> int:
        return int(model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)])

    links = spec.link_names
    return SceneLayout(
        hand=spec.name,
        n_links=len(links),
        touch=np.array([sensor(f"touch_{ln}") for ln in links]),
        contact=np.array([[sensor(f"contact_{ln}_{g}") for g in GRASP_CLASSES] for ln in links]),
        object_pos=np.array([sensor(f"pos_object{g}") for g in GRASP_CLASSES]),
        object_quat=np.array([sensor(f"quat_object{g}") for g in GRASP_CLASSES]),
        palm_pos=sensor("pos_palm"), palm_quat=sensor("quat_palm"),
        object_qpos=np.array([qadr(f"object{g}") for g in GRASP_CLASSES]),
        object_body=np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"object{g}")
                              for g in GRASP_CLASSES]),
        wrist_qpos=np.array([qadr(n) for n in WRIST_ACTUATORS]),
        hand_qpos=np.array([qadr(model.joint(model.actuator(d).trnid[0]).name) for d in spec.dofs]),
        n_ctrl=model.nu,
        link_finger=spec.link_finger,
        fingertip_site=np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"{f.name}_tip")
                                 for f in spec.fingers]),
    )


def grasp_model(hand: str) -> tuple[mujoco.MjModel, SceneLayout]:
    """Compile the grasp scene of MAP §III: the robot hand on a floating wrist, a table, six objects.

    See the module docstring for the scene (joints, actuators, tactile and contact sensors).

    Args:
        hand: "barrett" or "karlsruhe".

    Returns:
        A tuple (model, layout), a fresh model each call.

    Raises:
        ValueError: an unknown hand.
    """
    model = mujoco.MjModel.from_xml_string(grasp_scene_xml(hand))
    return model, scene_layout(model, hand)


def hand_joint_qpos(model: mujoco.MjModel, hand: str, targets: np.ndarray) -> np.ndarray:
    """Joint positions that put the hand's DoF at given targets, with the couplings satisfied.

    Starting the fingers in their preshape (equality constraints satisfied) avoids a violent first step.

    Args:
        model: a compiled model with the hand (the grasp scene or the manipulator scene).
        hand: "barrett" or "karlsruhe".
        targets: (n_dof,) hand-DoF targets (rad), `HandSpec.dofs` order.

    Returns:
        (nq,) qpos: the model's `qpos0` with the hand's joints set.

    Raises:
        ValueError: an unknown hand.
    """
    spec = hand_spec(hand)
    qpos = model.qpos0.copy()
    value = dict(zip(spec.dofs, np.asarray(targets, float)))

    def set_joint(name: str, v: float) -> None:
        qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)]] = v

    c0, c1 = spec.distal_coupling
    for f in spec.fingers:
        set_joint(f"{f.name}_prox", value[f.flex_dof])
        set_joint(f"{f.name}_dist", value[f.distal_dof] if f.distal_dof else c0 + c1 * value[f.flex_dof])
        if f.extra_joint == "spread":
            set_joint(f"{f.name}_spread", value[f.extra_dof])
        elif f.extra_joint == "oppose":
            set_joint("thumb_rot", value[f.extra_dof])
    return qpos


def parked_position(object_index: int) -> np.ndarray:
    """Where object `object_index` (index into `GRASP_CLASSES`) floats while another is grasped."""
    return np.array([_PARK_X_M + object_index, 0.0, 1.0])
