"""A parametric right human hand written as MJCF: capsule fingers and metacarpals, an ellipsoid thenar
eminence, 20 hinge joints with human ranges, skin-coloured (the hand of GRASP §III-B's database).

Hand frame (the `hand` body): origin at the wrist, +x from the wrist towards the fingers, +y towards
the thumb (radial side), +z out of the back of the hand; the palm faces -z. Finger flexion is a
positive rotation about each segment's +y axis (it curls the finger towards -z, the palm side).

Joints, in qpos order (`JOINT_NAMES`): thumb CMC abduction and flexion, MCP and IP flexion; then for the
index, middle, ring and little finger MCP abduction, MCP, PIP and DIP flexion (4 + 4 x 4 = 20).
`JOINT_RANGES_DEG` are adult active ranges of motion (rounded from the hand-surgery literature).

Geoms are named after the bone they stand for ("palm_index", "thenar", "index_proximal", ...,
"thumb_distal"), so that contacts read as hand parts. Hand geoms collide with objects
(contype 1 / conaffinity 0 here, objects use contype 0 / conaffinity 1) but not with each other.

`HandShape` holds the anthropometry; `DEFAULT_SHAPE` is the database hand (an average adult male
hand, about 19 cm long and 8.5 cm wide), `TEST_SHAPE` the honestly different test hand (longer,
thinner fingers, wider and flatter palm, darker skin).
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from lfd_common import as_array, check_real, matrix_to_quat, quat_to_matrix

FINGERS: tuple[str, ...] = ("thumb", "index", "middle", "ring", "little")
_THUMB_JOINTS = ("cmc_abd", "cmc_flex", "mcp", "ip")
_FINGER_JOINTS = ("mcp_abd", "mcp", "pip", "dip")
JOINT_NAMES: tuple[str, ...] = (tuple(f"thumb_{j}" for j in _THUMB_JOINTS)
                                + tuple(f"{f}_{j}" for f in FINGERS[1:] for j in _FINGER_JOINTS))
N_JOINTS = len(JOINT_NAMES)
_SEGMENTS = ("metacarpal", "proximal", "distal")          # thumb
_FINGER_SEGMENTS = ("proximal", "middle", "distal")        # other fingers

# (low, high) in degrees, per joint, in JOINT_NAMES order
_THUMB_RANGES = ((-20.0, 60.0), (-15.0, 60.0), (-10.0, 60.0), (-20.0, 85.0))
_FINGER_RANGES = {
    "index": ((-20.0, 20.0), (-20.0, 90.0), (0.0, 110.0), (-5.0, 85.0)),
    "middle": ((-15.0, 15.0), (-20.0, 90.0), (0.0, 110.0), (-5.0, 85.0)),
    "ring": ((-15.0, 15.0), (-20.0, 90.0), (0.0, 110.0), (-5.0, 85.0)),
    "little": ((-20.0, 25.0), (-20.0, 90.0), (0.0, 110.0), (-5.0, 85.0)),
}
JOINT_RANGES_DEG: np.ndarray = np.array(_THUMB_RANGES + sum((_FINGER_RANGES[f] for f in FINGERS[1:]), ()))

# relaxed hand (hanging arm): slight flexion everywhere, thumb resting beside the index
NEUTRAL_POSTURE_DEG: np.ndarray = np.array(
    [10.0, 5.0, 10.0, 10.0] + [0.0, 15.0, 20.0, 10.0] * 4)


@dataclass(frozen=True)
class HandShape:
    """Anthropometry of a hand, in metres (checked when the object is made).

    Attributes:
        finger_lengths: per finger (thumb, index, middle, ring, little) the three segment lengths,
            bone to bone (thumb: metacarpal, proximal, distal; others: proximal, middle, distal
            phalanx), the distal one to the fingertip; each in [0.005, 0.1].
        finger_radius: radius of the index proximal phalanx; other segments scale from it.
        palm_length: wrist to the middle finger's MCP joint.
        palm_width: across the MCP joints.
        palm_thickness: the palm's thickness.
        skin_rgba: RGBA in [0, 1].

    Raises:
        ValueError: a field out of its range or of the wrong shape, naming the field.
    """

    finger_lengths: tuple[tuple[float, float, float], ...] = (
        (0.046, 0.032, 0.028), (0.045, 0.026, 0.022), (0.050, 0.030, 0.024),
        (0.047, 0.029, 0.023), (0.038, 0.021, 0.020))
    finger_radius: float = 0.0095
    palm_length: float = 0.095
    palm_width: float = 0.085
    palm_thickness: float = 0.030
    skin_rgba: tuple[float, float, float, float] = (0.87, 0.66, 0.55, 1.0)

    def __post_init__(self):
        lengths = as_array(self.finger_lengths, "finger_lengths", shape=(5, 3), min_value=0.005, max_value=0.1)
        object.__setattr__(self, "finger_lengths", tuple(tuple(float(v) for v in row) for row in lengths))
        check_real(self.finger_radius, "finger_radius", min_value=0.003, max_value=0.02)
        check_real(self.palm_length, "palm_length", min_value=0.05, max_value=0.15)
        check_real(self.palm_width, "palm_width", min_value=0.05, max_value=0.13)
        check_real(self.palm_thickness, "palm_thickness", min_value=0.015, max_value=0.05)
        rgba = as_array(self.skin_rgba, "skin_rgba", shape=(4,), min_value=0.0, max_value=1.0)
        object.__setattr__(self, "skin_rgba", tuple(float(v) for v in rgba))


DEFAULT_SHAPE = HandShape()
TEST_SHAPE = HandShape(
    finger_lengths=((0.048, 0.034, 0.029), (0.050, 0.029, 0.024), (0.055, 0.033, 0.026),
                    (0.052, 0.032, 0.025), (0.043, 0.024, 0.022)),
    finger_radius=0.0082, palm_length=0.098, palm_width=0.092, palm_thickness=0.026,
    skin_rgba=(0.68, 0.47, 0.36, 1.0))

# finger radius relative to the index proximal phalanx, per finger (thumb first) and segment
_RADIUS_SCALE = np.array([[1.25, 1.05, 0.95], [1.0, 0.92, 0.84], [1.03, 0.95, 0.86],
                          [0.97, 0.9, 0.82], [0.86, 0.8, 0.74]])
# MCP joint of each finger (index..little): (x as a fraction of palm length, y as a fraction of width)
_MCP_FRACTION = np.array([[0.97, 0.36], [1.0, 0.12], [0.97, -0.12], [0.9, -0.35]])
_MCP_SPLAY_DEG = np.array([4.0, 0.0, -4.0, -9.0])  # resting direction of the fingers in the palm plane


def _fmt(v) -> str:
    return " ".join(f"{float(x):.5f}" for x in np.ravel(v))


def _quat_from_axes(x_axis, z_axis) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of the frame with the given x axis and (orthogonalised) z axis."""
    x = np.asarray(x_axis, float) / np.linalg.norm(x_axis)
    z = np.asarray(z_axis, float) - np.dot(z_axis, x) * x
    z /= np.linalg.norm(z)
    return matrix_to_quat(np.stack([x, np.cross(z, x), z], 1))


