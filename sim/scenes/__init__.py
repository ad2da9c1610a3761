"""Scenes: the demonstration scene filmed by a stereo pair, the table-top drop scene, offscreen
rendering and batched MJX rollouts.

The demonstration scene (LFD §III, LEVELSET §3) is a seated person (`PersonLook`) at a table
(`TableSpec`) with the objects they handle, a textured wall behind, and a rectified stereo pair in
front (`StereoRig`); `person_scene_xml` writes it, `PersonScene` poses it per frame (`ScenePose`) and
renders RGB and the ground-truth part of every pixel of both views (`PART_NAMES`, `PART_LABELS`).
The table-top drop scene is the plain MJX example: `worlds_from_qpos` and `batched_rollout` step
batches of worlds (`vmap` over worlds, `lax.scan` over steps) with `mjx_step`, MJX's step with its
LAPACK calls ordered so that XLA:CPU cannot deadlock.

Importing `sim` has no side effects: `setup_rendering()` chooses the OpenGL backend (EGL by default)
before `mujoco.Renderer` is used directly; `render_frame`, `PersonScene` and the grasp renderers
call it themselves.

* Demonstration scene: `person_scene_xml`, `PersonScene`, `ScenePose`, `PersonLook`, `StereoRig`,
  `TableSpec`, `PART_NAMES`, `PART_LABELS`, `CLOTH_PATTERNS`, `body_points`.
* MJX: `tabletop_drop_scene`, `table_height_m`, `random_drop_heights`, `worlds_from_qpos`,
  `batched_rollout`, `mjx_step`.
* Rendering: `setup_rendering`, `render_frame`, `offscreen_visual_xml`.

Examples:
    >>> import mujoco, numpy as np
    >>> from mujoco import mjx
    >>> from sim.scenes import batched_rollout, tabletop_drop_scene, worlds_from_qpos
    >>> model = mujoco.MjModel.from_xml_string(tabletop_drop_scene(n_objects=2))
    >>> mjx_model = mjx.put_model(model)
    >>> worlds = worlds_from_qpos(mjx_model, np.tile(model.qpos0, (4, 1)))
    >>> final, trajectory = batched_rollout(mjx_model, worlds, n_steps=10, record_every=5)
    >>> trajectory.shape
    (2, 4, 14)
"""
from sim._src.person_body import CLOTH_PATTERNS, PersonLook, body_points
from sim._src.person_scene import (PART_LABELS, PART_NAMES, PersonScene, ScenePose, StereoRig, TableSpec,
                                   person_scene_xml)
from sim._src.render import render_frame, setup_rendering
from sim._src.rollout import batched_rollout, mjx_step, worlds_from_qpos
from sim._src.scenes import offscreen_visual_xml, random_drop_heights, table_height_m, tabletop_drop_scene

__all__ = [
    "CLOTH_PATTERNS", "PART_LABELS", "PART_NAMES", "PersonLook", "PersonScene", "ScenePose", "StereoRig",
    "TableSpec", "batched_rollout", "body_points", "mjx_step", "offscreen_visual_xml", "person_scene_xml",
    "random_drop_heights", "render_frame", "setup_rendering", "table_height_m", "tabletop_drop_scene",
    "worlds_from_qpos",
]
