"""The planning half of the robot's task controller (`run_task` runs it): the task (`TaskSpec`), its
options (`TaskOptions`) and their checks, the manipulator scene with the grasp study's sensors
(`task_scene`), the grasp controller jitted for it, the palm's paths (`pose_path`, `approach_points`)
and the arm's tracking IK that follows them (`track_ik`), and the MAP §III plan turned about the vertical
to imitate the human hand and checked for reach (batched IK, then the tracking IK along the task's path)
and collisions at its key poses (`reachable_plan`)."""
from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import jax
import mujoco
import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation, Slerp

from lfd_common import as_array, check_choice, check_int, check_real, quat_to_matrix
from sim._src.grasp_objects import GRASP_CLASSES, GRASP_OBJECTS, check_grasp_class
from sim._src.grasp_strategy import (APPROACH_SPEED_M_S, CONTROL_DT_S, LIFT_SPEED_M_S, MAPPINGS, PlanOptions,
    TrialParams, controller_step, object_extent, plan_trials)
from sim._src.human_grasps import hand_pose_in_world
from sim._src.manipulator import (BASE_POS, DEFAULT_OBJECT_XY, DEFAULT_OBJECTS, HOME_Q, manipulator_qpos,
    manipulator_scene_xml, scene_layout as manipulator_layout)
from sim._src.manipulator_ik import ArmChain, IKResult, arm_chain, forward_kinematics, solve_ik
from sim._src.person_scene import TableSpec
from sim._src.robot_hands import HAND_NAMES, SceneLayout, hand_spec

HOLD_S = 0.3                 # the grasp controller's hold after its lift (its study holds 1 s)
RETRACT_M, RETRACT_UP_M = 0.08, 0.06
ABOVE_M = 0.12               # the approach ends with a vertical descent from this far above the pre-grasp
CLEAR_M = 0.15               # the palm first rises this far from home (its fingers point down at the table)
MOVE_SPEED_M_S = 0.3         # mean palm speed of the free approach and of the retract (min-jerk timing)
CARRY_SPEED_M_S = 0.15       # mean palm speed while carrying
LOWER_SPEED_M_S = 0.05       # palm speed while lowering onto the table
TRACK_ITERATIONS = 10        # DLS steps per control step of the tracking IK
REACH_TOL_M, REACH_TOL_RAD = 5e-3, 0.05  # a key pose counts as reached within these (plan's IK, tracking)
TABLE = TableSpec()
TASK_BACKENDS: tuple[str, ...] = ("native", "mjx-jax")


class TaskSpec(NamedTuple):
    """One pick-and-place task: what stands where, what to pick up with which grasp, where to put it.

    `run_task` checks it (ValueError naming the field).

    Attributes:
        objects: grasp-object classes (`sim.grasping.GRASP_OBJECTS`) standing on the table (K of
            them, as `manipulator_scene_xml`'s `objects`).
        object_xy: (K, 2) where they stand (world m).
        target: index of the object to handle.
        grasp: the human grasp class (1, 2, 4, 9, 10, 12).
        place_xy: (2,) where to put it down (world m).
        hand_rot: (3, 3) the human hand's orientation (world; columns the hand axes of the human hand,
            `sim.hands.hand_body_xml`); None: the grasp's canonical one
            (`sim.hands.hand_pose_in_world`, given in the object's frame) as a person sitting where
            the robot stands would hold it: turned about the vertical so that the canonical side
            approach points from the arm's base to the object.
        tactile: MAP §III's tactile correction for volar grasps.
        hand: "barrett" or "karlsruhe".
    """

    objects: tuple[int, ...] = DEFAULT_OBJECTS
    object_xy: Any = DEFAULT_OBJECT_XY
    target: int = 0
    grasp: int = 1
    place_xy: Any = (0.1, -0.45)
    hand_rot: Any = None
    tactile: bool = True
    hand: str = "barrett"