def _thumb_frame() -> tuple[np.ndarray, np.ndarray]:
    """Thumb CMC frame: (quaternion in the hand frame, palmar-abduction axis in that frame).

    Local x runs along the metacarpal (radial-distal, slightly palmar); flexion (+ about local y) swings
    the thumb across the palm towards the little finger; abduction swings it out of the palm plane
    towards the palm side (-z of the hand)."""
    x = _THUMB_DIRECTION / np.linalg.norm(_THUMB_DIRECTION)
    q = _quat_from_axes(x, -_THUMB_FLEXION)
    palmar = np.array([0.0, 0.0, -1.0]) - x * (-x[2])
    axis = np.cross(x, palmar / np.linalg.norm(palmar))
    return q, quat_to_matrix(q).T @ axis


_THUMB_DIRECTION = np.array([0.6, 0.75, -0.2])
_THUMB_FLEXION = np.array([0.3, -0.7, -0.6])


def _joint(name: str, axis: str, deg_range) -> str:
    lo, hi = np.radians(deg_range)
    return f'<joint name="{name}" type="hinge" axis="{axis}" range="{lo:.4f} {hi:.4f}" limited="true" damping="0.05"/>'


def _chain(finger: str, segments, lengths, radii, joint_xml: list[str]) -> str:
    """Nested bodies of one finger: each segment a capsule along +x, the first body's joints given."""
    xml, closing = "", ""
    for s, (seg, length, r) in enumerate(zip(segments, lengths, radii)):
        end = length - r if s == len(segments) - 1 else length  # the fingertip's cap ends at the length
        jname = f"{finger}_{_FLEX_JOINT[finger][s]}"
        joints = "".join(joint_xml) if s == 0 else _joint(jname, "0 1 0", _range(jname))
        pos = "0 0 0" if s == 0 else f"{lengths[s - 1]:.5f} 0 0"
        xml += (f'<body name="{finger}_{seg}" pos="{pos}">{joints}'
                f'<geom name="{finger}_{seg}" class="skin" type="capsule" fromto="0 0 0 {max(end, 1e-3):.5f} 0 0" '
                f'size="{r:.5f}"/>')
        closing += "</body>"
    return xml + closing


