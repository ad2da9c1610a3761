"""The robot's task controller (issue 21, "The robot"): pick one object up with the MAP §III grasp strategy
on the WAM-like arm of `sim.manipulator`, carry it to a place on the table, put it down upright, release
it. Native MuJoCo on the CPU, one world, a Python control loop at `CONTROL_DT_S`.

What it does, in order (`run_task(spec)` -> `TaskResult`):

1. Plan (MAP §III, seed file 000_a44a81cd5fd37a97.txt): `sim.grasp_strategy.plan_trials` gives the
   robot preshape of the human grasp class through the mapping table (`robot_grasp_for`), the hand
   orientation imitating the human hand's (palm normal -> approach, thumb axis -> wrap axis; volar
   grasps from the top or the side, open-loop grasps to a predefined distance), the approach start
   and goal, in the object's frame. The plan is turned about the vertical by the yaw that best aligns
   the canonical human hand (`sim.human_grasps.hand_pose_in_world`) with the recognised one
   (`TaskSpec.hand_rot`, world), and moved onto the object. The palm poses above the pre-grasp, at
   the pre-grasp, grasp, lift, above the place, at the place and retracted are checked with one
   batched `solve_ik`, at that yaw and at turns of `YAW_STEPS_DEG` (up to 90 degrees) from it, and
   with MuJoCo's collision detection at the IK answers (no contact with another object, none of the
   arm with the table): the first yaw at which the arm reaches all seven cleanly is executed
   (`TaskResult.yaw_deg`: the imitation as close as the arm allows); none -> the result fails at
   "ik_unreachable" without simulating (so does a place off the table).
2. Approach: the palm rises `CLEAR_M` from home (whose fingers point down at the table), then
   follows the caller's path (`approach_path` (T, 3) world, e.g. a PHMM-synthesised reach retargeted
   to the arm), else a straight line, to `ABOVE_M` above the pre-grasp pose, at `MOVE_SPEED_M_S` (arc
   length, min-jerk timing), the orientation slerped from home to the grasp's; then it descends onto
   the pre-grasp pose (the open fingers clear the object). The path is not checked for collisions
   (a joint-space move from home to the checked configuration above the pre-grasp was tried and was
   no better on the default three-object scene).
3. Grasp and lift: `sim.grasp_strategy.controller_step` itself (the floating-hand study's controller,
   jitted, B = 1) drives the palm position and the fingers: approach along the planned line, stop at
   the first touch for volar grasps and, if it is not on the palm and `tactile` is on, retract and
   replan towards the contact (MAP §III's correction), close, lift 10 cm, hold briefly. Its sensors
   (touch per hand link, contact with the object, object and palm frames) are added to the
   manipulator scene in the grasp scene's layout (`sim.robot_hands.SceneLayout`), and
   `sim.grasp_rollout.peak_touch` reads them per control period exactly as in the grasp study.
4. Carry the palm horizontally (at the lift height, the orientation kept) until the object is above
   the place; turn the hand about the object's centre so that the held object stands upright (its
   axis as measured, a tilt in the grasp of up to `MAX_STRAIGHTEN_DEG`, turned to the vertical; a
   larger tilt means the object pivots in the grasp and turning the hand would drop it); lower it
   until the object (or a finger) touches the table; open the fingers to the open preshape; retract
   along the approach direction and up.

Every palm pose becomes arm joint targets by tracking IK: one damped-least-squares solve per control
step (`solve_ik`, one start, warm-started at the last target), sent to the arm's position servos;
the fingers' targets go to the hand's servos.

Success (`TaskResult.success`): the handled object ends within `PLACE_TOL_M` of the place in x-y,
upright (its z axis within `UPRIGHT_TOL_DEG` of vertical; a cube may stand on any face, a ball is
always upright) and released (no contact with the robot). The first failing stage is named:
"ik_unreachable", "approach" (the palm did not reach the pre-grasp pose), "grasp" (the object is not
held by two links after closing), "lift" (held but not raised with the hand), "carry" (dropped on the
way), "place" (too far, not upright or not released, including an object that slips out while
lowered).

What it does not do: no collision-aware path planning (only the key poses are checked; the
straight carry can sweep other objects off the table, the arm may brush them), no re-grasp after a failure, no change of hand orientation
between grasp and place (a place that needs one is unreachable), no force control while lowering
(it stops at the first object-table contact). The plan uses the geometry of the grasp class's own
object (`sim.grasp_objects.GRASP_OBJECTS[grasp]`, as the grasp study does); a handled object of
another class only shifts the plan to its centre height. Recognised orientation: only its yaw
about the vertical is used (MAP §III snaps the approach to top or side anyway).
"""
from __future__ import annotations

