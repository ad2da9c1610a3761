"""sim.hands: the human hand (MJCF, postures, the grasp taxonomy's postures), the robot hands (Barrett-like and Karlsruhe-like) and virtual fingers (MAP §II-III).
"""
from sim._src.human_grasps import (GRASP_POSTURES, grasp_contacts, grasp_plausibility, grasp_scene_xml,
                                   hand_pose_in_world, posture, scene_qpos)
from sim._src.human_hand import (DEFAULT_SHAPE, FINGERS, HandShape, JOINT_NAMES, JOINT_RANGES_DEG,
                                 NEUTRAL_POSTURE_DEG, TEST_SHAPE, clip_posture, hand_body_xml,
                                 hand_defaults_xml, hand_model_xml, posture_qpos)
from sim._src.robot_hands import HAND_NAMES, grasp_model, hand_joint_qpos, hand_spec, preshape
from sim._src.virtual_fingers import (VirtualFingers, entities_from_links, group_virtual_fingers,
                                      human_entities, match_virtual_fingers, vf_errors)

__all__ = [
    "DEFAULT_SHAPE", "FINGERS", "GRASP_POSTURES", "HAND_NAMES", "HandShape", "JOINT_NAMES", "JOINT_RANGES_DEG", "NEUTRAL_POSTURE_DEG",
    "TEST_SHAPE", "VirtualFingers", "clip_posture", "entities_from_links", "grasp_contacts", "grasp_model", "grasp_plausibility", "grasp_scene_xml",
    "group_virtual_fingers", "hand_body_xml", "hand_defaults_xml", "hand_joint_qpos", "hand_model_xml", "hand_pose_in_world", "hand_spec", "human_entities",
    "match_virtual_fingers", "posture", "posture_qpos", "preshape", "scene_qpos", "vf_errors",
]
