"""MuJoCo / MJX side of lfd-jax: scenes written as MJCF here, batched rollouts, offscreen rendering.

Importing `sim` has no side effects: call `sim.setup_rendering()` (EGL by default) before rendering
with `mujoco.Renderer` directly; `sim.render_frame` and `sim.grasp_views.GraspRenderer` call it.

The demonstration scene (issue 18): `person_scene_xml(look, rig, objects)` writes a seated person
(`PersonLook`), a table, objects and a textured wall filmed by a rectified stereo pair (`StereoRig`);
`PersonScene` poses it per frame (`ScenePose`) and renders RGB and part labels of both views
(`PART_NAMES`, `PART_LABELS`: background, person, hand skin, face skin, objects).
"""
from sim.person_body import PersonLook
from sim.person_scene import PART_LABELS, PART_NAMES, PersonScene, ScenePose, StereoRig, TableSpec, person_scene_xml
from sim.render import render_frame, setup_rendering
from sim.rollout import batched_rollout, worlds_from_qpos
from sim.scenes import tabletop_drop_scene

__all__ = ["PART_LABELS", "PART_NAMES", "PersonLook", "PersonScene", "ScenePose", "StereoRig", "TableSpec",
           "person_scene_xml", "batched_rollout", "render_frame", "setup_rendering", "tabletop_drop_scene", "worlds_from_qpos"]