import functools
import time
from collections.abc import Sequence
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from lfd_common import as_array, check_choice, check_int, check_real, quat_to_matrix
from sim.grasp_objects import GRASP_CLASSES, GRASP_NAMES, GRASP_OBJECTS, check_grasp_class, robot_grasp_for
from sim.grasp_rollout import LIFT_SUCCESS_M, SUBSTEPS, peak_touch
from sim.grasp_strategy import (CONTROL_DT_S, DONE, HORIZON_S, LIFT, TrialParams, controller_step, initial_state,
                                object_extent, plan_trials)
from sim.human_grasps import hand_pose_in_world
from sim.manipulator import (BASE_POS, DEFAULT_OBJECT_XY, DEFAULT_OBJECTS, HOME_Q, manipulator_qpos,
                             manipulator_scene_xml, scene_layout as manipulator_layout)
from sim.manipulator_ik import ArmChain, arm_chain, forward_kinematics, solve_ik
from sim.person_scene import TableSpec
from sim.render import setup_rendering
from sim.robot_hands import HAND_NAMES, SceneLayout, hand_spec

__all__ = ["STAGES", "TaskResult", "TaskSpec", "run_task", "task_sweep", "task_table"]

STAGES: tuple[str, ...] = ("ik_unreachable", "approach", "grasp", "lift", "carry", "place")
PLACE_TOL_M = 0.05
UPRIGHT_TOL_DEG = 20.0
MOVE_SPEED_M_S = 0.3         # mean palm speed of the free approach and of the retract (min-jerk timing)
CARRY_SPEED_M_S = 0.15       # mean palm speed while carrying
LOWER_SPEED_M_S = 0.05       # palm speed while lowering onto the table
OPEN_S, SETTLE_S = 0.6, 0.3
MAX_STRAIGHTEN_DEG = 25.0    # a larger tilt in the grasp means the object pivots there: not turned
STRAIGHTEN_S = 0.4           # turning the held object upright above the place
HOLD_S = 0.3                 # the grasp controller's hold after its lift (its study holds 1 s)
RETRACT_M, RETRACT_UP_M = 0.08, 0.06
CLEAR_M = 0.15               # the palm first rises this far from home (its fingers point down at the table)
ABOVE_M = 0.12               # the approach ends with a vertical descent from this far above the pre-grasp
APPROACH_TOL_M = 0.02        # the palm within this of the pre-grasp pose after the approach
TRACK_ITERATIONS = 10        # DLS steps per control step of the tracking IK
TABLE = TableSpec()


class TaskSpec(NamedTuple):
    """One pick-and-place task.

    objects: grasp-object classes of `sim.grasp_objects` standing on the table (K of them, as
    `sim.manipulator.manipulator_scene_xml`'s `objects`); object_xy (K, 2) world m; target: index of
    the object to handle; grasp: the human grasp class (1, 2, 4, 9, 10, 12); hand_rot (3, 3): the
    human hand's orientation (world; columns the hand axes of `sim.human_hand`), None: the grasp's
    canonical one (`sim.human_grasps.hand_pose_in_world`, given in the object's frame) as a person
    sitting where the robot stands would hold it: turned about the vertical so that the canonical side
    approach points from the arm's base to the object; place_xy (2,) world m: where to put it
    down; tactile: MAP §III's tactile correction for volar grasps; hand: "barrett" or "karlsruhe".
    """

    objects: tuple[int, ...] = DEFAULT_OBJECTS
    object_xy: Any = DEFAULT_OBJECT_XY
    target: int = 0
    grasp: int = 1
    place_xy: Any = (0.1, -0.45)
    hand_rot: Any = None
    tactile: bool = True
    hand: str = "barrett"


class TaskResult(NamedTuple):
    """The outcome of one task (numpy / Python values).

    success: placed within `PLACE_TOL_M`, upright and released; failed_stage: the first stage that
    failed (one of `STAGES`), "" on success; object_pos (3,) the handled object's final position
    (world); upright, released: the two final checks; place_error_m: x-y distance to the place;
    n_corrections: tactile corrections made; yaw_deg: how far (about the vertical) the executed hand
    orientation is turned from the preferred one (`YAW_STEPS_DEG`); stage_sim_s / stage_wall_s: simulated and wall-clock
    seconds per stage that ran ("plan", "approach", "grasp", "carry", "place"; "grasp" includes the
    lift); frames (F, H, W, 3) uint8 of the fixed camera, or None when not rendered; fps: their rate.
    """

    success: bool
    failed_stage: str
    object_pos: np.ndarray
    upright: bool
    released: bool
    place_error_m: float
    n_corrections: int
    yaw_deg: float
    stage_sim_s: dict
    stage_wall_s: dict
    frames: np.ndarray | None
    fps: float


# ---------------------------------------------------------------- the scene with the grasp sensors

