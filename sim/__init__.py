"""sim: the MuJoCo / MJX side of lfd-jax: scenes written as MJCF in code, batched rollouts, offscreen
rendering, and the robot that repeats a demonstration.

Four subpackages, by concept:

* `sim.hands`: the human hand and its six reference grasps, the Barrett-like and Karlsruhe-like robot
  hands, virtual fingers (GRASP §III-B, MAP §III-IV).
* `sim.grasping`: grasp classes and objects, the MAP §III grasp strategy, batched grasp rollouts on
  MuJoCo or MJX, the rendered view database of GRASP §III-B.
* `sim.robot`: a WAM-like 7-DoF arm with a robot hand, its inverse kinematics, the pick-and-place task
  (`run_task`); the HOAP-3-like arm of PHMM §IV.
* `sim.scenes`: the demonstration scene (a seated person, a table, objects, a stereo pair), the
  table-top drop scene, offscreen rendering, batched MJX rollouts.

The names used most are also importable from `sim` itself. Importing `sim` has no side effects: call
`sim.setup_rendering()` (EGL by default) before rendering with `mujoco.Renderer` directly;
`sim.render_frame`, `sim.PersonScene` and `sim.grasping.GraspRenderer` call it themselves.

Papers: MAP is Romero, Kjellström, Kragic 2009 (markerless human-to-robot grasp mapping); GRASP is
Kjellström, Romero, Kragic 2008 (IROS, visual recognition of grasps); PHMM is Herzog, Ude, Krüger 2008
(Humanoids, parametric HMMs); LFD is Kjellström, Kragic 2009; LEVELSET is Martínez, Romero,
Kjellström, Kragic 2008 (technical report).

Examples:
    >>> import sim
    >>> spec = sim.TaskSpec(objects=(1,), object_xy=[(0.0, -0.40)], grasp=1, place_xy=(0.2, -0.40))
    >>> result = sim.run_task(spec)  # doctest: +SKIP
    >>> result.success, result.failed_stage  # doctest: +SKIP
    (True, '')
"""
from sim import grasping, hands, robot, scenes
from sim.robot import (ArmChain, IKResult, ManipulatorLayout, TaskOptions, TaskResult, TaskSpec, arm_chain,
                       forward_kinematics, manipulator_model, manipulator_qpos, manipulator_scene_xml, run_task,
                       solve_ik)
from sim.scenes import (PART_LABELS, PART_NAMES, PersonLook, PersonScene, ScenePose, StereoRig, TableSpec,
                        batched_rollout, person_scene_xml, render_frame, setup_rendering, tabletop_drop_scene,
                        worlds_from_qpos)

__all__ = [
    "ArmChain", "IKResult", "ManipulatorLayout", "PART_LABELS", "PART_NAMES", "PersonLook", "PersonScene",
    "ScenePose", "StereoRig", "TableSpec", "TaskOptions", "TaskResult", "TaskSpec", "arm_chain",
    "batched_rollout", "forward_kinematics", "manipulator_model", "manipulator_qpos", "manipulator_scene_xml",
    "person_scene_xml", "render_frame", "run_task", "setup_rendering", "solve_ik", "tabletop_drop_scene",
    "worlds_from_qpos",
]
