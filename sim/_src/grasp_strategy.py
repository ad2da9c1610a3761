"""The grasp strategy of MAP §III: robot preshape and hand pose from the human grasp, and the grasp controller.

Planning (numpy, at the boundary): `plan_trials` turns (hand, human grasp class, perturbation, seed)
into `TrialParams`, one row per trial. The robot imitates the human hand's orientation relative to the
object (`sim.hands.hand_pose_in_world`): its palm normal is the human's (the approach direction), its
wrap axis the human's thumb axis. Volar grasps (Large and Small Diameter) approach from the top if the
human palm is about parallel to the table (normal within 30 degrees of vertical), else from the side,
horizontally, towards the estimated object centroid. Non-volar grasps approach open-loop to a
predefined distance: where the closing fingertips reach the object (`contact_depth`), but with the
palm at most `PALM_GAP_M` from the object's surface; from the top, no closer than where the open
fingertip sites (the centres of the capsule ends) are `TIP_CLEARANCE_M` above the table: long fingers
then rest lightly on the table and close along it onto a low object's sides, instead of landing on the
object (clearing the table by the whole capsule radius made the Barrett's cube and disc grasps worse).

Control (JAX, jittable, vectorised over trials B): `controller_step(state, sensordata, params, layout)`
-> (state, ctrl) is one pure function, a state machine with phases APPROACH, RETRACT, CLOSE, LIFT, HOLD,
DONE. A link touches the object when its touch sensor exceeds `TOUCH_THRESHOLD_N` and its contact
sensor with the object fires (peaks over the control period, see `sim.grasping.peak_touch`).
Volar grasps stop at the first touch; if it is not on the palm and tactile correction is on, the hand
retracts straight back and replans with p_new = alpha c + (1 - alpha) p_old, alpha <- alpha^2 (c: the
mean position of the touching links' contacts), at most `MAX_CORRECTIONS` times; every approach first
moves sideways onto the line through the goal, then along it, slowing down near the target. Volar
approaches move slowly all the way: their open fingers reach far ahead of the palm, and the hand starts
with the fingertips `START_CLEARANCE_M` from the object, so under a position error a fingertip may
strike the object from the first step on; at full speed that strike topples a thin cylinder before
the correction can act (`experiments.validation.tactile_correction` logs it). Then the fingers close,
the hand lifts 10 cm and holds for 1 s. No Python branching on data: every transition is a `where`.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from lfd_common import as_array, check_choice, check_real, quat_to_matrix
from sim._src.grasp_objects import (GRASP_CLASSES, GRASP_OBJECTS, VOLAR_GRASPS, check_grasp_class,
    robot_grasp_for)
from sim._src.human_grasps import hand_pose_in_world
from sim._src.robot_hands import SceneLayout, grasp_model, hand_joint_qpos, hand_spec, preshape

APPROACH, RETRACT, CLOSE, LIFT, HOLD, DONE = range(6)
PHASE_NAMES = ("approach", "retract", "close", "lift", "hold", "done")
CONTROL_DT_S = 0.02            # one control step = 10 physics steps of 2 ms
APPROACH_SPEED_M_S = 0.25
SLOW_SPEED_M_S, SLOW_ZONE_M = 0.08, 0.07  # slower within this distance of the approach target (volar: always)
START_CLEARANCE_M = 0.02       # the open fingertips start this far from the object's surface
RETRACT_M = 0.05
TOUCH_THRESHOLD_N = 0.05
ALPHA0 = 0.7
MAX_CORRECTIONS = 2
APPROACH_TIMEOUT_S = 2.5       # per approach leg (a slow volar one takes up to 2.3 s): then close where it is
CLOSE_S, SETTLE_S = 0.8, 0.3    # a slow close: a fast one flicks light objects away
LIFT_M, LIFT_SPEED_M_S = 0.10, 0.2
HOLD_S = 1.0
HORIZON_S = 8.0                # enough for two slow corrections; `n_control_steps()` control steps
TOP_APPROACH_MAX_DEG = 30.0
PALM_GAP_M = 0.02              # open-loop approaches stop at most this far from the object's surface
TIP_CLEARANCE_M = 0.005        # ... and, from the top, with the open fingertip sites this far above the table


def n_control_steps() -> int:
    """The number of control steps of one trial.

    Returns:
        `HORIZON_S / CONTROL_DT_S`, rounded: enough for two slow tactile corrections (MAP §III).
    """
    return int(round(HORIZON_S / CONTROL_DT_S))


class TrialParams(NamedTuple):
    """The plan of B grasp trials (MAP §III), one row per trial (numpy or jax arrays); D hand DoF.

    Made by `plan_trials`; read by `controller_step` and `rollout_grasps`.

    Attributes:
        goal: (B, 3) the estimated object centroid (the planned goal, world).
        approach: (B, 3) unit approach direction (the hand's z axis).
        wrist: (B, 3) wrist hinge angles (Rz Rx Ry, rad).
        start: (B, 3) where the palm centre starts.
        standoff: (B,) palm-to-goal distance at which an open-loop approach stops (0 for volar grasps:
            approach until contact).
        volar: (B,) bool: a volar grasp (the palm is expected to touch first).
        tactile: (B,) bool: tactile correction on.
        open_: (B, D) open hand targets.
        closed: (B, D) closed hand targets.
        obj: (B,) int: index of the active object in `GRASP_CLASSES`.
        hold_s: (B,) how long the lifted object is held (s; `HOLD_S` in the study).
    """

    goal: np.ndarray
    approach: np.ndarray
    wrist: np.ndarray
    start: np.ndarray
    standoff: np.ndarray
    volar: np.ndarray
    tactile: np.ndarray
    open_: np.ndarray
    closed: np.ndarray
    obj: np.ndarray
    hold_s: np.ndarray


class ControllerState(NamedTuple):
    """The grasp controller's state for B trials (jax arrays); L hand links.

    Attributes:
        phase: (B,) int: APPROACH, RETRACT, CLOSE, LIFT, HOLD or DONE.
        t: (B,) seconds in the phase.
        cmd: (B, 3) commanded palm position.
        goal: (B, 3) current goal.
        alpha: (B,) the weight of the next tactile correction (MAP §III).
        n_corr: (B,) corrections made.
        retract_to: (B, 3) where a retract ends.
        touched: (B,) bool: a first contact happened.
        palm_first: (B,) bool: it was on the palm.
        first_link: (B,) int: link of the first contact (-1: none).
        grasp_contacts: (B, L, 7) found, position (3), normal (3) in the object frame at the end of
            closing.
        lift_z: (B,) palm height when lifting began.
        hold_obj: (B, 3) the object's centre in the palm frame when holding began.
        slip_m: (B,) its displacement at the end of the hold.
        end_obj: (B, 3) the object's position (world) at the end of the hold.
    """

    phase: jax.Array
    t: jax.Array
    cmd: jax.Array
    goal: jax.Array
    alpha: jax.Array
    n_corr: jax.Array
    retract_to: jax.Array
    touched: jax.Array
    palm_first: jax.Array
    first_link: jax.Array
    grasp_contacts: jax.Array
    lift_z: jax.Array
    hold_obj: jax.Array
    slip_m: jax.Array
    end_obj: jax.Array


def initial_state(params: TrialParams, n_links: int) -> ControllerState:
    """The controller state at the start of the trials: APPROACH, the palm commanded at `params.start`.

    Args:
        params: the plan of B trials (`plan_trials`).
        n_links: L, the number of hand links (palm first) whose contacts are recorded.

    Returns:
        The `ControllerState` of B rows, alpha at `ALPHA0`, no contact yet.
    """
    b = params.goal.shape[0]
    start = jnp.asarray(params.start, jnp.float32)
    return ControllerState(
        phase=jnp.zeros(b, jnp.int32), t=jnp.zeros(b), cmd=start, goal=jnp.asarray(params.goal, jnp.float32),
        alpha=jnp.full(b, ALPHA0), n_corr=jnp.zeros(b, jnp.int32), retract_to=start,
        touched=jnp.zeros(b, bool), palm_first=jnp.zeros(b, bool), first_link=jnp.full(b, -1, jnp.int32),
        grasp_contacts=jnp.zeros((b, n_links, 7)), lift_z=jnp.zeros(b), hold_obj=jnp.zeros((b, 3)),
        slip_m=jnp.zeros(b), end_obj=jnp.zeros((b, 3)))


def _move_towards(cmd: jax.Array, target: jax.Array, step) -> tuple[jax.Array, jax.Array]:
    """Move (B, 3) `cmd` at most `step` (scalar or (B, 1)) towards `target`; also return whether it
    arrived (B,)."""
    delta = target - cmd
    dist = jnp.linalg.norm(delta, axis=-1, keepdims=True)
    scale = jnp.minimum(1.0, step / jnp.maximum(dist, 1e-9))
    return cmd + delta * scale, (dist <= step)[..., 0]


def read_sensors(sensordata: jax.Array, obj: jax.Array, layout: SceneLayout):
    """Split (B, S) sensordata: touch (B, L), contacts with the active object (B, L, 7), object position
    (B, 3) and rotation (B, 3, 3), palm position (B, 3) and rotation (B, 3, 3)."""
    touch = sensordata[:, layout.touch]
    adr = jnp.asarray(layout.contact)[:, obj].T                      # (B, L)
    contacts = jnp.take_along_axis(sensordata[:, None, :], adr[..., None] + jnp.arange(7), axis=-1)
    pos_adr = jnp.asarray(layout.object_pos)[obj][:, None] + jnp.arange(3)
    quat_adr = jnp.asarray(layout.object_quat)[obj][:, None] + jnp.arange(4)
    obj_pos = jnp.take_along_axis(sensordata, pos_adr, axis=-1)
    obj_rot = quat_to_matrix(jnp.take_along_axis(sensordata, quat_adr, axis=-1))
    palm_pos = sensordata[:, layout.palm_pos:layout.palm_pos + 3]
    palm_rot = quat_to_matrix(sensordata[:, layout.palm_quat:layout.palm_quat + 4])
    return touch, contacts, obj_pos, obj_rot, palm_pos, palm_rot


def controller_step(state: ControllerState, sensordata: jax.Array, params: TrialParams,
                    layout: SceneLayout) -> tuple[ControllerState, jax.Array]:
    """One control step of the MAP §III grasp strategy for B trials (pure, jittable).

    The state machine of the module docstring: approach (sideways onto the line through the goal, then
    along it), stop at the first touch, tactile correction by retract and replan, close, lift, hold.

    Args:
        state: the controller state (`initial_state`, then this function's output).
        sensordata: (B, S) sensor readings of the grasp scene (`peak_touch` of the control period).
        params: the plan of the B trials (`plan_trials`).
        layout: where the sensors are in `sensordata` (the scene's layout, from `grasp_model`).

    Returns:
        (new state, ctrl (B, U)), ctrl = [palm position command (3), wrist hinge angles (3), hand DoF
            targets (D)].
    """
    dt = CONTROL_DT_S
    touch, contacts, obj_pos, obj_rot, palm_pos, palm_rot = read_sensors(sensordata, params.obj, layout)
    a = jnp.asarray(params.approach, jnp.float32)
    phase, t = state.phase, state.t + dt
    # a link touches the object when its tactile sensor and its contact with the object both fire
    # (touches of the table are not a contact with the object to grasp)
    touching = (touch > TOUCH_THRESHOLD_N) & (contacts[..., 0] > 0)             # (B, L)
    any_touch = touching.any(-1)
    palm_touch = touching[:, 0]

    # APPROACH: onto the line through the goal along a first (sideways), then along it to goal - standoff * a
    target = state.goal - params.standoff[:, None] * a
    to_target = target - state.cmd
    lateral = to_target - jnp.sum(to_target * a, -1, keepdims=True) * a
    aligned = jnp.linalg.norm(lateral, axis=-1, keepdims=True) < 0.002
    waypoint = jnp.where(aligned, target, state.cmd + lateral)
    volar = jnp.asarray(params.volar)
    fast = (jnp.linalg.norm(to_target, axis=-1) > SLOW_ZONE_M) & ~volar
    cmd_app, arrived = _move_towards(state.cmd, waypoint,
                                     jnp.where(fast, APPROACH_SPEED_M_S, SLOW_SPEED_M_S)[:, None] * dt)
    arrived = arrived & aligned[:, 0]
    in_app = phase == APPROACH
    tactile = jnp.asarray(params.tactile)
    first_now = in_app & any_touch & ~state.touched
    first_link = jnp.where(first_now, jnp.argmax(touching, axis=-1), state.first_link)
    palm_first = jnp.where(first_now, palm_touch, state.palm_first)
    touched = state.touched | (in_app & any_touch)
    stop_volar = in_app & volar & any_touch
    correct = stop_volar & ~palm_touch & tactile & (state.n_corr < MAX_CORRECTIONS)
    timeout = in_app & (t > APPROACH_TIMEOUT_S)
    close_now = (stop_volar & ~correct) | (in_app & ~volar & arrived) | (in_app & timeout & ~correct)
    # the tactile correction: c = mean contact position of the touching links (palm excluded)
    w = (touching & jnp.any(contacts[..., 1:4] != 0, -1)).astype(jnp.float32)  # positions of this substep
    c = (w[..., None] * contacts[..., 1:4]).sum(1) / jnp.maximum(w.sum(1), 1.0)[:, None]
    c = jnp.where(w.sum(1, keepdims=True) > 0, c, state.goal)
    goal = jnp.where(correct[:, None], state.alpha[:, None] * c + (1 - state.alpha[:, None]) * state.goal,
                     state.goal)
    alpha = jnp.where(correct, state.alpha ** 2, state.alpha)
    n_corr = state.n_corr + correct.astype(jnp.int32)
    retract_to = jnp.where(correct[:, None], palm_pos - RETRACT_M * a, state.retract_to)

    # RETRACT: straight back along -a; the next approach first moves sideways onto the new line
    cmd_ret, ret_done = _move_towards(state.cmd, state.retract_to, APPROACH_SPEED_M_S * dt)
    in_ret = phase == RETRACT

    # CLOSE: interpolate the fingers, hold the wrist where the palm is
    in_close = phase == CLOSE
    close_done = in_close & (t > CLOSE_S + SETTLE_S)
    frac = jnp.where(in_close, jnp.clip(t / CLOSE_S, 0.0, 1.0), (phase > CLOSE).astype(jnp.float32))
    fingers = params.open_ + frac[:, None] * (params.closed - params.open_)

    # object in the palm frame and contact records in the object frame
    obj_in_palm = jnp.einsum("bji,bj->bi", palm_rot, obj_pos - palm_pos)
    rel = contacts[..., 1:4] - obj_pos[:, None]
    c_pos = jnp.einsum("bji,blj->bli", obj_rot, rel)
    c_nrm = -jnp.einsum("bji,blj->bli", obj_rot, contacts[..., 4:7])  # out of the object, towards the hand
    record = jnp.concatenate([(contacts[..., :1] > 0).astype(jnp.float32), c_pos, c_nrm], -1)
    grasp_contacts = jnp.where(close_done[:, None, None], record, state.grasp_contacts)

    # LIFT then HOLD
    in_lift = phase == LIFT
    lift_z = jnp.where(close_done, state.cmd[:, 2], state.lift_z)
    lift_done = in_lift & (t > LIFT_M / LIFT_SPEED_M_S + 0.1)
    hold_obj = jnp.where(lift_done[:, None], obj_in_palm, state.hold_obj)
    in_hold = phase == HOLD
    hold_done = in_hold & (t > params.hold_s)
    slip = jnp.where(hold_done, jnp.linalg.norm(obj_in_palm - state.hold_obj, axis=-1), state.slip_m)
    end_obj = jnp.where(hold_done[:, None], obj_pos, state.end_obj)

    cmd = jnp.where(in_app[:, None], cmd_app, state.cmd)
    cmd = jnp.where(in_ret[:, None], cmd_ret, cmd)
    cmd = jnp.where((close_now | correct)[:, None], palm_pos, cmd)   # stop pushing at the touch
    lift_cmd = jnp.concatenate([state.cmd[:, :2],
                                (state.lift_z + jnp.minimum(t * LIFT_SPEED_M_S, LIFT_M))[:, None]], -1)
    cmd = jnp.where(in_lift[:, None], lift_cmd, cmd)

    new_phase = jnp.select(
        [correct, close_now, in_ret & ret_done, close_done, lift_done, hold_done],
        [jnp.full_like(phase, RETRACT), jnp.full_like(phase, CLOSE), jnp.full_like(phase, APPROACH),
         jnp.full_like(phase, LIFT), jnp.full_like(phase, HOLD), jnp.full_like(phase, DONE)], phase)
    t = jnp.where(new_phase != phase, 0.0, t)
    new = ControllerState(new_phase, t, cmd, goal, alpha, n_corr, retract_to, touched, palm_first, first_link,
                          grasp_contacts, lift_z, hold_obj, slip, end_obj)
    ctrl = jnp.concatenate([cmd, jnp.asarray(params.wrist, jnp.float32), fingers], -1)
    return new, ctrl


# ---------------------------------------------------------------- planning (numpy, at the boundary)

def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def human_hand_frame(grasp: int) -> tuple[np.ndarray, np.ndarray]:
    """(approach (3,), wrap axis (3,)) the human hand implies, in the object frame (object upright).

    The approach is the human palm normal (palm faces the hand frame's -z), made horizontal for a side
    approach or vertical for a top approach (MAP §III); the wrap axis is the human thumb axis (+y),
    made perpendicular to the approach.
    """
    _, quat = hand_pose_in_world(grasp)
    rot = Rotation.from_quat(quat, scalar_first=True).as_matrix()
    normal, thumb = -rot[:, 2], rot[:, 1]
    top = normal[2] < -np.cos(np.radians(TOP_APPROACH_MAX_DEG))
    approach = np.array([0.0, 0.0, -1.0]) if top else _unit(np.array([normal[0], normal[1], 0.0]))
    axis = np.array([0.0, 0.0, 1.0]) if not top else thumb
    axis = _unit(axis - approach * (axis @ approach))
    return approach, axis


def wrist_angles(rot: np.ndarray) -> np.ndarray:
    """(B, 3, 3) hand rotations -> (B, 3) wrist hinge angles of R = Rz(a) Rx(b) Ry(c)."""
    return Rotation.from_matrix(rot).as_euler("ZXY")


@functools.lru_cache(maxsize=None)
def fingertip_sweep(hand: str, robot_grasp: str, n: int = 41) -> np.ndarray:
    """(n, F, 3) fingertip positions in the hand frame while the hand closes from the open to the closed
    preshape of `robot_grasp` (forward kinematics at n evenly spaced closures)."""
    model, layout = grasp_model(hand)
    data = mujoco.MjData(model)
    open_, closed = preshape(hand, robot_grasp)
    tips = []
    for closure in np.linspace(0.0, 1.0, n):
        data.qpos[:] = hand_joint_qpos(model, hand, open_ + closure * (closed - open_))
        data.qpos[layout.wrist_qpos] = 0.0
        mujoco.mj_kinematics(model, data)
        tips.append(data.site_xpos[layout.fingertip_site].copy())
    return np.stack(tips)


def contact_depth(hand: str, robot_grasp: str, half_width: float) -> float:
    """Depth along the palm normal (m) at which the closing fingertips of `robot_grasp` first come within
    `half_width` (+ finger radius) of the approach axis, on average: the open-loop standoff that puts the
    object's centre where the fingertips close on it (MAP §III's "predefined distance")."""
    tips = fingertip_sweep(hand, robot_grasp)
    radial = np.linalg.norm(tips[..., :2], axis=-1).mean(-1)           # (n,)
    reach = half_width + max(f.radius for f in hand_spec(hand).fingers)
    k = int(np.argmax(radial <= reach)) if np.any(radial <= reach) else len(radial) - 1
    return float(tips[k, :, 2].mean())


def object_extent(grasp: int, direction: np.ndarray) -> np.ndarray:
    """Half-extent of a grasp object along unit directions, the object upright.

    Args:
        grasp: the grasp class whose object (`GRASP_OBJECTS`) is measured.
        direction: (..., 3) unit directions.

    Returns:
        (...) half-extents in metres, the support function of the cylinder, sphere or box.
    """
    obj = GRASP_OBJECTS[grasp]
    d = np.abs(np.asarray(direction, float))
    if obj.geom_type == "sphere":
        return np.full(d.shape[:-1], obj.size[0])
    if obj.geom_type == "box":
        return d @ np.asarray(obj.size)
    radius, half = obj.size
    return radius * np.hypot(d[..., 0], d[..., 1]) + half * d[..., 2]


def _seeded_normal(seeds: np.ndarray, stream: int, shape: tuple[int, ...]) -> np.ndarray:
    """Standard normal draws (B, *shape), a deterministic function of each trial's own seed."""
    keys = jax.vmap(lambda s: jax.random.fold_in(jax.random.key(s), stream))(jnp.asarray(seeds, jnp.uint32))
    return np.asarray(jax.vmap(lambda k: jax.random.normal(k, shape))(keys), np.float64)


MAPPINGS: tuple[str, ...] = ("map2009", "iros2008")


@dataclass(frozen=True)
class PlanOptions:
    """How `plan_trials` plans: the grasp mapping, the hand-pose noise and the hold time.

    Fields are checked when the object is made. Change one with `dataclasses.replace(options, ...)`.

    Attributes:
        mapping: the human-to-robot grasp mapping, "map2009" (MAP Fig. 2) or "iros2008" (GRASP
            Fig. 2, Barrett hand only).
        pos_noise_m: hand-position noise, Gaussian per axis (m, in [0, 0.05]).
        rot_noise_deg: hand-rotation noise, Gaussian per axis (degrees, in [0, 20]).
        hold_s: how long the lifted object is held (s, in [CONTROL_DT_S, HOLD_S]; shorter only to make
            a test cheaper).

    Raises:
        ValueError: a field out of its range or of the wrong type, naming the field.
    """

    mapping: str = "map2009"
    pos_noise_m: float = 0.003
    rot_noise_deg: float = 2.0
    hold_s: float = HOLD_S

    def __post_init__(self):
        object.__setattr__(self, "mapping", check_choice(self.mapping, "mapping", MAPPINGS))
        object.__setattr__(self, "pos_noise_m", check_real(self.pos_noise_m, "pos_noise_m", min_value=0.0,
                                                           max_value=0.05))
        object.__setattr__(self, "rot_noise_deg", check_real(self.rot_noise_deg, "rot_noise_deg", min_value=0.0,
                                                             max_value=20.0))
        object.__setattr__(self, "hold_s", check_real(self.hold_s, "hold_s", min_value=CONTROL_DT_S,
                                                      max_value=HOLD_S))


def plan_trials(hand: str, grasps: ArrayLike, offsets: ArrayLike, tilts_deg: ArrayLike, tactile: ArrayLike,
                seeds: ArrayLike, objects: ArrayLike | None = None,
                options: PlanOptions = PlanOptions()) -> tuple[TrialParams, np.ndarray]:
    """Plan B grasp trials of `hand` with the MAP §III grasp strategy, one per row of the arrays.

    The preshape and the approach come from the grasp class (the mapping table and the human hand's
    orientation); the stand-off, the stop and the centre height from the handled object's geometry
    (MAP §III's "predefined distance" is from the object). The plan is made in the object's frame,
    the object upright at the origin.

    Args:
        hand: "barrett" or "karlsruhe".
        grasps: (B,) human grasp classes (`GRASP_CLASSES`).
        offsets: (B, 2) true object position minus the estimate, on the table (m, |offset| <= 0.2).
        tilts_deg: (B,) orientation error of the estimate (degrees, |.| <= 90): the planned hand pose
            is rotated by it about a horizontal axis through the object centre (for a side approach
            the approach tilts downwards).
        tactile: (B,) bool: tactile correction on.
        seeds: (B,) int >= 0: each trial's hand-pose noise (`options.pos_noise_m`,
            `options.rot_noise_deg`) is a deterministic function of its own seed.
        objects: (B,) the grasp class whose object (`GRASP_OBJECTS`) each trial handles; None: its
            own grasp's.
        options: the mapping, the noise levels and the hold time (`PlanOptions`).

    Returns:
        A tuple (params, object_start) of the `TrialParams` and the (B, 3) positions where each trial's object
            really stands (the offset applied, at its resting height).

    Raises:
        ValueError: an unknown hand, grasp class or object class, an array of the wrong shape or out
            of range, or `options` not a `PlanOptions`, naming the argument.
    """
    if not isinstance(options, PlanOptions):
        raise ValueError(f"options: expected a PlanOptions, got {type(options).__name__}")
    spec = hand_spec(hand)
    mapping, pos_noise_m, rot_noise_deg, hold_s = (options.mapping, options.pos_noise_m, options.rot_noise_deg,
                                                   options.hold_s)
    grasps = as_array(grasps, "grasps", ndim=1, dtype=np.int64)
    b = grasps.shape[0]
    objects = grasps if objects is None else as_array(objects, "objects", shape=(b,), dtype=np.int64)
    for name, values in (("grasps", grasps), ("objects", objects)):
        for g in np.unique(values):  # the distinct classes, not the trials
            check_grasp_class(int(g), name)
    offsets = as_array(offsets, "offsets", shape=(b, 2), min_value=-0.2, max_value=0.2)
    tilts = as_array(tilts_deg, "tilts_deg", shape=(b,), min_value=-90.0, max_value=90.0)
    tactile = as_array(tactile, "tactile", shape=(b,), dtype=bool)
    seeds = as_array(seeds, "seeds", shape=(b,), dtype=np.int64, min_value=0)

    # per grasp class (6 rows, `GRASP_CLASSES` order), then gathered per trial
    frames = [human_hand_frame(g) for g in GRASP_CLASSES]
    robots = [robot_grasp_for(g, spec.name, mapping) for g in GRASP_CLASSES]
    shapes = np.array([preshape(spec.name, r) for r in robots])                    # (6, 2, D)
    volar_cls = np.isin(GRASP_CLASSES, list(VOLAR_GRASPS))
    reach_cls = np.array([fingertip_sweep(spec.name, r)[0, :, 2].max() for r in robots])
    top_cls = np.array([a[2] < -np.cos(np.radians(TOP_APPROACH_MAX_DEG)) for a, _ in frames])
    cls = np.searchsorted(GRASP_CLASSES, grasps)                                 # (B,)
    obj = np.searchsorted(GRASP_CLASSES, objects)                                # (B,)

    def standoff_of(c: int, o: int) -> float:  # the palm's from the centre of object o grasped with class c
        (a, x), g = frames[c], GRASP_CLASSES[o]
        if volar_cls[c]:
            return 0.0
        extent = float(object_extent(g, a))
        depth = contact_depth(spec.name, robots[c], float(object_extent(g, np.cross(a, x))))
        table = reach_cls[c] - GRASP_OBJECTS[g].rest_height_m + TIP_CLEARANCE_M if top_cls[c] else 0.0
        return max(float(np.clip(depth, extent + 0.01, extent + PALM_GAP_M)), table)

    pairs = {pair: standoff_of(*pair) for pair in set(zip(cls.tolist(), obj.tolist()))}
    approach = np.stack([a for a, _ in frames])[cls]
    axis = np.stack([x for _, x in frames])[cls]
    # orientation error: rotate the planned pose about k = a x z (side) or the wrap axis (top)
    side = np.abs(approach[:, 2]) < 0.5
    k = np.where(side[:, None], np.cross(approach, [0.0, 0.0, 1.0]), axis)
    k = _unit(k) * np.where(side, -1.0, np.where(seeds % 2 == 0, 1.0, -1.0))[:, None]
    r_err = Rotation.from_rotvec(k * np.radians(tilts)[:, None]).as_matrix()
    noise = Rotation.from_rotvec(np.radians(rot_noise_deg) * _seeded_normal(seeds, 1, (3,))).as_matrix()
    rot = np.stack([_unit(axis), np.cross(approach, axis), approach], -1)      # columns x, y, z (B, 3, 3)
    rot = noise @ r_err @ rot
    approach = rot[:, :, 2]
    rest = np.array([GRASP_OBJECTS[g].rest_height_m for g in objects])
    goal = np.stack([np.zeros(b), np.zeros(b), rest], -1) + pos_noise_m * _seeded_normal(seeds, 2, (3,))
    extent = np.choose(obj, [object_extent(g, approach) for g in GRASP_CLASSES])
    standoff = np.array([pairs[pair] for pair in zip(cls.tolist(), obj.tolist())])
    start = goal - approach * (np.maximum(standoff, extent + reach_cls[cls]) + START_CLEARANCE_M)[:, None]
    params = TrialParams(
        goal=goal.astype(np.float32), approach=approach.astype(np.float32),
        wrist=wrist_angles(rot).astype(np.float32), start=start.astype(np.float32),
        standoff=standoff.astype(np.float32), volar=volar_cls[cls], tactile=tactile,
        open_=shapes[cls, 0].astype(np.float32), closed=shapes[cls, 1].astype(np.float32),
        obj=obj.astype(np.int32), hold_s=np.full(b, hold_s, np.float32))
    object_start = np.stack([offsets[:, 0], offsets[:, 1], rest], -1)
    return params, object_start
