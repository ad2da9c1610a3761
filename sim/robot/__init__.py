"""Robots: a WAM-like 7-DoF arm with a robot hand, its kinematics, and the pick-and-place task; and the
HOAP-3-like arm that PHMM (Humanoids 2008 §IV) maps movements to.

`manipulator_model(hand)` compiles a Barrett-WAM-like arm on a pedestal at the demonstration table,
carrying the Barrett-like or Karlsruhe-like hand of MAP §III, with a few free objects (its
`ManipulatorLayout` says where things are). `arm_chain` reads the arm's kinematic chain;
`forward_kinematics` and the batched damped-least-squares `solve_ik` run in JAX. `run_task(TaskSpec)`
picks an object up with the MAP §III grasp strategy, carries it to a place and puts it down
(`TaskOptions`: mapping, physics backend ("native" or "mjx-jax") and video; `TaskResult`: success and the first failing stage of `STAGES`).

* Arm: `manipulator_scene_xml`, `manipulator_model`, `manipulator_qpos`, `HOME_Q`, `JOINT_RANGE`,
  `BASE_POS`, `SHOULDER_M`, `DEFAULT_OBJECTS`; `TableSpec` (the table, also in `sim.scenes`).
* Kinematics: `arm_chain`, `ArmChain`, `forward_kinematics`, `solve_ik`, `IKResult`.
* Task: `run_task`, `TaskSpec`, `TaskOptions`, `TaskResult`, `STAGES`, `PLACE_TOL_M`,
  `retarget_path` (a demonstrated reach onto the robot's start and end), `task_sweep` and
  `task_table` (every hand, grasp and place); `task_scene`, `TaskSim` and `MjxTaskSim` (its physics on
  MJX-JAX) step a task's world directly; `TASK_BACKENDS`.
* The HOAP-3-like arm of PHMM: `arm_scene_xml`, `play` -> `Playback`, `UPPER_ARM_M`, `FOREARM_M`,
  `SHOULDER_POS` (these three are that arm's, not the WAM's).

Examples:
    >>> from sim.robot import HOME_Q, arm_chain, forward_kinematics, manipulator_model, solve_ik
    >>> model, layout = manipulator_model("barrett")
    >>> chain = arm_chain(model)
    >>> pos, rot = forward_kinematics(chain, HOME_Q)
    >>> solve_ik(chain, pos[None], rot[None]).reachable.tolist()
    [True]
"""
from sim._src.manipulator import (BASE_POS, DEFAULT_OBJECTS, HOME_Q, JOINT_RANGE, SHOULDER_M, ManipulatorLayout,
                                  manipulator_model, manipulator_qpos, manipulator_scene_xml)
from sim._src.manipulator_ik import ArmChain, IKResult, arm_chain, forward_kinematics, solve_ik
from sim._src.person_scene import TableSpec
from sim._src.robot_arm import FOREARM_M, SHOULDER_POS, UPPER_ARM_M, Playback, arm_scene_xml, play
from sim._src.task_controller import PLACE_TOL_M, STAGES, TaskResult, run_task, task_sweep, task_table
from sim._src.task_motion import MjxTaskSim, TaskSim
from sim._src.task_plan import TASK_BACKENDS, TaskOptions, TaskScene, TaskSpec, retarget_path, task_scene

__all__ = [
    "BASE_POS", "DEFAULT_OBJECTS", "FOREARM_M", "HOME_Q", "JOINT_RANGE", "PLACE_TOL_M", "SHOULDER_M",
    "SHOULDER_POS", "STAGES", "TASK_BACKENDS", "UPPER_ARM_M", "ArmChain", "IKResult", "ManipulatorLayout",
    "MjxTaskSim", "Playback",
    "TableSpec", "TaskOptions", "TaskResult", "TaskScene", "TaskSim", "TaskSpec", "arm_chain", "arm_scene_xml",
    "forward_kinematics", "manipulator_model", "manipulator_qpos", "manipulator_scene_xml", "play",
    "retarget_path", "run_task", "solve_ik", "task_scene", "task_sweep", "task_table",
]
