"""The demonstrator's body as MJCF for the table-top demonstration scene (`sim.scenes.person_scene_xml`).

Every body part is a mocap body (no physics): a recording sets their poses frame by frame.

Trunk frame (the mocap body "trunk"): origin at the face centre (the point the OAC motions are
relative to), axes those of the world when the person sits upright: x the person's left, y backwards
(the person faces -y, the cameras), z up. The trunk carries the head (a skin ellipsoid with eyes,
nose and mouth), hair, neck, chest and shoulders. Arms are separate mocap bodies: each capsule
segment's frame has its origin at the proximal joint and z along the segment (`segment_pose`).

- right arm: "r_upper" (shoulder -> elbow), "r_fore" (elbow -> wrist), "r_hand_mount" holding the
  human hand of `sim.hands.hand_body_xml` (body "r_hand", 20 finger joints = the model's qpos) in its
  hand frame (origin at the wrist, +x to the fingers, +y to the thumb, palm towards -z);
- left arm: "l_upper", "l_fore", "l_hand": a simple hand (palm, fingers, thumb) in the same frame
  convention (x to the fingers, palm towards -z; the thumb on -y, it is a left hand).

Geoms are named "<part>.<what>", part one of `PART_PREFIXES`: "person" (clothing, hair),
"skin" (skin that is neither the right hand nor the face: left hand, bare forearms), "face" (head skin,
eyes, nose, mouth, neck). The scene's part labels (`sim.scenes.PART_NAMES`) are read from these names.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lfd_common import as_array, check_choice, check_real, matrix_to_quat
from sim._src.human_hand import DEFAULT_SHAPE, HandShape, hand_body_xml

CLOTH_PATTERNS: tuple[str, ...] = ("plain", "checker", "speckle", "grid")
HAIR_STYLES: tuple[str, ...] = ("none", "short", "long")
PART_PREFIXES: tuple[str, ...] = ("background", "person", "hand", "skin", "face")

# Trunk-frame points of an average man (size 1), metres; everything scales with the person's size.
_HEAD = np.array([0.0, 0.06, 0.0])
_HEAD_SIZE = np.array([0.075, 0.085, 0.11])
_R_SHOULDER = np.array([-0.18, 0.08, -0.24])
_STERNUM = np.array([0.0, -0.01, -0.30])
_EYE = np.array([0.0, -0.02, 0.025])


@dataclass(frozen=True)
class PersonLook:
    """How a demonstrator looks (checked when the object is made).

    Attributes:
        size: body size (1 = average man, in [0.6, 1.5]); every trunk point scales with it.
        upper_arm_m: upper arm length (m, in [0.15, 0.5]).
        forearm_m: forearm length (m, in [0.15, 0.5]).
        cloth_rgba: the clothing's colour (RGBA in [0, 1]).
        cloth2_rgba: the second colour, which draws the pattern.
        cloth_pattern: the clothing pattern, one of `CLOTH_PATTERNS`.
        hair_rgba: the hair's colour.
        hair: the hair style, "none", "short" or "long".
        short_sleeves: short sleeves (bare forearms) or long.
        hand: the right hand's shape; its `skin_rgba` is the skin of the whole person.

    Raises:
        ValueError: a field out of its range or of the wrong type, naming the field.
    """

    size: float = 1.0
    upper_arm_m: float = 0.30
    forearm_m: float = 0.27
    cloth_rgba: tuple[float, float, float, float] = (0.2, 0.3, 0.6, 1.0)
    cloth2_rgba: tuple[float, float, float, float] = (0.8, 0.8, 0.85, 1.0)
    cloth_pattern: str = "plain"
    hair_rgba: tuple[float, float, float, float] = (0.2, 0.12, 0.06, 1.0)
    hair: str = "short"
    short_sleeves: bool = False
    hand: HandShape = DEFAULT_SHAPE

    def __post_init__(self):
        check_real(self.size, "size", min_value=0.6, max_value=1.5)
        check_real(self.upper_arm_m, "upper_arm_m", min_value=0.15, max_value=0.5)
        check_real(self.forearm_m, "forearm_m", min_value=0.15, max_value=0.5)
        for name in ("cloth_rgba", "cloth2_rgba", "hair_rgba"):
            rgba = as_array(getattr(self, name), name, shape=(4,), min_value=0.0, max_value=1.0)
            object.__setattr__(self, name, tuple(float(v) for v in rgba))
        check_choice(self.cloth_pattern, "cloth_pattern", CLOTH_PATTERNS)
        check_choice(self.hair, "hair", HAIR_STYLES)
        if not isinstance(self.hand, HandShape):
            raise ValueError(f"hand: expected a HandShape, got {type(self.hand).__name__}")

    @property
    def skin_rgba(self) -> tuple[float, float, float, float]:
        """The person's skin colour: the right hand's."""
        return self.hand.skin_rgba


def body_points(look: PersonLook) -> dict[str, np.ndarray]:
    """Named points of the person's trunk, in the trunk frame (origin at the face centre).

    Args:
        look: the person.

    Returns:
        A dict of (3,) points in metres: "r_shoulder", "l_shoulder" (joint centres), "sternum" (front
            of the chest), "eye" (between the eyes), "head" (the head ellipsoid's centre).
    """
    s = look.size
    return {"r_shoulder": s * _R_SHOULDER, "l_shoulder": s * _R_SHOULDER * np.array([-1.0, 1.0, 1.0]),
            "sternum": s * _STERNUM, "eye": s * _EYE, "head": s * _HEAD}


def segment_pose(start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mocap pose (pos (..., 3), quat (..., 4) w x y z) of a segment body whose local z runs from
    `start` (..., 3) towards `end` (..., 3)."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    z = end - start
    z = z / np.maximum(np.linalg.norm(z, axis=-1, keepdims=True), 1e-12)
    helper = np.where(np.abs(z[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    x = helper - np.sum(helper * z, -1, keepdims=True) * z
    x = x / np.linalg.norm(x, axis=-1, keepdims=True)
    return start, matrix_to_quat(np.stack([x, np.cross(z, x), z], axis=-1))


def _v(v) -> str:
    return " ".join(f"{float(x):.5f}" for x in np.ravel(v))


def _rgba(c) -> str:
    return " ".join(f"{float(x):.4f}" for x in c)


def look_assets_xml(look: PersonLook) -> str:
    """`<texture>`/`<material>` elements (inside an `<asset>`) of the clothing ("cloth"), skin
    ("skin_mat"), hair, eyes and lips."""
    c1, c2 = _rgba(look.cloth_rgba[:3]), _rgba(look.cloth2_rgba[:3])
    texture = {
        "plain": "",
        "checker": f'<texture name="cloth" type="2d" builtin="checker" rgb1="{c1}" rgb2="{c2}" width="64" height="64"/>',
        "speckle": (f'<texture name="cloth" type="2d" builtin="flat" rgb1="{c1}" rgb2="{c1}" mark="random" '
                    f'random="0.12" markrgb="{c2}" width="128" height="128"/>'),
        "grid": (f'<texture name="cloth" type="2d" builtin="flat" rgb1="{c1}" rgb2="{c1}" mark="edge" '
                 f'markrgb="{c2}" width="32" height="32"/>'),
    }[look.cloth_pattern]
    cloth = (f'<material name="cloth" rgba="{_rgba(look.cloth_rgba)}" specular="0.05"/>' if not texture else
             f'<material name="cloth" texture="cloth" texrepeat="5 5" specular="0.05"/>')
    return (texture + cloth + f'<material name="skin_mat" rgba="{_rgba(look.skin_rgba)}" specular="0.15" shininess="0.3"/>'
            + f'<material name="hair" rgba="{_rgba(look.hair_rgba)}" specular="0.1"/>'
            + '<material name="eye" rgba="0.08 0.06 0.05 1"/>'
            + f'<material name="lips" rgba="{_rgba(np.clip(np.array(look.skin_rgba) * [0.85, 0.55, 0.55, 1], 0, 1))}"/>')


def _geom(name: str, material: str, **attrs) -> str:
    extra = " ".join(f'{k}="{v}"' for k, v in attrs.items())
    return f'<geom name="{name}" material="{material}" contype="0" conaffinity="0" {extra}/>'


def _trunk_xml(look: PersonLook) -> str:
    s = look.size
    p = body_points(look)
    head = p["head"]
    g = [
        _geom("face.head", "skin_mat", type="ellipsoid", pos=_v(head), size=_v(s * _HEAD_SIZE)),
        _geom("face.nose", "skin_mat", type="ellipsoid", pos=_v(s * np.array([0.0, -0.024, 0.0])),
              size=_v(s * np.array([0.011, 0.014, 0.02]))),
        _geom("face.mouth", "lips", type="ellipsoid", pos=_v(s * np.array([0.0, -0.016, -0.048])),
              size=_v(s * np.array([0.02, 0.006, 0.006]))),
        _geom("face.neck", "skin_mat", type="capsule", size=f"{0.048 * s:.5f}",
              fromto=_v(s * np.array([0.0, 0.07, -0.07, 0.0, 0.08, -0.17]))),
        _geom("person.chest", "cloth", type="ellipsoid", pos=_v(s * np.array([0.0, 0.10, -0.42])),
              size=_v(s * np.array([0.17, 0.11, 0.27]))),
        _geom("person.shoulders", "cloth", type="capsule", size=f"{0.062 * s:.5f}",
              fromto=_v(np.concatenate([p["r_shoulder"] + s * np.array([0.02, 0.0, 0.01]),
                                        p["l_shoulder"] + s * np.array([-0.02, 0.0, 0.01])]))),
        _geom("person.collar", "cloth", type="capsule", size=f"{0.05 * s:.5f}",
              fromto=_v(s * np.array([-0.06, 0.09, -0.19, 0.06, 0.09, -0.19]))),
    ]
    for side in (-1.0, 1.0):
        g.append(_geom(f"face.eye_{'r' if side < 0 else 'l'}", "eye", type="sphere", size=f"{0.011 * s:.5f}",
                       pos=_v(s * np.array([0.032 * side, -0.009, 0.025]))))
    if look.hair != "none":
        g.append(_geom("person.hair", "hair", type="ellipsoid", pos=_v(s * np.array([0.0, 0.08, 0.05])),
                       size=_v(s * np.array([0.081, 0.086, 0.096]))))
    if look.hair == "long":
        g.append(_geom("person.hair_long", "hair", type="ellipsoid", pos=_v(s * np.array([0.0, 0.11, -0.07])),
                       size=_v(s * np.array([0.088, 0.05, 0.15]))))
    return f'<body name="trunk" mocap="true">{"".join(g)}</body>'


def _segment_xml(name: str, geom_name: str, material: str, length: float, radius: float) -> str:
    return (f'<body name="{name}" mocap="true">'
            + _geom(geom_name, material, type="capsule", size=f"{radius:.5f}", fromto=f"0 0 0 0 0 {length:.5f}")
            + "</body>")


def _left_hand_xml(look: PersonLook) -> str:
    k = look.hand.palm_length / DEFAULT_SHAPE.palm_length
    r = look.hand.finger_radius
    g = [_geom("skin.l_palm", "skin_mat", type="ellipsoid", pos=_v(k * np.array([0.05, 0.0, 0.0])),
               size=_v(k * np.array([0.052, 0.04, 0.014])))]
    for i, y in enumerate(np.linspace(0.028, -0.028, 4)):
        length = k * (0.075 if i in (1, 2) else 0.062)
        g.append(_geom(f"skin.l_finger{i}", "skin_mat", type="capsule", size=f"{r * 0.95:.5f}",
                       fromto=_v(np.array([0.095 * k, k * y, 0.0, 0.095 * k + length, k * y * 1.1, -0.004]))))
    g.append(_geom("skin.l_thumb", "skin_mat", type="capsule", size=f"{r * 1.1:.5f}",
                   fromto=_v(k * np.array([0.03, -0.035, -0.008, 0.085, -0.062, -0.006]))))
    return f'<body name="l_hand" mocap="true">{"".join(g)}</body>'


def person_body_xml(look: PersonLook) -> str:
    """The person's mocap bodies (to put in a worldbody); needs `look_assets_xml(look)` in the
    model's `<asset>` and `sim.hands.hand_defaults_xml(look.hand)` in its `<default>`."""
    s = look.size
    fore_part, fore_mat = ("skin", "skin_mat") if look.short_sleeves else ("person", "cloth")
    return "".join([
        _trunk_xml(look),
        _segment_xml("r_upper", "person.r_upper", "cloth", look.upper_arm_m, 0.047 * s),
        _segment_xml("r_fore", f"{fore_part}.r_fore", fore_mat, look.forearm_m, 0.036 * s),
        f'<body name="r_hand_mount" mocap="true">{hand_body_xml(look.hand, name="r_hand")}</body>',
        _segment_xml("l_upper", "person.l_upper", "cloth", look.upper_arm_m, 0.047 * s),
        _segment_xml("l_fore", f"{fore_part}.l_fore", fore_mat, look.forearm_m, 0.036 * s),
        _left_hand_xml(look),
    ])
