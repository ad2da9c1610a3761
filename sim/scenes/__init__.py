"""sim.scenes: the seated person and the demonstration scene filmed by a stereo pair, the table-top drop scene, offscreen rendering and batched MJX rollouts.
"""
from sim._src.person_body import CLOTH_PATTERNS, PersonLook, body_points
from sim._src.person_scene import (PART_LABELS, PART_NAMES, PersonScene, ScenePose, StereoRig, TableSpec,
                                   person_scene_xml)
from sim._src.render import render_frame, setup_rendering
from sim._src.rollout import batched_rollout, mjx_step, worlds_from_qpos
from sim._src.scenes import offscreen_visual_xml, random_drop_heights, table_height_m, tabletop_drop_scene

__all__ = [
    "CLOTH_PATTERNS", "PART_LABELS", "PART_NAMES", "PersonLook", "PersonScene", "ScenePose", "StereoRig", "TableSpec",
    "batched_rollout", "body_points", "mjx_step", "offscreen_visual_xml", "person_scene_xml", "random_drop_heights", "render_frame", "setup_rendering",
    "table_height_m", "tabletop_drop_scene", "worlds_from_qpos",
]
