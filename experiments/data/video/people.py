"""The demonstrators and their scene: the OAC persons (`experiments.data.oac.draw_persons`) with a look
(clothing, hair, skin, sleeves), a table-top `Subject` for the arm kinematics
(`experiments.data.tabletop`), the table layout and the stereo rig in front of them."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from experiments.data.oac.grips import grip_of
from experiments.data.oac.motion import face_point, camera_pose, object_trajectory
from experiments.data.oac.scene import grip_pose, hand_shape
from experiments.data.oac.settings import BASELINE_M, FOCAL_PX, IMAGE_SIZE_PX, OBJECTS, TABLE_Z_M, Person, draw_persons
from experiments.data.tabletop.subjects import HIP, TABLE_HEIGHT_M, Subject, sample_subject
from experiments.data.video.settings import VideoSettings
from sim.scenes import CLOTH_PATTERNS, PersonLook, body_points
from sim.scenes import StereoRig, TableSpec, person_scene_xml

TABLE = TableSpec(top_z=TABLE_Z_M)
# The table-top kinematics' frame (x the subject's right, y forward, origin on the floor below the hips,
# table top at TABLE_HEIGHT_M) in this world (x the person's left, y backwards): a half turn about z
# and a shift that puts both tables at one height and the hip pivot under the chest.
_TAB_SHIFT = np.array([0.0, 0.05, TABLE_Z_M - TABLE_HEIGHT_M])
_FLIP = np.array([-1.0, -1.0, 1.0])
# Where each object stands (x, y of its grasped part, world), and the left hand rests.
_SLOTS = np.array([[-0.20, -0.42], [0.0, -0.33], [-0.40, -0.26]])
_LEFT_WRIST = np.array([0.29, -0.34])
_CLOTHES = np.array([[0.15, 0.25, 0.55], [0.55, 0.12, 0.12], [0.2, 0.45, 0.25], [0.35, 0.35, 0.38],
                     [0.25, 0.55, 0.55], [0.12, 0.12, 0.15], [0.5, 0.3, 0.55], [0.85, 0.85, 0.8],
                     [0.25, 0.5, 0.65], [0.4, 0.2, 0.1]])
_HAIR = np.array([[0.08, 0.06, 0.05], [0.3, 0.18, 0.08], [0.55, 0.4, 0.2], [0.45, 0.42, 0.4], [0.7, 0.55, 0.3]])
_DISTRACTORS = (  # a book and a glass (world geoms; pos filled in per person)
    '<geom name="background.book" type="box" size="0.11 0.075 0.02" pos="{x:.4f} {y:.4f} {z:.4f}" '
    'euler="0 0 {a:.3f}" rgba="0.6 0.15 0.1 1" contype="0" conaffinity="0"/>'
    '<geom name="background.book_pages" type="box" size="0.105 0.072 0.005" pos="{x:.4f} {y:.4f} {z2:.4f}" '
    'euler="0 0 {a:.3f}" rgba="0.92 0.9 0.82 1" contype="0" conaffinity="0"/>',
    '<geom name="background.glass" type="cylinder" size="0.032 0.055" pos="{x:.4f} {y:.4f} {z:.4f}" '
    'rgba="0.55 0.7 0.75 1" contype="0" conaffinity="0"/>',
)


def to_world(p_tab: np.ndarray) -> np.ndarray:
    """Table-top kinematics frame (..., 3) -> world (..., 3)."""
    return np.asarray(p_tab) * _FLIP + _TAB_SHIFT


def to_tabletop(p_world: np.ndarray) -> np.ndarray:
    """World (..., 3) -> table-top kinematics frame (..., 3)."""
    return (np.asarray(p_world) - _TAB_SHIFT) * _FLIP


class Actor(NamedTuple):
    """One person in their scene. face (3,) the face centre when seated (world); hip (3,) the trunk's
    pivot; subject: table-top anthropometry and style in the kinematics frame; rest_pos (K, 3), rest_rot
    (K, 3, 3): the objects' poses on the table; grips: (hand position (3,), rotation (3, 3)) of the hand
    in each object's frame; left_wrist (3,): where the left wrist rests on the table; xml: the scene."""

    person: Person
    look: PersonLook
    subject: Subject
    rig: StereoRig
    face: np.ndarray
    hip: np.ndarray
    rest_pos: np.ndarray
    rest_rot: np.ndarray
    grips: tuple
    left_wrist: np.ndarray
    xml: str


