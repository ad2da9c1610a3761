"""The robot's task controller: pick one object up with the MAP §III grasp strategy on the WAM-like arm
of `sim.robot.manipulator_model`, carry it to a place on the table, put it down upright, release it.
One world, a Python control loop at `CONTROL_DT_S`; the physics under it on a backend
(`TaskOptions.backend`): native MuJoCo (`TaskSim`) or MJX-JAX (`MjxTaskSim`: one jitted program per
control period, on the default JAX device), the controller, IK and plan the same code on both.

What it does, in order (`run_task(spec)` -> `TaskResult`):

1. Plan (MAP §III): `sim.grasping.plan_trials` gives the
   robot preshape of the human grasp class through the mapping table (`robot_grasp_for`), the hand
   orientation imitating the human hand's (palm normal -> approach, thumb axis -> wrap axis; volar
   grasps from the top or the side, open-loop grasps to a predefined distance), the approach start
   and goal, in the object's frame. The plan is turned about the vertical by the yaw that best aligns
   the canonical human hand (`sim.hands.hand_pose_in_world`) with the recognised one
   (`TaskSpec.hand_rot`, world), and moved onto the object. The palm poses above the pre-grasp, at
   the pre-grasp, grasp, lift, above the place, at the place and retracted are checked with one
   batched `solve_ik`, at that yaw and at turns of `YAW_STEPS_DEG` (up to 90 degrees) from it, each
   level and then tilted downwards by `TILT_STEPS_DEG` (the grasp study's orientation error), and
   with MuJoCo's collision detection at the IK answers (no contact with another object, none of the
   arm with the table); of the plans for which the arm reaches all seven cleanly, the first whose whole
   path the tracking IK below follows through them (`path_tracks`: its warm-started solves from home
   along the approach, the descent, the grasp, lift, carry, lowering and retract, no physics) is executed,
   else the first of them (`TaskResult.yaw_deg`, `tilt_deg`: the imitation as close as the arm allows);
   none -> the result fails at "ik_unreachable" without simulating (so does a place off the table).
2. Approach: the palm rises `CLEAR_M` from home (whose fingers point down at the table), then
   follows the caller's path (`approach_path` (T, 3) world, e.g. a PHMM-synthesised reach, retargeted
   to the arm by `retarget_path`), else a straight line, to `ABOVE_M` above the pre-grasp pose, at `MOVE_SPEED_M_S` (arc
   length, min-jerk timing), the orientation slerped from home to the grasp's; then it descends onto
   the pre-grasp pose (the open fingers clear the object). The path is not checked for collisions
   (a joint-space move from home to the checked configuration above the pre-grasp was tried and was
   no better on the default three-object scene).
3. Grasp and lift: `sim.grasping.controller_step` itself (the floating-hand study's controller,
   jitted, B = 1) drives the palm position and the fingers: approach along the planned line, stop at
   the first touch for volar grasps and, if it is not on the palm and `tactile` is on, retract and
   replan towards the contact (MAP §III's correction), close, lift 10 cm, hold briefly. Its sensors
   (touch per hand link, contact with the object, object and palm frames) are added to the
   manipulator scene in the grasp scene's layout (`sim.hands.SceneLayout`), and
   `sim.grasping.peak_touch` reads them per control period exactly as in the grasp study.
4. Carry the palm horizontally (at the lift height, the orientation kept) until the object is above
   the place, the fingers' targets `GRIP_MARGIN` past the positions at which they hold it (a lighter
   grip than the grasp controller's); turn the hand about the object's centre so that the held object
   stands upright (its axis as measured, a tilt in the grasp of up to `MAX_STRAIGHTEN_DEG`, turned to
   the vertical; a larger tilt means the object pivots in the grasp and turning the hand would drop
   it); lower it at `LOWER_SPEED_M_S`, the last `TOUCH_M` above its standing height at
   `TOUCH_SPEED_M_S`, until the object (or a finger) touches the table; let the grip fade (the
   fingers' targets to their measured positions over `RELEASE_S`), open the fingers to the open
   preshape; retract along the approach direction and up (volar grasps first centre the palm on the
   object sideways, so that the open fingers clear it).

Every palm pose becomes arm joint targets by tracking IK (`track_ik`): one damped-least-squares solve per
control step (`solve_ik`, one start, warm-started at the last target), sent to the arm's position servos;
the fingers' targets go to the hand's servos.

Success (`TaskResult.success`): the handled object ends within `PLACE_TOL_M` of the place in x-y,
upright (its z axis within `UPRIGHT_TOL_DEG` of vertical; a cube may stand on any face, a ball is
always upright) and released (no contact with the robot). The first failing stage is named:
"ik_unreachable", "approach" (the palm did not reach the pre-grasp pose), "grasp" (the object is not
held by two links after closing), "lift" (held but not raised with the hand), "carry" (dropped on the
way), "place" (too far, not upright or not released, including an object that slips out while
lowered).

What it does not do: no collision-aware path planning (only the key poses are checked; the
straight carry can sweep other objects off the table, the arm may brush them), no re-grasp after a
failure, no change of hand orientation between grasp and place (a place that needs one is
unreachable), no force control while lowering (it stops at the first object-table contact). The plan takes the preshape and the approach from
the grasp class and the stand-off, the stop and the centre height from the handled object's geometry
(`plan_trials(..., objects=...)`; the grasp study plans each class for its own object). Recognised orientation: only its yaw
about the vertical is used (MAP §III snaps the approach to top or side anyway).
"""
from __future__ import annotations

