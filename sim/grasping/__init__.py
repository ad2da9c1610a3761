"""Grasping: the six grasp classes and their objects, the MAP §III grasp strategy, batched grasp
rollouts, and the rendered view database of GRASP §III-B.

A human grasp class (Cutkosky 1, 2, 4, 9, 10, 12; `GRASP_CLASSES`) maps to a robot preshape
(`robot_grasp_for`, MAP Fig. 2). `plan_trials` turns a batch of (hand, grasp class, pose error, seed)
into `TrialParams` with the MAP §III strategy (`PlanOptions`: mapping, noise, hold time);
`rollout_grasps` runs them on the `native`, `mjx-jax` or `mjx-warp` backend with the jittable
controller `controller_step` (approach, tactile correction, close, lift, hold) and returns
`GraspOutcomes`. The view database renders the human hand of `sim.hands` from a half-sphere of
cameras and crops it (`view_database`, `ViewOptions`; `GraspRenderer` for single views).

* Classes and objects: `GRASP_CLASSES`, `GRASP_NAMES`, `GRASP_OBJECTS`, `VOLAR_GRASPS`,
  `ROBOT_GRASPS`, `GRASP_MAPPINGS`, `check_grasp_class`, `robot_grasp_for`.
* Strategy: `plan_trials`, `PlanOptions`, `TrialParams`, `controller_step`, `initial_state`,
  `n_control_steps`, `object_extent`; the phases `APPROACH` ... `DONE`.
* Rollouts: `rollout_grasps`, `GraspOutcomes`, `resolve_backend`, `warp_status`, `peak_touch`; the
  pieces of the native rollout for callers that step it themselves (`native_start`, `grasp_scene`,
  `jitted_controller`, `initial_qpos`, `object_gravcomp`, `first_readings`, `trial_outcomes`).
* Views: `view_database`, `ViewDatabase`, `ViewOptions`, `render_views`, `render_grasp`,
  `GraspRenderer`, `crop_hand`, `hand_center`, `sphere_camera`, `look_at_rotation`, `view_euler`,
  `view_grid`.

Examples:
    >>> import numpy as np
    >>> from sim.grasping import PlanOptions, plan_trials, robot_grasp_for, rollout_grasps
    >>> robot_grasp_for(9, "barrett")
    'Two-finger Thumb'
    >>> params, start = plan_trials("barrett", [1, 9], np.zeros((2, 2)), [0.0, 0.0], [True, True], [0, 1],
    ...                             options=PlanOptions(hold_s=0.3))
    >>> outcomes = rollout_grasps("barrett", params, start, backend="native")
    >>> outcomes.lifted.shape
    (2,)
"""
from sim._src.grasp_objects import (GRASP_CLASSES, GRASP_MAPPINGS, GRASP_NAMES, GRASP_OBJECTS, ROBOT_GRASPS,
                                    VOLAR_GRASPS, GraspObject, check_grasp_class, robot_grasp_for)
from sim._src.grasp_rollout import (BACKENDS, SUBSTEPS, GraspOutcomes, first_readings, grasp_scene, initial_qpos,
                                    jitted_controller, native_start, object_gravcomp, peak_touch, resolve_backend,
                                    rollout_grasps, trial_outcomes, warp_status)
from sim._src.grasp_strategy import (ALPHA0, APPROACH, CLOSE, CONTROL_DT_S, DONE, HOLD, HOLD_S, LIFT, RETRACT,
                                     TOUCH_THRESHOLD_N, ControllerState, PlanOptions, TrialParams, controller_step,
                                     initial_state, n_control_steps, object_extent, plan_trials)
from sim._src.grasp_views import (GraspRenderer, ViewDatabase, ViewOptions, crop_hand, hand_center,
                                  look_at_rotation, render_grasp, render_views, sphere_camera, view_database,
                                  view_euler, view_grid)

__all__ = [
    "ALPHA0", "APPROACH", "BACKENDS", "CLOSE", "CONTROL_DT_S", "DONE", "GRASP_CLASSES", "GRASP_MAPPINGS",
    "GRASP_NAMES", "GRASP_OBJECTS", "HOLD", "HOLD_S", "LIFT", "RETRACT", "ROBOT_GRASPS", "SUBSTEPS",
    "TOUCH_THRESHOLD_N", "VOLAR_GRASPS", "ControllerState", "GraspObject", "GraspOutcomes", "GraspRenderer",
    "PlanOptions", "TrialParams", "ViewDatabase", "ViewOptions", "check_grasp_class", "controller_step",
    "crop_hand", "first_readings", "grasp_scene", "hand_center", "initial_qpos", "initial_state",
    "jitted_controller", "look_at_rotation", "n_control_steps", "native_start", "object_extent",
    "object_gravcomp", "peak_touch", "plan_trials", "render_grasp", "render_views", "resolve_backend",
    "robot_grasp_for", "rollout_grasps", "sphere_camera", "trial_outcomes", "view_database", "view_euler",
    "view_grid", "warp_status",
]
