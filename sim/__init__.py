"""MuJoCo / MJX side of lfd-jax: scenes written as MJCF here, batched rollouts, offscreen rendering."""
import os

# MuJoCo picks its GL backend when `mujoco` is first imported; with no display, EGL (Mesa) is the one
# that works on these machines. A user's explicit MUJOCO_GL always wins.
os.environ.setdefault("MUJOCO_GL", "egl")

from sim.render import render_frame  # noqa: E402
from sim.rollout import batched_rollout, worlds_from_qpos  # noqa: E402
from sim.scenes import tabletop_drop_scene  # noqa: E402

__all__ = ["batched_rollout", "render_frame", "tabletop_drop_scene", "worlds_from_qpos"]