_FLEX_JOINT = {"thumb": ("cmc_flex", "mcp", "ip"), **{f: ("mcp", "pip", "dip") for f in FINGERS[1:]}}


def _range(name: str):
    return JOINT_RANGES_DEG[JOINT_NAMES.index(name)]


def hand_body_xml(shape: HandShape = DEFAULT_SHAPE, pos: ArrayLike = (0.0, 0.0, 0.0),
                  quat: ArrayLike = (1.0, 0.0, 0.0, 0.0),
                  name: str = "hand") -> str:
    """The MJCF `<body>` of the hand, to put in a worldbody or another body.

    Needs the `<default>` class "skin" of `hand_defaults_xml(shape)` in the same model.

    Args:
        shape: the hand's anthropometry.
        pos: (3,) the root's position in its parent (the root is fixed).
        quat: (4,) its orientation in its parent (w, x, y, z).
        name: the root body's name.

    Returns:
        The `<body>` element, with the 20 joints of `JOINT_NAMES` and geoms named after the bones.
    """
    L, W, T = shape.palm_length, shape.palm_width, shape.palm_thickness
    r0 = shape.finger_radius
    parts = []
    # palm: one capsule per metacarpal, converging towards the wrist, thick enough to close the gaps
    r_palm = max(T / 2.0, W / 7.0)
    for k, finger in enumerate(FINGERS[1:]):
        fx, fy = _MCP_FRACTION[k]
        end = np.array([fx * L - r_palm * 0.6, fy * W * 0.95, 0.0])
        start = np.array([0.2 * L, fy * W * 0.55, 0.0])
        parts.append(f'<geom name="palm_{finger}" class="skin" type="capsule" fromto="{_fmt(start)} {_fmt(end)}" '
                     f'size="{r_palm * (1.0 - 0.08 * k):.5f}"/>')
    parts.append(f'<geom name="wrist" class="skin" type="ellipsoid" pos="{0.08 * L:.5f} 0 0" '
                 f'size="{0.12 * L:.5f} {0.32 * W:.5f} {0.45 * T:.5f}"/>')
    # thenar eminence (the thumb's muscle pad) on the palm side, radial
    parts.append(f'<geom name="thenar" class="skin" type="ellipsoid" pos="{0.35 * L:.5f} {0.22 * W:.5f} {-0.2 * T:.5f}" '
                 f'size="{0.26 * L:.5f} {0.17 * W:.5f} {0.42 * T:.5f}" euler="0 0 0.5"/>')
    # thumb: from the CMC joint on the radial, palmar side; resting direction radial-distal, nail sideways
    lengths = shape.finger_lengths[0]
    radii = r0 * _RADIUS_SCALE[0]
    q, abd_axis = _thumb_frame()
    joints = [_joint("thumb_cmc_abd", _fmt(abd_axis), _range("thumb_cmc_abd")),
              _joint("thumb_cmc_flex", "0 1 0", _range("thumb_cmc_flex"))]
    thumb = _chain("thumb", _SEGMENTS, lengths, radii, joints)
    parts.append(f'<body name="thumb_base" pos="{0.16 * L:.5f} {0.2 * W:.5f} {-0.25 * T:.5f}" quat="{_fmt(q)}">'
                 f'{thumb}</body>')
    for k, finger in enumerate(FINGERS[1:]):
        fx, fy = _MCP_FRACTION[k]
        yaw = np.radians(_MCP_SPLAY_DEG[k])
        q = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
        joints = [_joint(f"{finger}_mcp_abd", "0 0 1", _range(f"{finger}_mcp_abd")),
                  _joint(f"{finger}_mcp", "0 1 0", _range(f"{finger}_mcp"))]
        chain = _chain(finger, _FINGER_SEGMENTS, shape.finger_lengths[k + 1], r0 * _RADIUS_SCALE[k + 1], joints)
        parts.append(f'<body name="{finger}_base" pos="{fx * L:.5f} {fy * W:.5f} {-0.1 * T:.5f}" quat="{_fmt(q)}">'
                     f'{chain}</body>')
    return f'<body name="{name}" pos="{_fmt(pos)}" quat="{_fmt(quat)}">{"".join(parts)}</body>'