@dataclass(frozen=True)
class TaskOptions:
    """How `run_task` runs a task: the grasp mapping, the physics backend, and the video it records.

    Fields are checked when the object is made (the camera's name when the task's scene is built).
    Change one with `dataclasses.replace(options, ...)`.

    Attributes:
        mapping: the human-to-robot grasp mapping, "map2009" (MAP Fig. 2) or "iros2008" (GRASP
            Fig. 2, Barrett hand only).
        backend: the physics under the one controller (`TASK_BACKENDS`): "native" (MuJoCo's C
            engine, float64) or "mjx-jax" (MJX's JAX implementation, float32, on the default JAX
            device: one jitted program per control period; MJX-JAX has no cylinder-box collision, so a
            scene with the Pinch cube (class 9) is refused).
        render: record frames of `camera` (EGL by default, `sim.setup_rendering`).
        camera: a camera of the manipulator scene ("front").
        width: frame width (px, in [16, 640]).
        height: frame height (px, in [16, 480]).
        fps: frames per simulated second (in [1, 1 / CONTROL_DT_S]).

    Raises:
        ValueError: a field out of its range or of the wrong type, naming the field.
    """

    mapping: str = "map2009"
    backend: str = "native"
    render: bool = False
    camera: str = "front"
    width: int = 320
    height: int = 240
    fps: float = 20.0

    def __post_init__(self):
        object.__setattr__(self, "mapping", check_choice(self.mapping, "mapping", MAPPINGS))
        object.__setattr__(self, "backend", check_choice(self.backend, "backend", TASK_BACKENDS))
        if not isinstance(self.render, (bool, np.bool_)):
            raise ValueError(f"render: expected a bool, got {self.render!r}")
        object.__setattr__(self, "render", bool(self.render))
        if not isinstance(self.camera, str):
            raise ValueError(f"camera: expected a camera's name, got {self.camera!r}")
        object.__setattr__(self, "width", check_int(self.width, "width", min_value=16, max_value=640))
        object.__setattr__(self, "height", check_int(self.height, "height", min_value=16, max_value=480))
        object.__setattr__(self, "fps", check_real(self.fps, "fps", min_value=1.0, max_value=1.0 / CONTROL_DT_S))


# ---------------------------------------------------------------- the scene with the grasp sensors

def _sensor_xml(links: Sequence[str], n_objects: int) -> str:
    """The grasp scene's sensors (`sim.hands.grasp_model`) for a manipulator scene's objects "object0" ...:
    touch per link site, contact per (link, object), object and palm frames."""
    touch = "".join(f'<touch name="touch_{ln}" site="{ln}"/>' for ln in links)
    contact = "".join(f'<contact name="contact_{ln}_{k}" geom1="{ln}" geom2="object{k}" data="found pos normal" '
                      f'reduce="mindist" num="1"/>' for ln in links for k in range(n_objects))
    frames = "".join(f'<framepos name="pos_object{k}" objtype="body" objname="object{k}"/>'
                     f'<framequat name="quat_object{k}" objtype="body" objname="object{k}"/>' for k in range(n_objects))
    palm = ('<framepos name="pos_palm" objtype="site" objname="palm_centre"/>'
            '<framequat name="quat_palm" objtype="site" objname="palm_centre"/>')
    return f"<sensor>{touch}{contact}{frames}{palm}</sensor>"


class TaskScene(NamedTuple):
    """The manipulator scene of a task with the grasp study's sensors (`task_scene`).

    Attributes:
        model: the compiled scene.
        arm: its `ManipulatorLayout`.
        sensors: the grasp controller's view of the sensors (a `SceneLayout`).
        chain: the arm's kinematic chain to the palm centre.
        robot_geoms: ids of every robot geom (arm and hand).
        hand_geoms: ids of the hand's link geoms (palm first).
        table_geom: id of the table's collision plane.
    """

    model: mujoco.MjModel
    arm: Any              # a ManipulatorLayout
    sensors: SceneLayout  # the grasp controller's view of the sensors
    chain: ArmChain
    robot_geoms: np.ndarray
    hand_geoms: np.ndarray
    table_geom: int


@functools.lru_cache(maxsize=8)
def task_scene(hand: str, objects: tuple[int, ...], object_xy: tuple[tuple[float, float], ...]) -> TaskScene:
    """The manipulator scene of a task, with the grasp study's sensors added (cached, up to 8).

    The sensors are those of the grasp scenes (`sim.hands.grasp_model`): touch per link site, contact
    per (link, object), object and palm frames, so that the grasp controller reads them unchanged.

    Args:
        hand: "barrett" or "karlsruhe".
        objects: grasp classes of the objects on the table.
        object_xy: where they stand (world m), one (x, y) per object.

    Returns:
        The `TaskScene`, shared by callers with the same arguments: do not modify its model.

    Raises:
        ValueError: an unknown hand or grasp class.
    """
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
    return TaskScene(model, arm, sensors, arm_chain(model, "palm_centre"), robot_geoms, hand_geoms,
                     model.geom("table").id)