def _sensor_xml(links: Sequence[str], n_objects: int) -> str:
    """The grasp scene's sensors (`sim.robot_hands`) for a manipulator scene's objects "object0" ...:
    touch per link site, contact per (link, object), object and palm frames."""
    touch = "".join(f'<touch name="touch_{ln}" site="{ln}"/>' for ln in links)
    contact = "".join(f'<contact name="contact_{ln}_{k}" geom1="{ln}" geom2="object{k}" data="found pos normal" '
                      f'reduce="mindist" num="1"/>' for ln in links for k in range(n_objects))
    frames = "".join(f'<framepos name="pos_object{k}" objtype="body" objname="object{k}"/>'
                     f'<framequat name="quat_object{k}" objtype="body" objname="object{k}"/>' for k in range(n_objects))
    palm = ('<framepos name="pos_palm" objtype="site" objname="palm_centre"/>'
            '<framequat name="quat_palm" objtype="site" objname="palm_centre"/>')
    return f"<sensor>{touch}{contact}{frames}{palm}</sensor>"


class _Scene(NamedTuple):
    model: mujoco.MjModel
    arm: Any              # sim.manipulator.ManipulatorLayout
    sensors: SceneLayout  # the grasp controller's view of the sensors
    chain: ArmChain
    robot_geoms: np.ndarray
    hand_geoms: np.ndarray
    table_geom: int


@functools.lru_cache(maxsize=8)
def _scene(hand: str, objects: tuple[int, ...], object_xy: tuple[tuple[float, float], ...]) -> _Scene:
    spec = hand_spec(hand)
    xml = manipulator_scene_xml(hand, objects=objects, object_xy=np.array(object_xy))
    xml = xml.replace("</mujoco>", _sensor_xml(spec.link_names, len(objects)) + "\n</mujoco>")
    model = mujoco.MjModel.from_xml_string(xml)
    arm = manipulator_layout(model, hand)
    links = spec.link_names

    def sensor(name: str) -> int:
        return int(model.sensor_adr[model.sensor(name).id])

    sensors = SceneLayout(
        hand=spec.name, n_links=len(links),
        touch=np.array([sensor(f"touch_{ln}") for ln in links]),
        contact=np.array([[sensor(f"contact_{ln}_{k}") for k in range(len(objects))] for ln in links]),
        object_pos=np.array([sensor(f"pos_object{k}") for k in range(len(objects))]),
        object_quat=np.array([sensor(f"quat_object{k}") for k in range(len(objects))]),
        palm_pos=sensor("pos_palm"), palm_quat=sensor("quat_palm"),
        object_qpos=arm.object_qpos, object_body=arm.object_body, wrist_qpos=np.zeros(0, int),
        hand_qpos=np.array([int(model.jnt_qposadr[model.actuator_trnid[a, 0]]) for a in arm.hand_ctrl]),
        n_ctrl=model.nu, link_finger=spec.link_finger,
        fingertip_site=np.array([model.site(f"{f.name}_tip").id for f in spec.fingers]))
    robot_geoms = np.flatnonzero(model.geom_contype == 2)
    hand_geoms = np.array([model.geom(ln).id for ln in links])
    return _Scene(model, arm, sensors, arm_chain(model, "palm_centre"), robot_geoms, hand_geoms, model.geom("table").id)


@functools.lru_cache(maxsize=8)
def _controller(hand: str, n_objects: int):
    """The grasp controller jitted for the sensor layout of a scene with `n_objects` objects (the layout
    depends only on the hand and the number of objects)."""
    layout = _scene(hand, (GRASP_CLASSES[0],) * n_objects,
                    tuple((0.3 * k, -0.4) for k in range(n_objects))).sensors
    return jax.jit(functools.partial(controller_step, layout=layout))


# ---------------------------------------------------------------- checks at the boundary

def _check_spec(spec: TaskSpec) -> TaskSpec:
    if not isinstance(spec, TaskSpec):
        raise ValueError(f"spec: expected a TaskSpec, got {type(spec).__name__}")
    objects = tuple(int(check_choice(g, "objects", GRASP_CLASSES)) for g in spec.objects)
    if not objects:
        raise ValueError("objects: at least one object is needed")
    xy = as_array(spec.object_xy, "object_xy", shape=(len(objects), 2))
    target = check_int(spec.target, "target", min_value=0, max_value=len(objects) - 1)
    grasp = check_grasp_class(spec.grasp, "grasp")
    place = as_array(spec.place_xy, "place_xy", shape=(2,))
    hand_rot = None
    if spec.hand_rot is not None:
        hand_rot = as_array(spec.hand_rot, "hand_rot", shape=(3, 3))
        if np.abs(hand_rot.T @ hand_rot - np.eye(3)).max() > 1e-4 or np.linalg.det(hand_rot) <= 0:
            raise ValueError("hand_rot: expected a rotation matrix (orthonormal, det +1)")
    if not isinstance(spec.tactile, (bool, np.bool_)):
        raise ValueError(f"tactile: expected a bool, got {spec.tactile!r}")
    hand = check_choice(spec.hand, "hand", HAND_NAMES)
    return TaskSpec(objects, xy, target, grasp, place, hand_rot, bool(spec.tactile), hand)