def hand_defaults_xml(shape: HandShape = DEFAULT_SHAPE) -> str:
    """The `<default class="skin">` that `hand_body_xml` geoms use (colour, contact filtering).

    Args:
        shape: the hand's anthropometry (its skin colour is used).

    Returns:
        The `<default>` element.
    """
    return (f'<default class="skin"><geom rgba="{_fmt(shape.skin_rgba)}" contype="1" conaffinity="0" '
            f'condim="3" friction="1 0.01 0.001" density="1100"/></default>')


def hand_model_xml(shape: HandShape = DEFAULT_SHAPE) -> str:
    """A stand-alone MJCF model with only the hand (fixed at the origin, identity orientation).

    Args:
        shape: the hand's anthropometry.

    Returns:
        The MJCF text.
    """
    return (f'<mujoco model="human_hand"><compiler angle="radian"/><default>{hand_defaults_xml(shape)}</default>'
            f'<worldbody><light pos="0 0 1" dir="0 0 -1"/>{hand_body_xml(shape)}</worldbody></mujoco>')


def posture_qpos(posture_deg: ArrayLike) -> np.ndarray:
    """The hand's qpos for a posture, checked against the joint ranges.

    Args:
        posture_deg: (20,) joint angles in degrees, `JOINT_NAMES` order.

    Returns:
        (20,) radians.

    Raises:
        ValueError: a posture of the wrong shape, or a joint outside its range (naming the joint).
    """
    p = as_array(posture_deg, "posture_deg", shape=(N_JOINTS,))
    lo, hi = JOINT_RANGES_DEG[:, 0], JOINT_RANGES_DEG[:, 1]
    bad = np.flatnonzero((p < lo - 1e-6) | (p > hi + 1e-6))
    if bad.size:
        j = bad[0]
        raise ValueError(f"posture_deg: joint {JOINT_NAMES[j]} = {p[j]:.1f} deg is outside its range "
                         f"[{lo[j]:.0f}, {hi[j]:.0f}]")
    return np.radians(p)


def clip_posture(posture_deg: ArrayLike) -> np.ndarray:
    """Clip joint angles to the human ranges (`JOINT_RANGES_DEG`).

    Args:
        posture_deg: (..., 20) joint angles in degrees.

    Returns:
        (..., 20) the clipped angles.

    Raises:
        ValueError: a last axis other than 20, or non-finite values.
    """
    p = as_array(posture_deg, "posture_deg")
    if p.shape[-1] != N_JOINTS:
        raise ValueError(f"posture_deg: expected a last axis of {N_JOINTS}, got shape {p.shape}")
    return np.clip(p, JOINT_RANGES_DEG[:, 0], JOINT_RANGES_DEG[:, 1])