def persons(settings: VideoSettings) -> list[Person]:
    """The settings' demonstrators: the OAC generator's draw (7 men, 3 women for 10)."""
    return draw_persons(np.random.default_rng(settings.seed), settings.n_persons)


def _look(person: Person, rng: np.random.Generator) -> PersonLook:
    cloth = _CLOTHES[rng.integers(len(_CLOTHES))] * rng.uniform(0.85, 1.1)
    second = np.clip(cloth + rng.choice([-1, 1]) * rng.uniform(0.2, 0.4), 0, 1)
    hair = ("long" if rng.uniform() < 0.8 else "short") if person.female else \
        ("none" if rng.uniform() < 0.2 else "short")
    s = person.size
    return PersonLook(size=s, upper_arm_m=0.30 * s, forearm_m=0.27 * s,
                      cloth_rgba=tuple(np.clip(cloth, 0, 1)) + (1.0,), cloth2_rgba=tuple(second) + (1.0,),
                      cloth_pattern=CLOTH_PATTERNS[rng.integers(len(CLOTH_PATTERNS))],
                      hair_rgba=tuple(_HAIR[rng.integers(len(_HAIR))] * rng.uniform(0.8, 1.1)) + (1.0,), hair=hair,
                      short_sleeves=bool(rng.uniform() < 0.4), hand=hand_shape(person))


def _subject(look: PersonLook, face: np.ndarray, rng: np.random.Generator) -> Subject:
    """A table-top subject (style, speed) whose body is this person's: shoulder, sternum, eye, arm and
    hand lengths from the look, expressed in the kinematics frame."""
    points = body_points(look)
    return sample_subject(rng)._replace(
        shoulder=to_tabletop(face + points["r_shoulder"]), sternum=to_tabletop(face + points["sternum"]),
        eye=to_tabletop(face + points["eye"]), upper_arm=look.upper_arm_m, forearm=look.forearm_m,
        hand=look.hand.palm_length, finger=float(sum(look.hand.finger_lengths[1])))


def rig_for(person: Person, settings: VideoSettings) -> StereoRig:
    """The OAC generator's camera pose for this person, at the settings' image size."""
    centre, rot = camera_pose(person)
    return StereoRig(centre=tuple(centre), rotation=tuple(map(tuple, rot)), baseline_m=BASELINE_M,
                     width=settings.width, height=settings.height,
                     focal_px=FOCAL_PX * settings.width / IMAGE_SIZE_PX[0])


def actor(settings: VideoSettings, index: int) -> Actor:
    """Person `index` of the settings with their look, kinematics, table layout, rig and scene MJCF."""
    person = persons(settings)[index]
    rng = np.random.default_rng([settings.seed, 7, index])
    look = _look(person, rng)
    face = face_point(person)
    subject = _subject(look, face, rng)
    rest_pos, rest_rot, grips, geoms = [], [], [], []
    for k in range(len(OBJECTS)):
        grip = grip_of(k, person)
        _, rots = object_trajectory(k, person, np.random.default_rng([settings.seed, 8, index, k]), 4)
        slot = _SLOTS[k] + 0.02 * rng.standard_normal(2)
        rest_pos.append(np.array([slot[0], slot[1], TABLE_Z_M + grip.rest_height_m]))
        rest_rot.append(rots[0])
        grips.append(grip_pose(k, person))
        geoms.append(grip.geoms)
    distractors = []
    for i in range(settings.n_distractors):
        x, y = 0.5 + 0.04 * rng.standard_normal(), (-0.54 if i == 0 else -0.26) + 0.03 * rng.standard_normal()
        distractors.append(_DISTRACTORS[i].format(x=x, y=y, z=TABLE_Z_M + (0.02 if i == 0 else 0.055),
                                                  z2=TABLE_Z_M + 0.04, a=rng.uniform(-0.5, 0.5)))
    rig = rig_for(person, settings)
    left = np.array([*(_LEFT_WRIST * math.sqrt(person.size) + 0.015 * rng.standard_normal(2)),
                     TABLE_Z_M + 0.036 * person.size])
    return Actor(person=person, look=look, subject=subject, rig=rig, face=face, hip=to_world(HIP),
                 rest_pos=np.array(rest_pos), rest_rot=np.array(rest_rot), grips=tuple(grips), left_wrist=left,
                 xml=person_scene_xml(look, rig, geoms, distractors, TABLE, shadows=settings.shadows))