import time
from collections.abc import Sequence
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation, Slerp

from lfd_common import as_array, check_int
from sim._src.grasp_objects import GRASP_CLASSES, GRASP_NAMES, GRASP_OBJECTS, robot_grasp_for
from sim._src.grasp_rollout import LIFT_SUCCESS_M
from sim._src.grasp_strategy import CONTROL_DT_S, DONE, HORIZON_S, LIFT, initial_state
from sim._src.manipulator import HOME_Q
from sim._src.manipulator_ik import forward_kinematics
from sim._src.robot_hands import HAND_NAMES
from sim._src.task_motion import (held_links, hold, move, object_tilt, ramp_fingers, task_sim, tilt_correction,
    upright_axis)
from sim._src.task_plan import (ABOVE_M, CARRY_SPEED_M_S, LOWER_SPEED_M_S, MOVE_SPEED_M_S, RETRACT_M, RETRACT_UP_M,
    TaskOptions, TaskSpec, approach_points, check_spec, grasp_controller, min_jerk, on_table, reachable_plan,
    task_scene)

__all__ = ["STAGES", "TaskOptions", "TaskResult", "TaskSpec", "run_task", "task_sweep", "task_table"]

STAGES: tuple[str, ...] = ("ik_unreachable", "approach", "grasp", "lift", "carry", "place")
PLACE_TOL_M = 0.05
UPRIGHT_TOL_DEG = 20.0
TOUCH_M, TOUCH_SPEED_M_S = 0.02, 0.01  # ... and while the object is within TOUCH_M of standing on it
# the fingers open slowly: opened over 0.6 s, the Karlsruhe hand's fingers knocked a thin cylinder (1.5 cm x 20 cm)
# over after it stood on the table in 2 of 72 validation tasks of the imitation loop (none with 2 s)
RELEASE_S, OPEN_S, SETTLE_S = 0.3, 2.0, 0.3
MAX_STRAIGHTEN_DEG = 25.0    # a larger tilt in the grasp means the object pivots there: not turned
STRAIGHTEN_S = 0.4           # turning the held object upright above the place
GRIP_MARGIN = 0.2            # rad: carry and place with the fingers' targets this far past where they hold
APPROACH_TOL_M = 0.02        # the palm within this of the pre-grasp pose after the approach


class TaskResult(NamedTuple):
    """The outcome of one task of `run_task` (numpy / Python values).

    Attributes:
        success: placed within `PLACE_TOL_M`, upright and released.
        failed_stage: the first stage that failed (one of `STAGES`), "" on success.
        object_pos: (3,) the handled object's final position (world).
        upright: the object stands upright (its z axis within `UPRIGHT_TOL_DEG` of vertical).
        released: no contact with the robot.
        place_error_m: x-y distance to the place.
        n_corrections: tactile corrections made.
        yaw_deg: how far (about the vertical) the executed hand orientation is turned from the
            preferred one (`YAW_STEPS_DEG`).
        tilt_deg: the approach's downward tilt (`TILT_STEPS_DEG`).
        stage_sim_s: simulated seconds per stage that ran ("plan", "approach", "grasp", "carry",
            "place"; "grasp" includes the lift).
        stage_wall_s: wall-clock seconds per stage that ran.
        frames: (F, H, W, 3) uint8 of the fixed camera, or None when not rendered.
        fps: their rate.
        others_moved_m: how far (x-y) the other objects were pushed, the most (the arm has no
            collision-aware path; not part of `success`).
    """

    success: bool
    failed_stage: str
    object_pos: np.ndarray
    upright: bool
    released: bool
    place_error_m: float
    n_corrections: int
    yaw_deg: float
    tilt_deg: float
    stage_sim_s: dict
    stage_wall_s: dict
    frames: np.ndarray | None
    fps: float
    others_moved_m: float = 0.0


