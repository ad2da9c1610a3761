"""The two robot hands of MAP §III as data: fingers, palm, actuated DoF, preshapes (MJCF: `sim.hands.grasp_model`).

A Barrett-like hand (three fingers, one spread DoF shared by two of them, coupled distal links) and a
Karlsruhe-like hand (human-like: an opposable thumb and four fingers). Hand frame (both hands): origin
at the centre of the palm surface, +z the palm normal (the approach direction: the object lies at +z
when the hand grasps it), x the axis a wrap closes around. Finger frames: see `Finger`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lfd_common import check_choice
from sim._src.grasp_objects import ROBOT_GRASPS

__all__ = ["HANDS", "HAND_NAMES", "Finger", "HandSpec", "hand_spec", "preshape"]

HAND_NAMES: tuple[str, ...] = ("barrett", "karlsruhe")


@dataclass(frozen=True)
class Finger:
    """One finger of a robot hand: base position and frame in the hand frame, link lengths, radius.

    The finger extends along its z axis and flexes about its x axis towards its -y axis.

    Attributes:
        name: the finger's name (its bodies, geoms and sites are named after it).
        pos: (3,) the finger base's position in the hand frame (m).
        xyaxes: (6,) the finger frame's x and y axes in the hand frame.
        lengths: the proximal and distal link lengths (m).
        radius: the links' capsule radius (m).
        flex_dof: the actuator that flexes the proximal link.
        distal_dof: the actuator of the distal link; None: the distal joint is coupled to the flexion.
        extra_joint: "spread" or "oppose": a hinge before the flexion (about the finger's z axis / y
            axis); None: none.
        extra_dof: the actuator that drives the extra hinge.
        extra_sign: the direction of the spread hinge's axis.
    """

    name: str
    pos: tuple[float, float, float]
    xyaxes: tuple[float, ...]
    lengths: tuple[float, float]
    radius: float
    flex_dof: str
    distal_dof: str | None = None
    extra_joint: str | None = None
    extra_dof: str | None = None
    extra_sign: float = 1.0


@dataclass(frozen=True)
class HandSpec:
    """A robot hand of MAP §III: fingers, palm capsule, actuated hand DoF and grasp preshapes.

    Attributes:
        name: "barrett" or "karlsruhe".
        palm_fromto: (6,) the palm capsule's ends in the hand frame (m).
        palm_radius: its radius (m).
        fingers: the fingers.
        dofs: the actuated hand DoF, in actuator order.
        preshapes: `preshapes[name] = (open, closed)`, each (n_dof,) joint targets in radians in
            `dofs` order (MAP Fig. 2).
        distal_coupling: (c0, c1): distal = c0 + c1 * proximal for coupled distal joints.
        finger_kp: the finger servos' position gain.
        finger_force: their force limit.
        dof_range: joint ranges (rad) of DoF whose range differs from the default.
    """

    name: str
    palm_fromto: tuple[float, ...]
    palm_radius: float
    fingers: tuple[Finger, ...]
    dofs: tuple[str, ...]
    preshapes: dict[str, tuple[tuple[float, ...], tuple[float, ...]]]
    distal_coupling: tuple[float, float]
    finger_kp: float
    finger_force: float
    dof_range: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def link_names(self) -> tuple[str, ...]:
        """Palm first, then each finger's proximal and distal link."""
        return ("palm",) + tuple(f"{f.name}_{part}" for f in self.fingers for part in ("prox", "dist"))

    @property
    def link_finger(self) -> np.ndarray:
        """(L,) int: 0 for the palm, k for a link of finger k (1-based, `fingers` order)."""
        return np.array([0] + [k + 1 for k in range(len(self.fingers)) for _ in range(2)])


_BARRETT = HandSpec(
    name="barrett",
    # palm: a capsule across the hand joining thumb side and finger side, surface at z = 0
    palm_fromto=(0.0, -0.05, -0.028, 0.0, 0.05, -0.028), palm_radius=0.028,
    fingers=(
        Finger("f1", (0.026, 0.062, 0.0), (1, 0, 0, 0, 1, 0), (0.070, 0.058), 0.011, "flex1",
               extra_joint="spread", extra_dof="spread", extra_sign=-1.0),
        Finger("f2", (-0.026, 0.062, 0.0), (1, 0, 0, 0, 1, 0), (0.070, 0.058), 0.011, "flex2",
               extra_joint="spread", extra_dof="spread", extra_sign=1.0),
        Finger("f3", (0.0, -0.062, 0.0), (-1, 0, 0, 0, -1, 0), (0.070, 0.058), 0.011, "flex3"),
    ),
    dofs=("spread", "flex1", "flex2", "flex3"),
    # Fig. 2 g-i: Wrap (large aperture, fingers parallel against the thumb), Two-finger Thumb (small
    # aperture, tips pinch), Precision Disc (fingers spread 60 degrees: a tripod). Two-finger Thumb
    # (measured on the 3 cm cube): the two finger bases are 52 mm apart, so unspread they
    # straddle a small object and at most one touches it, at its edge, against the thumb (the cube spun
    # or was squeezed out in every trial); spread 0.6 rad their tips meet on the thumb's line. The
    # closing target 0.6 rad (not 1.5) keeps the squeeze below the finger torque limit: at the limit
    # the cube, held higher by the thumb than by the fingers, tilted and slipped out.
    preshapes={
        "Wrap": ((0.0, 0.0, 0.0, 0.0), (0.0, 2.2, 2.2, 2.2)),
        "Two-finger Thumb": ((0.6, 0.1, 0.1, 0.1), (0.6, 0.6, 0.6, 0.6)),
        "Precision Disc": ((1.05, 0.0, 0.0, 0.0), (1.05, 1.5, 1.5, 1.5)),
    },
    distal_coupling=(0.0, 0.5),  # the distal link follows the proximal at half its angle
    finger_kp=3.0, finger_force=1.6,
    dof_range={"spread": (0.0, 3.14), "flex1": (0.0, 2.44), "flex2": (0.0, 2.44), "flex3": (0.0, 2.44)},
)