@functools.lru_cache(maxsize=8)
def grasp_controller(hand: str, n_objects: int):
    """The grasp controller jitted for the sensor layout of a scene with `n_objects` objects (the layout
    depends only on the hand and the number of objects)."""
    layout = task_scene(hand, (GRASP_CLASSES[0],) * n_objects,
                    tuple((0.3 * k, -0.4) for k in range(n_objects))).sensors
    return jax.jit(functools.partial(controller_step, layout=layout))


# ---------------------------------------------------------------- checks at the boundary

def check_spec(spec: TaskSpec) -> TaskSpec:
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


def on_table(xy: np.ndarray, margin: float = 0.03) -> bool:
    x, y = xy
    return (abs(x) <= TABLE.half_width - margin) and (TABLE.far_y + margin <= y <= TABLE.near_y - margin)


# ---------------------------------------------------------------- the palm's paths and the tracking IK

def min_jerk(n: int) -> np.ndarray:
    """(max(n, 1),) the fractions of a min-jerk move reached after each of its n control steps (the last 1)."""
    s = np.linspace(0.0, 1.0, max(n, 1) + 1)[1:]
    return 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5


def polyline(points: np.ndarray, speed: float) -> np.ndarray:
    """(N, 3) positions per control step along the polyline `points` (P, 3) at mean speed `speed`,
    min-jerk in arc length."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    if arc[-1] < 1e-6:
        return points[-1:]
    n = max(int(np.ceil(arc[-1] / speed / CONTROL_DT_S)), 5)
    s = min_jerk(n) * arc[-1]
    return np.stack([np.interp(s, arc, points[:, i]) for i in range(3)], -1)


def pose_path(points: np.ndarray, rot_from: np.ndarray, rot_to: np.ndarray,
              speed: float) -> tuple[np.ndarray, np.ndarray]:
    """The palm's poses per control step of a move along the polyline `points` (P, 3) at mean speed `speed`
    (`polyline`), its rotation slerped from `rot_from` (3, 3) to `rot_to` (3, 3) in as many steps.

    Returns:
        (N, 3) positions and (N, 3, 3) rotations (world), the last ones `points[-1]` and `rot_to`.
    """
    path = polyline(points, speed)
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([rot_from, rot_to])))
    return path, slerp(np.linspace(0.0, 1.0, len(path) + 1)[1:]).as_matrix()


def retarget_path(path: ArrayLike, start: ArrayLike, end: ArrayLike) -> np.ndarray:
    """A demonstrated movement moved onto the robot's own start and end (PHMM synthesis -> robot).

    The path is turned about the vertical so that its horizontal chord points along the robot's,
    shifted to `start`, and what is then left between its end and `end` spread over it in proportion
    to arc length. The vertical profile (the lift over the table) and the sideways bulge relative to
    the chord are kept; the endpoints are the robot's exactly.

    Args:
        path: (T, 3) a demonstrated movement (world m, e.g. a PHMM-synthesised reach).
        start: (3,) the robot's start.
        end: (3,) the robot's end.

    Returns:
        (T, 3) the retargeted path.
    """
    path = np.asarray(path, np.float64)
    start, end = np.asarray(start, np.float64), np.asarray(end, np.float64)
    rel = path - path[0]
    heading = lambda v: np.arctan2(v[1], v[0]) if np.hypot(v[0], v[1]) > 1e-6 else 0.0
    turn = heading(end - start) - heading(rel[-1])
    c, s = np.cos(turn), np.sin(turn)
    turned = rel @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    frac = arc / arc[-1] if arc[-1] > 1e-9 else np.linspace(0.0, 1.0, len(path))
    return start + turned + frac[:, None] * (end - start - turned[-1])


def approach_points(home_pos: np.ndarray, above: np.ndarray, path: np.ndarray | None) -> np.ndarray:
    """(P, 3) the approach's polyline: the palm at home (3,), `CLEAR_M` above it, the demonstrated reach
    `path` (T, 3) retargeted between there and `above` (3,) (`retarget_path`; None: a straight line), `above`."""
    clear = home_pos + [0.0, 0.0, CLEAR_M]
    middle = [retarget_path(path, clear, above)[1:-1]] if path is not None else []
    return np.concatenate([home_pos[None], clear[None], *middle, above[None]])


def track_ik(chain: ArmChain, q: np.ndarray, pos: np.ndarray, rot: np.ndarray) -> IKResult:
    """One control step of the arm's tracking IK: `TRACK_ITERATIONS` damped-least-squares steps from the
    last target q (B, K), one start (`solve_ik`), towards the palm poses pos (B, 3), rot (B, 3, 3).

    Returns:
        The `IKResult` (`reachable`: within `REACH_TOL_M` and `REACH_TOL_RAD`).
    """
    return solve_ik(chain, pos, rot, q, pos_tol=REACH_TOL_M, rot_tol=REACH_TOL_RAD, n_restarts=1, rounds=1,
                    iterations=TRACK_ITERATIONS)


# ---------------------------------------------------------------- planning

def _rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


YAW_STEPS_DEG = (0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0)
# downward tilts of the approach (`plan_trials`' tilts_deg), tried at every yaw after the plan's own (0):
# near the arm's base a level side approach to a short object puts the wrist into the table, and the forearm
# over a neighbour; on the imitation study's validation demonstrations (each of its own seed), Abducted Thumb
# tasks were reachable 4 / 14 level, 13 / 14 with these
TILT_STEPS_DEG = (0.0, 15.0, 30.0)


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


class TaskPlan(NamedTuple):
    params: TrialParams     # world frame, B = 1
    rot: np.ndarray         # (3, 3) palm rotation (world)
    grasp_palm: np.ndarray  # (3,) where the palm is expected to close (world)
    obj_centre: np.ndarray  # (3,) the object's centre (world)
    yaw_deg: float          # the plan's turn away from the preferred yaw
    tilt_deg: float         # the approach's downward tilt (`TILT_STEPS_DEG`)


def _plan(spec: TaskSpec, params: TrialParams, psi: float, yaw_deg: float, tilt_deg: float) -> TaskPlan:
    """`plan_trials`' plan (object frame, B = 1, tilted by `tilt_deg`) turned by `psi` about the vertical
    and put on the object."""
    turn = _rot_z(psi)
    obj = GRASP_OBJECTS[spec.objects[spec.target]]
    ox, oy = spec.object_xy[spec.target]
    shift = np.array([ox, oy, TABLE.top_z])   # the plan is made for the handled object (`plan_trials` objects)
    goal = params.goal[0] @ turn.T + shift
    start = params.start[0] @ turn.T + shift
    approach = turn @ params.approach[0]
    rot = turn @ Rotation.from_euler("ZXY", params.wrist[0]).as_matrix()
    # the palm stops at the standoff (open-loop) or at about the object's surface (volar)
    standoff = params.standoff[0] if not params.volar[0] else float(object_extent(spec.objects[spec.target], approach))
    world = params._replace(goal=goal[None].astype(np.float32), start=start[None].astype(np.float32),
                            approach=approach[None].astype(np.float32),
                            obj=np.array([spec.target], np.int32))
    centre = np.array([ox, oy, TABLE.top_z + obj.rest_height_m])
    return TaskPlan(world, rot, goal - standoff * approach, centre, yaw_deg, tilt_deg)


def reachable_plan(spec: TaskSpec, scene: TaskScene, seed: int, mapping: str,
                   approach_path: np.ndarray | None = None) -> tuple[TaskPlan, bool]:
    """The plan of the first (tilt, yaw) in `TILT_STEPS_DEG` x `YAW_STEPS_DEG` (turns from the preferred
    yaw; the level approach at every yaw first) whose key poses (`key_poses`) the arm reaches (one batched
    IK call for all) without touching another object, or the table with anything but the hand
    (`collides`), and whose path the arm's tracking IK follows through all of them (`path_tracks`, along
    `approach_path` (T, 3) or a straight approach); else the first clean one whose path does not track;
    and whether there is a clean one (else the level, preferred one)."""
    n_tilt = len(TILT_STEPS_DEG)
    params, _ = plan_trials(spec.hand, [spec.grasp] * n_tilt, np.zeros((n_tilt, 2)), TILT_STEPS_DEG,
                            [spec.tactile] * n_tilt, [seed] * n_tilt, objects=[spec.objects[spec.target]] * n_tilt,
                            options=PlanOptions(mapping=mapping, hold_s=HOLD_S))
    psi0 = _preferred_yaw(spec.grasp, spec.hand_rot, spec.object_xy[spec.target])
    plans = [_plan(spec, jax.tree.map(lambda a, i=i: a[i:i + 1], params), psi0 + np.radians(d), d, t)
             for i, t in enumerate(TILT_STEPS_DEG) for d in YAW_STEPS_DEG]
    poses = np.stack([key_poses(p, spec.place_xy) for p in plans])          # (tilts x yaws, P, 3)
    n_plan, n_pose = poses.shape[:2]
    rots = np.repeat(np.stack([p.rot for p in plans]), n_pose, axis=0)
    ik = solve_ik(scene.chain, poses.reshape(-1, 3), rots, np.tile(HOME_Q, (n_plan * n_pose, 1)), pos_tol=REACH_TOL_M,
                  rot_tol=REACH_TOL_RAD)
    ok = np.asarray(ik.reachable).reshape(n_plan, n_pose).all(1)
    q = np.asarray(ik.q, float).reshape(n_plan, n_pose, -1)
    clean = [k for k in np.flatnonzero(ok) if not collides(scene, spec.target, q[k], plans[k].params)]
    if not clean:
        return plans[0], False
    # each key pose alone can be reachable where the controller's tracking IK, warm-started along the
    # path, stops at a wrist limit (carrying, 6 cm short of the place): such a plan only as a last resort
    tracked = next((k for k in clean if path_tracks(scene.chain, plans[k], spec.place_xy, approach_path)), clean[0])
    return plans[tracked], True


def collides(scene: TaskScene, target: int, q: np.ndarray, params: TrialParams) -> bool:
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


def key_poses(plan: TaskPlan, place_xy: np.ndarray) -> np.ndarray:
    """(7, 3) palm positions to check: above the pre-grasp, pre-grasp, grasp, lift, above the place, at
    the place, retract."""
    a = plan.params.approach[0].astype(float)
    lift = plan.grasp_palm + [0.0, 0.0, 0.10]
    carry = lift + np.append(place_xy - plan.obj_centre[:2], 0.0)
    placed = carry - [0.0, 0.0, 0.10]
    retract = placed - RETRACT_M * a + [0.0, 0.0, RETRACT_UP_M]
    pre = plan.params.start[0]
    return np.stack([pre + [0.0, 0.0, ABOVE_M], pre, plan.grasp_palm, lift, carry, placed, retract])


def path_tracks(chain: ArmChain, plan: TaskPlan, place_xy: np.ndarray, approach_path: np.ndarray | None) -> bool:
    """Whether the tracking IK (`track_ik`, no physics), from `HOME_Q` along the task's nominal palm path
    through the plan's key poses (`key_poses`) at the controller's speeds, reaches each of them.

    The path: the approach (`approach_points`, the orientation slerped from home's to the plan's), the
    descent onto the pre-grasp pose, the grasp controller's approach and lift, the carry, the lowering,
    the retract. Each key pose alone can be reachable where the tracking stops at a joint limit on the way
    (the arm arrives on another wrist branch than the pose needs).

    Args:
        chain: the arm's chain.
        plan: the plan.
        place_xy: (2,) the place (world m).
        approach_path: (T, 3) the demonstrated reach (`run_task`'s `approach_path`), or None.

    Returns:
        True if every key pose is reached within `REACH_TOL_M` and `REACH_TOL_RAD`.
    """
    above, pre, grasp, lift, carry, placed, retract = key_poses(plan, place_xy)
    home_pos, home_rot = (np.asarray(a, float) for a in forward_kinematics(chain, HOME_Q))
    rot = plan.rot
    legs = [(approach_points(home_pos, above, approach_path), home_rot, MOVE_SPEED_M_S),
            (np.stack([above, pre]), rot, MOVE_SPEED_M_S / 2), (np.stack([pre, grasp]), rot, APPROACH_SPEED_M_S),
            (np.stack([grasp, lift]), rot, LIFT_SPEED_M_S), (np.stack([lift, carry]), rot, CARRY_SPEED_M_S),
            (np.stack([carry, placed]), rot, LOWER_SPEED_M_S), (np.stack([placed, retract]), rot, MOVE_SPEED_M_S / 2)]
    q = HOME_Q[None].astype(float)
    for points, rot_from, speed in legs:
        for p, r in zip(*pose_path(points, rot_from, rot, speed)):
            ik = track_ik(chain, q, p[None], r[None])
            q = np.asarray(ik.q, float)
        if not bool(ik.reachable[0]):
            return False
    return True
