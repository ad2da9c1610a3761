"""Hands: the human hand and its reference grasps, the two robot hands, and virtual fingers.

The human hand is a parametric right hand in MJCF (20 joints with human ranges, `HandShape`), posed in
the six reference grasps of GRASP and MAP (`GRASP_POSTURES`, Cutkosky 1, 2, 4, 9, 10, 12) around the
object each grasp holds. The robot hands are the Barrett-like and the Karlsruhe-like hand of MAP §III
(`hand_spec`, `preshape`), compiled with a table and the six objects by `grasp_model`. Virtual fingers
(MAP §IV-A) compare a robot grasp's contacts with the human grasp's.

* Human hand: `hand_body_xml`, `hand_model_xml`, `posture_qpos`, `clip_posture`, `DEFAULT_SHAPE`
  (the database hand), `TEST_SHAPE` (a different test hand).
* Reference grasps: `posture(grasp, stage)`, `hand_pose_in_world`, `grasp_scene_xml` (with
  `GraspSceneOptions`), `grasp_contacts`, `grasp_plausibility`.
* Robot hands: `HAND_NAMES`, `hand_spec`, `preshape`, `grasp_model`, `hand_joint_qpos`.
* Virtual fingers: `human_entities`, `entities_from_links`, `group_virtual_fingers`,
  `match_virtual_fingers`, `vf_errors`.

Examples:
    >>> from sim.hands import grasp_plausibility, preshape
    >>> grasp_plausibility(1)["fingers_in_contact"]
    ('thumb', 'index', 'middle', 'ring', 'little', 'palm')
    >>> open_, closed = preshape("barrett", "Wrap")
    >>> closed.tolist()
    [0.0, 2.2, 2.2, 2.2]
"""
from sim._src.human_grasps import (GRASP_POSTURES, GraspContacts, GraspPosture, GraspSceneOptions, grasp_contacts,
                                   grasp_plausibility, grasp_scene_xml, hand_pose_in_world, posture, scene_qpos)
from sim._src.human_hand import (DEFAULT_SHAPE, FINGERS, JOINT_NAMES, JOINT_RANGES_DEG, NEUTRAL_POSTURE_DEG,
                                 TEST_SHAPE, HandShape, clip_posture, hand_body_xml, hand_defaults_xml,
                                 hand_model_xml, posture_qpos)
from sim._src.robot_hands import (HAND_NAMES, Finger, HandSpec, SceneLayout, grasp_model, hand_joint_qpos,
                                  hand_spec, preshape)
from sim._src.virtual_fingers import (VFErrors, VirtualFingers, entities_from_links, group_virtual_fingers,
                                      human_entities, match_virtual_fingers, vf_errors)

__all__ = [
    "DEFAULT_SHAPE", "FINGERS", "GRASP_POSTURES", "HAND_NAMES", "JOINT_NAMES", "JOINT_RANGES_DEG",
    "NEUTRAL_POSTURE_DEG", "TEST_SHAPE", "Finger", "GraspContacts", "GraspPosture", "GraspSceneOptions",
    "HandShape", "HandSpec", "SceneLayout", "VFErrors", "VirtualFingers", "clip_posture", "entities_from_links",
    "grasp_contacts", "grasp_model", "grasp_plausibility", "grasp_scene_xml", "group_virtual_fingers",
    "hand_body_xml", "hand_defaults_xml", "hand_joint_qpos", "hand_model_xml", "hand_pose_in_world", "hand_spec",
    "human_entities", "match_virtual_fingers", "posture", "posture_qpos", "preshape", "scene_qpos", "vf_errors",
]
