"""sim.robot: the 7-DoF arm with a robot hand on its flange, its kinematic chain, damped-least-squares IK, and the pick-and-place task controller.
"""
from sim._src.manipulator import (BASE_POS, DEFAULT_OBJECTS, HOME_Q, JOINT_RANGE, ManipulatorLayout,
                                  SHOULDER_M, manipulator_model, manipulator_qpos, manipulator_scene_xml)
from sim._src.manipulator_ik import ArmChain, IKResult, arm_chain, forward_kinematics, solve_ik
from sim._src.task_controller import PLACE_TOL_M, STAGES, TaskResult, TaskSpec, run_task
from sim._src.task_motion import TaskSim, retarget_path
from sim._src.task_plan import task_scene

from sim._src.robot_arm import FOREARM_M, SHOULDER_POS, UPPER_ARM_M, arm_scene_xml, play
__all__ = [
    "FOREARM_M", "SHOULDER_POS", "UPPER_ARM_M", "arm_scene_xml", "play",
    "ArmChain", "BASE_POS", "DEFAULT_OBJECTS", "HOME_Q", "IKResult", "JOINT_RANGE", "ManipulatorLayout", "PLACE_TOL_M",
    "SHOULDER_M", "STAGES", "TaskResult", "TaskSim", "TaskSpec", "arm_chain", "forward_kinematics", "manipulator_model",
    "manipulator_qpos", "manipulator_scene_xml", "retarget_path", "run_task", "solve_ik", "task_scene",
]
