"""MJCF of one recording scene: the objects, the grip of each class, the person's hand."""
from __future__ import annotations

import math

import numpy as np

from experiments.data.oac.grips import grip_of
from experiments.data.oac.settings import Person
from experiments.data.oac.motion import face_point, rotation_about
from lfd_common import matrix_to_quat, quat_to_matrix


# ----------------------------------------------------------------------- the person's hand, the scene
def hand_shape(person: Person):
    """The person's hand: `sim.human_hand.DEFAULT_SHAPE` scaled by sqrt(body size), skin tone varied."""
    from sim.hands import DEFAULT_SHAPE, HandShape

    k = math.sqrt(person.size)
    tone = 1.0 - 0.25 * (person.size * 7.0 % 1.0)  # a deterministic per-person skin tone
    skin = tuple(float(c) for c in np.clip(np.array(DEFAULT_SHAPE.skin_rgba[:3]) * tone, 0, 1)) + (1.0,)
    return HandShape(finger_lengths=tuple(tuple(v * k for v in row) for row in DEFAULT_SHAPE.finger_lengths),
                     finger_radius=DEFAULT_SHAPE.finger_radius * k, palm_length=DEFAULT_SHAPE.palm_length * k,
                     palm_width=DEFAULT_SHAPE.palm_width * k, palm_thickness=DEFAULT_SHAPE.palm_thickness * k,
                     skin_rgba=skin)


def rotation_to_quat(rot: np.ndarray) -> np.ndarray:
    """(3, 3) rotation -> (4,) unit quaternion (w, x, y, z)."""
    return matrix_to_quat(np.asarray(rot, float))


def grip_pose(cls: int, person: Person) -> tuple[np.ndarray, np.ndarray]:
    """Hand pose (position (3,), rotation (3, 3)) in the grasped-part frame (x away from the palm).

    `sim.human_grasps` gives the hand in the frame of the grasp's own object (z its axis); that frame
    is turned about z so that the palm centre lies on the -x side, and the hand is moved out with
    its scale (a bigger hand holds the same object with its wrist further away).
    """
    from sim.hands import hand_pose_in_world

    pos, quat = hand_pose_in_world(grip_of(cls, person).grasp)
    rot = quat_to_matrix(quat)
    shape = hand_shape(person)
    palm = pos + rot @ np.array([0.5 * shape.palm_length, 0.0, -0.5 * shape.palm_thickness])
    alpha = math.pi - math.atan2(palm[1], palm[0])  # turn the palm direction onto -x
    fix = rotation_about(np.array([0.0, 0.0, 1.0]), alpha)
    return fix @ pos * math.sqrt(person.size), fix @ rot


def scene_xml(cls: int, person: Person, image_px: int) -> str:
    """MJCF: the person's head (skin) and one mocap body (the grasped part's frame) holding the object's
    geoms and the person's hand."""
    from sim.hands import hand_body_xml, hand_defaults_xml
    from sim.scenes import offscreen_visual_xml

    shape = hand_shape(person)
    hand_pos, hand_rot = grip_pose(cls, person)
    head = face_point(person) + np.array([0.0, 0.06, 0.0]) * person.size  # the face surface is in front
    skin = " ".join(f"{c:.4f}" for c in shape.skin_rgba)
    return f"""<mujoco model="oac_{cls}">
  <compiler angle="radian"/>
  <option gravity="0 0 0"/>
  {offscreen_visual_xml(image_px, ambient=0.35, diffuse=0.3, offsamples=0)}
  <default>{hand_defaults_xml(shape)}</default>
  <worldbody>
    <light name="key" directional="true" castshadow="false" dir="0.3 0.5 -1" diffuse="0.6 0.6 0.6" specular="0.1 0.1 0.1"/>
    <body name="head" pos="{head[0]:.4f} {head[1]:.4f} {head[2]:.4f}">
      <geom type="ellipsoid" size="{0.075 * person.size:.4f} {0.085 * person.size:.4f} {0.11 * person.size:.4f}" rgba="{skin}"/>
    </body>
    <body name="grasped" mocap="true">
      <body name="object">{grip_of(cls, person).geoms}</body>
      {hand_body_xml(shape, pos=hand_pos, quat=rotation_to_quat(hand_rot))}
    </body>
  </worldbody>
</mujoco>"""
