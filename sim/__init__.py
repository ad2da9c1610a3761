"""MuJoCo / MJX side of lfd-jax: scenes written as MJCF here, batched rollouts, offscreen rendering.

Importing `sim` has no side effects: call `sim.setup_rendering()` (EGL by default) before rendering
with `mujoco.Renderer` directly; `sim.render_frame` and `sim.grasp_views.GraspRenderer` call it.
"""
from sim.render import render_frame, setup_rendering
from sim.rollout import batched_rollout, worlds_from_qpos
from sim.scenes import tabletop_drop_scene

__all__ = ["batched_rollout", "render_frame", "setup_rendering", "tabletop_drop_scene", "worlds_from_qpos"]