# Karlsruhe-like: human-like, fingers extend along +y in the palm plane and curl towards +z; shorter
# fingers than the Barrett, and the thumb base close to the finger bases (MAP §IV-A names both).
_K_FINGER_AXES = (1, 0, 0, 0, 0, -1)  # finger z = hand +y, closing (-y_f) = hand +z
_KARLSRUHE = HandSpec(
    name="karlsruhe",
    palm_fromto=(-0.03, 0.0, -0.025, 0.03, 0.0, -0.025), palm_radius=0.025,
    fingers=(
        Finger("thumb", (0.015, -0.045, -0.01), (0, -1, 0, 1, 0, 0), (0.040, 0.032), 0.009, "thumb_flex",
               extra_joint="oppose", extra_dof="thumb_rot"),
        Finger("index", (0.027, 0.040, -0.01), _K_FINGER_AXES, (0.045, 0.035), 0.0085, "index_prox",
               distal_dof="index_dist"),
        Finger("middle", (0.009, 0.042, -0.01), _K_FINGER_AXES, (0.048, 0.036), 0.0085, "middle_prox",
               distal_dof="middle_dist"),
        Finger("ring", (-0.009, 0.040, -0.01), _K_FINGER_AXES, (0.045, 0.034), 0.0085, "ring_flex"),
        Finger("little", (-0.027, 0.036, -0.01), _K_FINGER_AXES, (0.038, 0.030), 0.008, "little_flex"),
    ),
    dofs=("thumb_rot", "thumb_flex", "index_prox", "index_dist", "middle_prox", "middle_dist",
          "ring_flex", "little_flex"),
    # Fig. 2 j-m: Power (thumb opposed to four parallel fingers), Wrap (thumb not opposed: it flexes
    # across the palm), Sphere (fingers bent more), Disc (thumb opposed, fingers straighter). The thumb
    # stands on the palm pointing along the palm normal; thumb_rot turns its flexion plane from across
    # the palm (0) to towards the fingers (pi/2, opposition), and an opposing thumb starts extended
    # away from the fingers (negative flexion) so the object passes it on the approach.
    preshapes={
        "Power": ((1.45, -0.5, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25),
                  (1.45, 1.4, 1.6, 1.3, 1.6, 1.3, 1.6, 1.6)),
        "Wrap": ((0.25, -0.3, 0.2, 0.2, 0.2, 0.2, 0.2, 0.2),
                 (0.25, 1.0, 1.7, 1.4, 1.7, 1.4, 1.7, 1.7)),
        "Sphere": ((1.2, -0.5, 0.55, 0.35, 0.55, 0.35, 0.55, 0.55),
                   (1.2, 1.3, 1.5, 1.2, 1.5, 1.2, 1.5, 1.5)),
        "Disc": ((1.4, -0.6, 0.15, 0.1, 0.15, 0.1, 0.15, 0.15),
                 (1.4, 1.2, 1.2, 0.9, 1.2, 0.9, 1.2, 1.2)),
    },
    distal_coupling=(0.0, 0.8),
    finger_kp=2.0, finger_force=1.0,
    dof_range={"thumb_flex": (-0.8, 2.0)},
)
HANDS: dict[str, HandSpec] = {"barrett": _BARRETT, "karlsruhe": _KARLSRUHE}


def hand_spec(hand: str) -> HandSpec:
    """The description of a robot hand.

    Args:
        hand: "barrett" or "karlsruhe".

    Returns:
        Its `HandSpec`.

    Raises:
        ValueError: an unknown hand, naming `hand`.
    """
    return HANDS[check_choice(hand, "hand", HAND_NAMES)]


def preshape(hand: str, robot_grasp: str) -> tuple[np.ndarray, np.ndarray]:
    """The open and closed hand-DoF targets of a robot grasp (MAP Fig. 2).

    Args:
        hand: "barrett" or "karlsruhe".
        robot_grasp: one of `ROBOT_GRASPS[hand]`.

    Returns:
        (open (n_dof,), closed (n_dof,)) in radians, `HandSpec.dofs` order.

    Raises:
        ValueError: an unknown hand or robot grasp.
    """
    spec = hand_spec(hand)
    name = check_choice(robot_grasp, "robot_grasp", ROBOT_GRASPS[spec.name])
    open_, closed = spec.preshapes[name]
    return np.asarray(open_, float), np.asarray(closed, float)
