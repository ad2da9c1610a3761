"""MuJoCo / MJX side of lfd-jax: scenes written as MJCF here, batched rollouts, offscreen rendering.

Importing `sim` has no side effects: call `sim.setup_rendering()` (EGL by default) before rendering
with `mujoco.Renderer` directly; `sim.render_frame` and `sim.grasp_views.GraspRenderer` call it.

The demonstration scene (issue 18): `person_scene_xml(look, rig, objects)` writes a seated person
(`PersonLook`), a table, objects and a textured wall filmed by a rectified stereo pair (`StereoRig`);
`PersonScene` poses it per frame (`ScenePose`) and renders RGB and part labels of both views
(`PART_NAMES`, `PART_LABELS`: background, person, hand skin, face skin, objects).

The robot (issue 21): `manipulator_scene_xml(hand)` writes a Barrett-WAM-like 7-DoF arm on a pedestal
at that table, carrying the Barrett-like or Karlsruhe-like hand of `sim.robot_hands` on its flange,
with joint-space position servos, gravity compensation and a few free objects; `manipulator_model`
compiles it with its `ManipulatorLayout` (qpos/ctrl indices), `manipulator_qpos` sets a pose.
`arm_chain(model)` reads the arm's kinematic chain (`ArmChain`) to the palm site;
`forward_kinematics(chain, q)` and the batched damped-least-squares `solve_ik(chain, target_pos,
target_rot, q0)` -> `IKResult(q, pos_error, rot_error, reachable)` run in JAX. `run_task(TaskSpec(...))`
-> `TaskResult` picks an object up with the MAP §III grasp strategy, carries it to a place and puts it
down (`sim.task_controller`).
"""
from sim import grasping, hands, robot, scenes
from sim.robot import (ArmChain, IKResult, ManipulatorLayout, TaskResult, TaskSpec, arm_chain,
                       forward_kinematics, manipulator_model, manipulator_qpos, manipulator_scene_xml,
                       run_task, solve_ik)
from sim.scenes import (PART_LABELS, PART_NAMES, PersonLook, PersonScene, ScenePose, StereoRig, TableSpec,
                        batched_rollout, person_scene_xml, render_frame, setup_rendering, tabletop_drop_scene,
                        worlds_from_qpos)

__all__ = [
    "ArmChain", "IKResult", "ManipulatorLayout", "PART_LABELS", "PART_NAMES", "PersonLook", "PersonScene", "ScenePose",
    "StereoRig", "TableSpec", "TaskResult", "TaskSpec", "arm_chain", "batched_rollout", "forward_kinematics", "manipulator_model",
    "manipulator_qpos", "manipulator_scene_xml", "person_scene_xml", "render_frame", "run_task", "setup_rendering", "solve_ik", "tabletop_drop_scene",
    "worlds_from_qpos",
]