def _on_table(xy: np.ndarray, margin: float = 0.03) -> bool:
    x, y = xy
    return (abs(x) <= TABLE.half_width - margin) and (TABLE.far_y + margin <= y <= TABLE.near_y - margin)


# ---------------------------------------------------------------- planning

def _rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


YAW_STEPS_DEG = (0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0)


def _preferred_yaw(grasp: int, hand_rot: np.ndarray | None, object_xy: np.ndarray) -> float:
    """The rotation about the vertical that best maps the canonical human hand onto `hand_rot`:
    argmax_psi trace(hand_rot^T Rz(psi) R_canonical). None: the canonical hand of a demonstrator
    reaching from the robot's seat, i.e. the canonical grasp frame's +y (the side approach's direction)
    turned to point from the arm's base to the object."""
    if hand_rot is None:
        dx, dy = object_xy - BASE_POS[:2]
        return float(np.arctan2(dy, dx) - np.pi / 2)
    m = quat_to_matrix(hand_pose_in_world(grasp)[1]) @ hand_rot.T
    return float(np.arctan2(m[0, 1] - m[1, 0], m[0, 0] + m[1, 1]))


class _Plan(NamedTuple):
    params: TrialParams     # world frame, B = 1
    rot: np.ndarray         # (3, 3) palm rotation (world)
    grasp_palm: np.ndarray  # (3,) where the palm is expected to close (world)
    obj_centre: np.ndarray  # (3,) the object's centre (world)
    yaw_deg: float          # the plan's turn away from the preferred yaw


def _plan(spec: TaskSpec, params: TrialParams, psi: float, yaw_deg: float) -> _Plan:
    """`plan_trials`' plan (object frame, B = 1) turned by `psi` about the vertical and put on the object."""
    turn = _rot_z(psi)
    obj = GRASP_OBJECTS[spec.objects[spec.target]]
    ox, oy = spec.object_xy[spec.target]
    shift = np.array([ox, oy, TABLE.top_z + obj.rest_height_m - GRASP_OBJECTS[spec.grasp].rest_height_m])
    goal = params.goal[0] @ turn.T + shift
    start = params.start[0] @ turn.T + shift
    approach = turn @ params.approach[0]
    rot = turn @ Rotation.from_euler("ZXY", params.wrist[0]).as_matrix()
    # the palm stops at the standoff (open-loop) or at about the object's surface (volar)
    standoff = params.standoff[0] if not params.volar[0] else float(object_extent(spec.grasp, approach))
    world = params._replace(goal=goal[None].astype(np.float32), start=start[None].astype(np.float32),
                            approach=approach[None].astype(np.float32),
                            obj=np.array([spec.target], np.int32))
    centre = np.array([ox, oy, TABLE.top_z + obj.rest_height_m])
    return _Plan(world, rot, goal - standoff * approach, centre, yaw_deg)


def _reachable_plan(spec: TaskSpec, scene: _Scene, seed: int, mapping: str) -> tuple[_Plan, bool]:
    """The plan of the first yaw in `YAW_STEPS_DEG` (turns from the preferred yaw) whose key poses
    (`_key_poses`) the arm reaches (one batched IK call for all) without touching another object, or
    the table with anything but the hand (`_collides`); and whether there is one (else the preferred)."""
    params, _ = plan_trials(spec.hand, [spec.grasp], np.zeros((1, 2)), [0.0], [spec.tactile], [seed],
                            mapping=mapping, hold_s=HOLD_S)
    psi0 = _preferred_yaw(spec.grasp, spec.hand_rot, spec.object_xy[spec.target])
    plans = [_plan(spec, params, psi0 + np.radians(d), d) for d in YAW_STEPS_DEG]
    poses = np.stack([_key_poses(p, spec.place_xy) for p in plans])                       # (Y, P, 3)
    n_yaw, n_pose = poses.shape[:2]
    rots = np.repeat(np.stack([p.rot for p in plans]), n_pose, axis=0)
    ik = solve_ik(scene.chain, poses.reshape(-1, 3), rots, np.tile(HOME_Q, (n_yaw * n_pose, 1)), pos_tol=5e-3,
                  rot_tol=0.05)
    ok = np.asarray(ik.reachable).reshape(n_yaw, n_pose).all(1)
    q = np.asarray(ik.q, float).reshape(n_yaw, n_pose, -1)
    for k in np.flatnonzero(ok):
        if not _collides(scene, spec.target, q[k], plans[k].params):
            return plans[k], True
    return plans[0], False


