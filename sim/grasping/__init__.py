"""sim.grasping: grasp objects, the MAP §III grasp strategy (approach, close, retract, tactile correction), batched grasp rollouts on several backends, and the rendered grasp views of GRASP's database.
"""
from sim._src.grasp_objects import (GRASP_CLASSES, GRASP_MAPPINGS, GRASP_NAMES, GRASP_OBJECTS, ROBOT_GRASPS,
                                    VOLAR_GRASPS, check_grasp_class, robot_grasp_for)
from sim._src.grasp_rollout import (grasp_scene, jitted_controller, trial_outcomes, GraspOutcomes, SUBSTEPS, first_readings, initial_qpos, native_start,
                                    object_gravcomp, peak_touch, resolve_backend, rollout_grasps, warp_status)
from sim._src.grasp_strategy import (ALPHA0, APPROACH, CLOSE, CONTROL_DT_S, DONE, HOLD_S, RETRACT,
                                     TOUCH_THRESHOLD_N, TrialParams, controller_step, initial_state,
                                     n_control_steps, object_extent, plan_trials)
from sim._src.grasp_views import (GraspRenderer, ViewDatabase, crop_hand, hand_center, look_at_rotation,
                                  render_grasp, render_views, sphere_camera, view_database, view_euler,
                                  view_grid)

__all__ = [
    "grasp_scene", "jitted_controller", "trial_outcomes",
    "ALPHA0", "APPROACH", "CLOSE", "CONTROL_DT_S", "DONE", "GRASP_CLASSES", "GRASP_MAPPINGS", "GRASP_NAMES",
    "GRASP_OBJECTS", "GraspOutcomes", "GraspRenderer", "HOLD_S", "RETRACT", "ROBOT_GRASPS", "SUBSTEPS", "TOUCH_THRESHOLD_N",
    "TrialParams", "VOLAR_GRASPS", "ViewDatabase", "check_grasp_class", "controller_step", "crop_hand", "first_readings", "hand_center",
    "initial_qpos", "initial_state", "look_at_rotation", "n_control_steps", "native_start", "object_extent", "object_gravcomp", "peak_touch",
    "plan_trials", "render_grasp", "render_views", "resolve_backend", "robot_grasp_for", "rollout_grasps", "sphere_camera", "view_database",
    "view_euler", "view_grid", "warp_status",
]