def run_task(spec: TaskSpec, *, approach_path: ArrayLike | None = None, seed: int = 0,
             options: TaskOptions = TaskOptions()) -> TaskResult:
    """Run one pick-and-place task with the MAP §III grasp strategy (physics: `options.backend`).

    See the module docstring for what it does, stage by stage, and what counts as success.

    Args:
        spec: the task.
        approach_path: (T, 3) a demonstrated reach (world m) whose shape the palm follows from the
            home pose to above the pre-grasp pose (`retarget_path` moves it onto those two); None: a
            straight line.
        seed: the grasp plan's hand-pose noise (`plan_trials`), >= 0.
        options: the grasp mapping, the physics backend and the recorded video (`TaskOptions`).

    Returns:
        The `TaskResult`. A place the arm cannot reach (or off the table) is a failed result at
            "ik_unreachable", not an exception.

    Raises:
        ValueError: bad input, naming the argument (or the field of `spec`; `camera` for a camera the
            manipulator scene does not have; `backend` for a scene that "mjx-jax" cannot simulate).
    """
    spec = check_spec(spec)
    seed = check_int(seed, "seed", min_value=0)
    if not isinstance(options, TaskOptions):
        raise ValueError(f"options: expected a TaskOptions, got {type(options).__name__}")
    mapping, render, camera, fps = options.mapping, options.render, options.camera, options.fps
    path = None if approach_path is None else as_array(approach_path, "approach_path", shape=(None, 3))
    scene = task_scene(spec.hand, spec.objects, tuple(map(tuple, spec.object_xy.tolist())))
    if camera not in [scene.model.camera(i).name for i in range(scene.model.ncam)]:
        raise ValueError(f"camera: no camera named {camera!r} in the manipulator scene")

    sim_s, wall_s = {}, {}
    clock = time.perf_counter()
    plan, reachable = reachable_plan(spec, scene, seed, mapping, path)
    wall_s["plan"], sim_s["plan"] = time.perf_counter() - clock, 0.0
    centre = plan.obj_centre
    if not (reachable and on_table(spec.place_xy)):
        return TaskResult(False, "ik_unreachable", centre, True, True,
                          float(np.linalg.norm(centre[:2] - spec.place_xy)), 0, plan.yaw_deg, plan.tilt_deg, sim_s, wall_s, None, fps)

    params = plan.params
    open_, closed = params.open_[0].astype(float), params.closed[0].astype(float)
    sim = task_sim(scene, spec, open_, options)
    stage = {"name": "approach", "t": 0.0, "wall": time.perf_counter()}

    def next_stage(name: str):
        sim_s[stage["name"]] = sim.t - stage["t"]
        wall_s[stage["name"]] = time.perf_counter() - stage["wall"]
        stage.update(name=name, t=sim.t, wall=time.perf_counter())

    def finish(failed: str) -> TaskResult:
        next_stage("")
        pos = sim.obj_pos()
        upright = bool(object_tilt(held_obj, sim.obj_rot()) <= np.radians(UPRIGHT_TOL_DEG))
        released = not sim.touches(scene.robot_geoms)
        err = float(np.linalg.norm(pos[:2] - spec.place_xy))
        ok = failed == "" and upright and released and err <= PLACE_TOL_M
        failed = failed or ("" if ok else "place")
        frames = np.stack(sim.frames) if sim.frames else None
        others = sim.others_moved()
        sim.close()
        return TaskResult(ok, failed, pos, upright, released, err, n_corr, plan.yaw_deg, plan.tilt_deg, sim_s, wall_s,
                          frames, fps, others)

    n_corr = 0
    held_obj = GRASP_OBJECTS[spec.objects[spec.target]]
    try:
        # 1. approach: up, along the caller's path (or a straight line) to above the pre-grasp pose, down
        home_pos, home_rot = (np.asarray(a, float) for a in forward_kinematics(scene.chain, HOME_Q))
        pre = params.start[0].astype(float)
        above = pre + [0.0, 0.0, ABOVE_M]
        move(sim, approach_points(home_pos, above, path), home_rot, plan.rot, open_, MOVE_SPEED_M_S)
        move(sim, np.stack([above, pre]), plan.rot, plan.rot, open_, MOVE_SPEED_M_S / 2)
        hold(sim, pre, plan.rot, open_, SETTLE_S)
        if np.linalg.norm(sim.palm() - pre) > APPROACH_TOL_M:
            return finish("approach")

        # 2. grasp and lift: the MAP §III controller drives the palm position and the fingers
        next_stage("grasp")
        control = grasp_controller(spec.hand, len(spec.objects))
        state = initial_state(params, scene.sensors.n_links)
        closed_links, lift_start = 0, None
        for _ in range(int(round(HORIZON_S / CONTROL_DT_S))):
            before = int(state.phase[0])
            state, ctrl = control(state, jnp.asarray(sim.sensordata, jnp.float32), params)
            ctrl = np.asarray(ctrl[0], float)
            phase = int(state.phase[0])
            if phase == LIFT and before != LIFT:
                closed_links, lift_start = held_links(sim.sensordata, scene.sensors, spec.target), sim.obj_pos()
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
        # a full-force grip (targets at the closed preshape) squeezes a pinched disc or ball slowly out of
        # the fingertips (10-25 N on 0.1 kg; it tilted 10 degrees in 3 s, then jumped out)
        hand_q = sim.hand_q()
        fingers = hand_q + np.clip(closed - hand_q, -GRIP_MARGIN, GRIP_MARGIN)
        cmd = np.asarray(state.cmd[0], float)
        goal = cmd + np.append(spec.place_xy - sim.obj_pos()[:2], 0.0)
        move(sim, np.stack([cmd, goal]), plan.rot, plan.rot, fingers, CARRY_SPEED_M_S)
        hold(sim, goal, plan.rot, fingers, SETTLE_S)
        # dropped: no longer touching the hand, or fallen (an object that turns in the grasp is still held)
        dropped = sim.obj_pos()[2] - centre[2] < LIFT_SUCCESS_M / 2 or not sim.touches(scene.hand_geoms)
        if dropped:
            return finish("carry")
        # straighten: turn the hand about the object's centre so that the held object's axis is vertical
        rot = plan.rot
        tilt = object_tilt(held_obj, sim.obj_rot())
        if 0.0 < tilt <= np.radians(MAX_STRAIGHTEN_DEG):
            fix = tilt_correction(upright_axis(held_obj, sim.obj_rot()))
            centre_now = sim.obj_pos()
            straight = centre_now + fix @ (goal - centre_now)
            slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([rot, fix @ rot])))
            n = int(round(STRAIGHTEN_S / CONTROL_DT_S))
            for s, r in zip(min_jerk(n), slerp(min_jerk(n)).as_matrix()):
                sim.step(goal + s * (straight - goal), r, fingers)
            goal, rot = straight, fix @ rot
            hold(sim, goal, rot, fingers, SETTLE_S)

        # 4. lower until the object touches the table, the last TOUCH_M slowly; release; open; retract
        next_stage("place")
        pos = goal.copy()
        lowest = pos[2] - (sim.obj_pos()[2] - centre[2]) - 0.03
        while pos[2] > lowest and not (sim.touches([scene.table_geom])
                                       or sim.contact(scene.hand_geoms, [scene.table_geom])):
            # a thin tall object met at 5 cm/s bounces on its base edge and topples once released
            near = sim.obj_pos()[2] - centre[2] < TOUCH_M
            pos = pos - [0.0, 0.0, (TOUCH_SPEED_M_S if near else LOWER_SPEED_M_S) * CONTROL_DT_S]
            sim.step(pos, rot, fingers)
        # the grip fades to the fingers' measured positions (an abrupt release kicks the object off its
        # base), then they open from there
        pos, release = sim.palm(), sim.hand_q()
        ramp_fingers(sim, pos, rot, fingers, release, RELEASE_S)
        ramp_fingers(sim, pos, rot, release, open_, OPEN_S)
        hold(sim, pos, rot, open_, SETTLE_S / 2)
        a = params.approach[0].astype(float)
        # volar grasps: first centre the palm on the object sideways (horizontal, across the approach);
        # 1 cm off centre, the open Barrett thumb rubbed along the bottle and dragged it 2 cm back
        off = sim.obj_pos() - pos
        off = (off - (off @ a) * a) * [1.0, 1.0, 0.0]
        centred = pos + (off if bool(params.volar[0]) else 0.0)
        back = centred - RETRACT_M * a
        move(sim, np.stack([pos, centred, back, back + [0.0, 0.0, RETRACT_UP_M]]), rot, rot, open_,
              MOVE_SPEED_M_S / 2)
        hold(sim, back + [0.0, 0.0, RETRACT_UP_M], rot, open_, SETTLE_S)
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
    """Run every (hand, grasp class, place) task: the grasp class's own object alone, canonical hand.

    The object stands at `SWEEP_OBJECT_XY`; the human hand has the canonical orientation. Run it with
    `python -c "from sim.robot import task_sweep, task_table; print(task_table(task_sweep()))"`.

    Args:
        hands: the robot hands.
        grasps: the grasp classes.
        places: the places (x, y, world m).
        tactile: MAP §III's tactile correction for volar grasps.
        progress: print one line per task.

    Returns:
        One dict per task: hand, grasp, place, success, failed_stage, place_error_m, upright,
            released, wall_s.
    """
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
    """A markdown table of `task_sweep`'s rows.

    Args:
        rows: `task_sweep`'s rows.

    Returns:
        The table: successes per grasp class and hand, the robot preshape, the stages that failed.
    """
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