def _collides(scene: _Scene, target: int, q: np.ndarray, params: TrialParams) -> bool:
    """Whether the robot at any of the arm configurations q (P, 7) (fingers open) touches an object other
    than `target` (at their start positions), or the table with a part other than the hand."""
    model, data = scene.model, mujoco.MjData(scene.model)
    others = np.array([model.body_geomadr[b] for k, b in enumerate(scene.arm.object_body) if k != target], int)
    arm_geoms = np.setdiff1d(scene.robot_geoms, scene.hand_geoms)
    base = manipulator_qpos(model, scene.arm, HOME_Q, params.open_[0].astype(float))
    for qk in q:
        data.qpos[:] = base
        data.qpos[scene.arm.arm_qpos] = qk
        mujoco.mj_forward(model, data)
        pairs = np.array([[c.geom1, c.geom2] for c in data.contact[:data.ncon]], int).reshape(-1, 2)
        robot = np.isin(pairs, scene.robot_geoms)
        hit_other = (robot[:, 0] & np.isin(pairs[:, 1], others)) | (robot[:, 1] & np.isin(pairs[:, 0], others))
        arm = np.isin(pairs, arm_geoms)
        table = pairs == scene.table_geom
        hit_table = (arm[:, 0] & table[:, 1]) | (arm[:, 1] & table[:, 0])
        if np.any(hit_other | hit_table):
            return True
    return False


def _key_poses(plan: _Plan, place_xy: np.ndarray) -> np.ndarray:
    """(7, 3) palm positions to check: above the pre-grasp, pre-grasp, grasp, lift, above the place, at
    the place, retract."""
    a = plan.params.approach[0].astype(float)
    lift = plan.grasp_palm + [0.0, 0.0, 0.10]
    carry = lift + np.append(place_xy - plan.obj_centre[:2], 0.0)
    placed = carry - [0.0, 0.0, 0.10]
    retract = placed - RETRACT_M * a + [0.0, 0.0, RETRACT_UP_M]
    pre = plan.params.start[0]
    return np.stack([pre + [0.0, 0.0, ABOVE_M], pre, plan.grasp_palm, lift, carry, placed, retract])


# ---------------------------------------------------------------- the simulation

def _min_jerk(n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, max(n, 1) + 1)[1:]
    return 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5


class _Sim:
    """One world stepped by control periods: palm pose -> tracking IK -> arm servo targets."""

    def __init__(self, scene: _Scene, spec: TaskSpec, open_: np.ndarray, render: bool, camera, width, height,
                 fps):
        self.scene, self.model = scene, scene.model
        self.data = mujoco.MjData(self.model)
        arm = scene.arm
        self.data.qpos[:] = _start_qpos(scene, open_)
        self.q_cmd = HOME_Q.astype(float).copy()
        self.data.ctrl[arm.arm_ctrl] = self.q_cmd
        self.data.ctrl[arm.hand_ctrl] = open_
        mujoco.mj_forward(self.model, self.data)
        self.sensordata = self.data.sensordata[None].copy()
        self.target = spec.target
        self.obj_geom = self.model.body_geomadr[arm.object_body[spec.target]]
        self.t = 0.0
        self.frames, self.renderer = [], None
        if render:
            setup_rendering()
            self.renderer = mujoco.Renderer(self.model, height=height, width=width)
            self.camera, self.frame_dt, self.next_frame = camera, 1.0 / fps, 0.0
            self._grab()

    def _grab(self):
        self.renderer.update_scene(self.data, camera=self.camera)
        self.frames.append(self.renderer.render().copy())
        self.next_frame += self.frame_dt

    def step(self, pos: np.ndarray, rot: np.ndarray, fingers: np.ndarray) -> None:
        """One control period with the palm commanded to (pos (3,), rot (3, 3)) and the hand to fingers (D,)."""
        ik = solve_ik(self.scene.chain, pos[None], rot[None], self.q_cmd[None], n_restarts=1, rounds=1,
                      iterations=TRACK_ITERATIONS)
        self.q_cmd = np.asarray(ik.q[0], float)
        self._step(fingers)

    def _step(self, fingers: np.ndarray) -> None:
        """One control period with the arm's servos at `q_cmd` and the hand's at fingers (D,)."""
        arm = self.scene.arm
        self.data.ctrl[arm.arm_ctrl] = self.q_cmd
        self.data.ctrl[arm.hand_ctrl] = fingers
        record = np.empty((1, SUBSTEPS, self.model.nsensordata))
        for k in range(SUBSTEPS):
            mujoco.mj_step(self.model, self.data)
            record[0, k] = self.data.sensordata
        self.sensordata = peak_touch(record, self.scene.sensors)
        self.t += CONTROL_DT_S
        if self.renderer is not None and self.t >= self.next_frame - 1e-9:
            self._grab()

    def palm(self) -> np.ndarray:
        return self.data.site_xpos[self.scene.arm.palm_site].copy()

    def obj_pos(self) -> np.ndarray:
        return self.data.xpos[self.scene.arm.object_body[self.target]].copy()

    def obj_rot(self) -> np.ndarray:
        return self.data.xmat[self.scene.arm.object_body[self.target]].reshape(3, 3).copy()

    def _pairs(self) -> np.ndarray:
        c = self.data.contact
        n = self.data.ncon
        return np.stack([c.geom1[:n], c.geom2[:n]], -1) if n else np.zeros((0, 2), int)

    def contact(self, geoms_a, geoms_b) -> bool:
        """Whether any geom of `geoms_a` touches any of `geoms_b` now."""
        pairs = self._pairs()
        a, b = np.isin(pairs, geoms_a), np.isin(pairs, geoms_b)
        return bool(np.any((a[:, 0] & b[:, 1]) | (a[:, 1] & b[:, 0])))

    def touches(self, geoms) -> bool:
        """Whether the handled object touches any of `geoms` now."""
        return self.contact([self.obj_geom], geoms)

    def close(self):
        if self.renderer is not None:
            self.renderer.close()


def _start_qpos(scene: _Scene, open_: np.ndarray) -> np.ndarray:
    return manipulator_qpos(scene.model, scene.arm, HOME_Q, open_)


def _polyline(points: np.ndarray, speed: float) -> np.ndarray:
    """(N, 3) positions per control step along the polyline `points` (P, 3) at mean speed `speed`,
    min-jerk in arc length."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    if arc[-1] < 1e-6:
        return points[-1:]
    n = max(int(np.ceil(arc[-1] / speed / CONTROL_DT_S)), 5)
    s = _min_jerk(n) * arc[-1]
    return np.stack([np.interp(s, arc, points[:, i]) for i in range(3)], -1)


def _move(sim: _Sim, points: np.ndarray, rot_from: np.ndarray, rot_to: np.ndarray, fingers, speed: float):
    path = _polyline(points, speed)
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([rot_from, rot_to])))
    rots = slerp(np.linspace(0.0, 1.0, len(path) + 1)[1:]).as_matrix()
    for p, r in zip(path, rots):
        sim.step(p, r, fingers)


def _upright_axis(obj, rot: np.ndarray) -> np.ndarray:
    """The object axis (3,) that should stand vertical: its z axis; for a cube, whichever of its axes
    (signed) is nearest to the vertical (a cube stands on any face)."""
    if obj.geom_type == "box" and np.ptp(obj.size) < 1e-9:
        k = int(np.argmax(np.abs(rot[2])))
        return rot[:, k] * np.sign(rot[2, k])
    return rot[:, 2]


def _tilt(obj, rot: np.ndarray) -> float:
    """How far (rad) the object with rotation `rot` (3, 3) is from standing upright (0 for a ball)."""
    if obj.geom_type == "sphere":
        return 0.0
    return float(np.arccos(np.clip(_upright_axis(obj, rot)[2], -1.0, 1.0)))


def _tilt_correction(axis: np.ndarray) -> np.ndarray:
    """(3, 3) the smallest rotation that turns the unit vector `axis` (3,) to the vertical."""
    k = np.cross(axis, [0.0, 0.0, 1.0])
    angle = np.arctan2(np.linalg.norm(k), axis[2])
    if np.linalg.norm(k) < 1e-9:
        return np.eye(3)
    return Rotation.from_rotvec(k / np.linalg.norm(k) * angle).as_matrix()


def _hold(sim: _Sim, pos, rot, fingers, seconds: float):
    for _ in range(int(round(seconds / CONTROL_DT_S))):
        sim.step(pos, rot, fingers)


def _held_links(sensordata: np.ndarray, sensors: SceneLayout, target: int) -> int:
    return int(np.sum(sensordata[0, sensors.contact[:, target]] > 0))


def run_task(spec: TaskSpec, *, approach_path=None, seed: int = 0, mapping: str = "map2009", render: bool = False,
             camera: str = "front", width: int = 320, height: int = 240, fps: float = 20.0) -> TaskResult:
    """Run one pick-and-place task on the native MuJoCo backend (CPU); see the module docstring.

    approach_path (T, 3): palm positions (world m) to follow from the home pose towards the pre-grasp
    pose (None: a straight line); seed: the grasp plan's hand-pose noise (`plan_trials`); mapping: the
    human-to-robot grasp mapping ("map2009" or "iros2008"); render: record frames of `camera` (a camera
    of the manipulator scene) at `width` x `height` and `fps` frames per simulated second (EGL by
    default, `sim.setup_rendering`). ValueError naming the argument for bad input; a place the arm
    cannot reach (or off the table) is a failed result at "ik_unreachable", not an exception.
    """
    spec = _check_spec(spec)
    seed = check_int(seed, "seed", min_value=0)
    mapping = check_choice(mapping, "mapping", ("map2009", "iros2008"))
    if not isinstance(render, (bool, np.bool_)):
        raise ValueError(f"render: expected a bool, got {render!r}")
    width = check_int(width, "width", min_value=16, max_value=640)
    height = check_int(height, "height", min_value=16, max_value=480)
    fps = check_real(fps, "fps", min_value=1.0, max_value=1.0 / CONTROL_DT_S)
    path = None if approach_path is None else as_array(approach_path, "approach_path", shape=(None, 3))
    scene = _scene(spec.hand, spec.objects, tuple(map(tuple, spec.object_xy.tolist())))
    if camera not in [scene.model.camera(i).name for i in range(scene.model.ncam)]:
        raise ValueError(f"camera: no camera named {camera!r} in the manipulator scene")

    sim_s, wall_s = {}, {}
    clock = time.perf_counter()
    plan, reachable = _reachable_plan(spec, scene, seed, mapping)
    wall_s["plan"], sim_s["plan"] = time.perf_counter() - clock, 0.0
    centre = plan.obj_centre
    if not (reachable and _on_table(spec.place_xy)):
        return TaskResult(False, "ik_unreachable", centre, True, True,
                          float(np.linalg.norm(centre[:2] - spec.place_xy)), 0, plan.yaw_deg, sim_s, wall_s, None, fps)

    params = plan.params
    open_, closed = params.open_[0].astype(float), params.closed[0].astype(float)
    sim = _Sim(scene, spec, open_, render, camera, width, height, fps)
    stage = {"name": "approach", "t": 0.0, "wall": time.perf_counter()}

    def next_stage(name: str):
        sim_s[stage["name"]] = sim.t - stage["t"]
        wall_s[stage["name"]] = time.perf_counter() - stage["wall"]
        stage.update(name=name, t=sim.t, wall=time.perf_counter())

    def finish(failed: str) -> TaskResult:
        next_stage("")
        pos = sim.obj_pos()
        upright = bool(_tilt(held_obj, sim.obj_rot()) <= np.radians(UPRIGHT_TOL_DEG))
        released = not sim.touches(scene.robot_geoms)
        err = float(np.linalg.norm(pos[:2] - spec.place_xy))
        ok = failed == "" and upright and released and err <= PLACE_TOL_M
        failed = failed or ("" if ok else "place")
        frames = np.stack(sim.frames) if sim.frames else None
        sim.close()
        return TaskResult(ok, failed, pos, upright, released, err, n_corr, plan.yaw_deg, sim_s, wall_s, frames, fps)

    n_corr = 0
    held_obj = GRASP_OBJECTS[spec.objects[spec.target]]
    try:
        # 1. approach: up, along the caller's path (or a straight line) to above the pre-grasp pose, down
        home_pos, home_rot = (np.asarray(a, float) for a in forward_kinematics(scene.chain, HOME_Q))
        pre = params.start[0].astype(float)
        above = pre + [0.0, 0.0, ABOVE_M]
        clear = home_pos + [0.0, 0.0, CLEAR_M]
        points = np.concatenate([home_pos[None], clear[None]] + ([path] if path is not None else [])
                                + [above[None]])
        _move(sim, points, home_rot, plan.rot, open_, MOVE_SPEED_M_S)
        _move(sim, np.stack([above, pre]), plan.rot, plan.rot, open_, MOVE_SPEED_M_S / 2)
        _hold(sim, pre, plan.rot, open_, SETTLE_S)
        if np.linalg.norm(sim.palm() - pre) > APPROACH_TOL_M:
            return finish("approach")

        # 2. grasp and lift: the MAP §III controller drives the palm position and the fingers
        next_stage("grasp")
        control = _controller(spec.hand, len(spec.objects))
        state = initial_state(params, scene.sensors.n_links)
        closed_links, lift_start = 0, None
        for _ in range(int(round(HORIZON_S / CONTROL_DT_S))):
            before = int(state.phase[0])
            state, ctrl = control(state, jnp.asarray(sim.sensordata, jnp.float32), params)
            ctrl = np.asarray(ctrl[0], float)
            phase = int(state.phase[0])
            if phase == LIFT and before != LIFT:
                closed_links, lift_start = _held_links(sim.sensordata, scene.sensors, spec.target), sim.obj_pos()
            if phase == DONE:
                break
            sim.step(ctrl[:3], plan.rot, ctrl[6:])
        n_corr = int(state.n_corr[0])
        if lift_start is None or (closed_links < 2 and sim.obj_pos()[2] - centre[2] < LIFT_SUCCESS_M):
            return finish("grasp")
        if int(state.phase[0]) != DONE or sim.obj_pos()[2] - centre[2] < LIFT_SUCCESS_M:
            return finish("lift")

        # 3. carry above the place, at the lift height, the orientation kept
        next_stage("carry")
        fingers = closed
        cmd = np.asarray(state.cmd[0], float)
        goal = cmd + np.append(spec.place_xy - sim.obj_pos()[:2], 0.0)
        _move(sim, np.stack([cmd, goal]), plan.rot, plan.rot, fingers, CARRY_SPEED_M_S)
        _hold(sim, goal, plan.rot, fingers, SETTLE_S)
        # dropped: no longer touching the hand, or fallen (an object that turns in the grasp is still held)
        dropped = sim.obj_pos()[2] - centre[2] < LIFT_SUCCESS_M / 2 or not sim.touches(scene.hand_geoms)
        if dropped:
            return finish("carry")
        # straighten: turn the hand about the object's centre so that the held object's axis is vertical
        rot = plan.rot
        tilt = _tilt(held_obj, sim.obj_rot())
        if 0.0 < tilt <= np.radians(MAX_STRAIGHTEN_DEG):
            fix = _tilt_correction(_upright_axis(held_obj, sim.obj_rot()))
            centre_now = sim.obj_pos()
            straight = centre_now + fix @ (goal - centre_now)
            slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([rot, fix @ rot])))
            n = int(round(STRAIGHTEN_S / CONTROL_DT_S))
            for s, r in zip(_min_jerk(n), slerp(_min_jerk(n)).as_matrix()):
                sim.step(goal + s * (straight - goal), r, fingers)
            goal, rot = straight, fix @ rot
            _hold(sim, goal, rot, fingers, SETTLE_S)

        # 4. lower until the object touches the table, open, retract
        next_stage("place")
        pos = goal.copy()
        max_steps = int(np.ceil((sim.obj_pos()[2] - centre[2] + 0.03) / (LOWER_SPEED_M_S * CONTROL_DT_S)))
        for _ in range(max_steps):
            if sim.touches([scene.table_geom]) or sim.contact(scene.hand_geoms, [scene.table_geom]):
                break
            pos = pos - [0.0, 0.0, LOWER_SPEED_M_S * CONTROL_DT_S]
            sim.step(pos, rot, fingers)
        pos = sim.palm()
        n_open = int(round(OPEN_S / CONTROL_DT_S))
        for s in np.linspace(0.0, 1.0, n_open + 1)[1:]:
            sim.step(pos, rot, closed + s * (open_ - closed))
        _hold(sim, pos, rot, open_, SETTLE_S / 2)
        a = params.approach[0].astype(float)
        back = pos - RETRACT_M * a
        _move(sim, np.stack([pos, back, back + [0.0, 0.0, RETRACT_UP_M]]), rot, rot, open_,
              MOVE_SPEED_M_S / 2)
        _hold(sim, back + [0.0, 0.0, RETRACT_UP_M], rot, open_, SETTLE_S)
        return finish("")
    except BaseException:
        sim.close()
        raise


# ---------------------------------------------------------------- the task-success sweep

SWEEP_OBJECT_XY = (0.0, -0.40)
SWEEP_PLACES = ((0.20, -0.40), (-0.25, -0.35), (0.05, -0.60))


def task_sweep(hands: Sequence[str] = HAND_NAMES, grasps: Sequence[int] = GRASP_CLASSES,
               places: Sequence[tuple[float, float]] = SWEEP_PLACES, tactile: bool = True,
               progress: bool = True) -> list[dict]:
    """Every (hand, grasp class, place): the grasp class's own object alone at `SWEEP_OBJECT_XY`,
    canonical human hand orientation. Returns one dict per task (hand, grasp, place, success,
    failed_stage, place_error_m, upright, released, wall_s). Run it with
    `python -c "from sim.task_controller import *; print(task_table(task_sweep()))"`."""
    rows = []
    for hand in hands:
        for g in grasps:
            for place in places:
                spec = TaskSpec(objects=(g,), object_xy=[SWEEP_OBJECT_XY], target=0, grasp=g, place_xy=place,
                                tactile=tactile, hand=hand)
                t0 = time.perf_counter()
                res = run_task(spec)
                rows.append(dict(hand=hand, grasp=g, place=tuple(place), success=res.success,
                                 failed_stage=res.failed_stage, place_error_m=res.place_error_m,
                                 upright=res.upright, released=res.released, wall_s=time.perf_counter() - t0))
                if progress:
                    r = rows[-1]
                    print(f"{hand:9s} grasp {g:2d} place {place}: {'ok  ' if r['success'] else 'FAIL'} "
                          f"{r['failed_stage']:14s} err {100 * r['place_error_m']:5.1f} cm upright {r['upright']:d} "
                          f"released {r['released']:d}  {r['wall_s']:.1f} s",
                          flush=True)
    return rows


def task_table(rows: list[dict]) -> str:
    """A markdown table of `task_sweep`'s rows: successes per grasp class and hand, the robot preshape,
    the stages that failed."""
    hands = sorted({r["hand"] for r in rows}, key=HAND_NAMES.index)
    lines = ["| grasp | " + " | ".join(hands) + " |", "|---|" + "---|" * len(hands)]
    for g in sorted({r["grasp"] for r in rows}):
        cells = []
        for h in hands:
            sel = [r for r in rows if r["hand"] == h and r["grasp"] == g]
            n_ok = sum(r["success"] for r in sel)
            fails = sorted({r["failed_stage"] for r in sel if not r["success"]})
            note = f" fails: {', '.join(fails)}" if fails else ""
            cells.append(f"{n_ok}/{len(sel)} ({robot_grasp_for(g, h)}){note}")
        lines.append(f"| {g} {GRASP_NAMES[g]} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
