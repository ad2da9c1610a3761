"""The six grasp classes of GRASP and MAP, the object each one holds, and the human-to-robot class mappings.

The classes are Cutkosky's numbers as the papers use them; the mappings are GRASP (IROS 2008) Fig. 2
and MAP (2009) Fig. 2.

One source for everything that grasps: the human reference grasps, the rendered view database and the
robot grasp execution all take their objects from here.

Geometry is chosen so that every physics backend can collide it with capsule fingers and a plane table:
MJX's JAX implementation (3.17) has no cylinder–box or box–ellipsoid pair, so objects are cylinders,
spheres and one box, the table is a plane, and hands are built from capsules.
"""
from __future__ import annotations

from dataclasses import dataclass

from lfd_common import check_choice

# Cutkosky numbers used by the papers, in the papers' order.
GRASP_CLASSES: tuple[int, ...] = (1, 2, 4, 9, 10, 12)
GRASP_NAMES: dict[int, str] = {
    1: "Large Diameter",
    2: "Small Diameter",
    4: "Abducted Thumb",
    9: "Pinch",
    10: "Power Sphere",
    12: "Precision Disc",
}
# MAP §III: grasps whose execution expects the palm to touch the object first (tactile correction).
VOLAR_GRASPS: frozenset[int] = frozenset({1, 2})


@dataclass(frozen=True)
class GraspObject:
    """A rigid object on the table, the one a grasp class holds (`GRASP_OBJECTS`).

    The object's frame is at its centre; it rests on the table with its z axis up.

    Attributes:
        name: what it stands for ("large cylinder (bottle)", ...).
        geom_type: MuJoCo's geom type: "cylinder", "sphere" or "box".
        size: MuJoCo's size, in metres (cylinder: radius, half-height; sphere: radius; box: half
            sizes).
        mass_kg: its mass.
        friction: MuJoCo's sliding, torsional and rolling friction.
    """

    name: str
    geom_type: str
    size: tuple[float, ...]
    mass_kg: float
    friction: tuple[float, float, float] = (1.0, 0.01, 0.001)

    @property
    def rest_height_m(self) -> float:
        """Height of the object's centre above the table top when it rests upright."""
        return self.size[0] if self.geom_type == "sphere" else self.size[-1]

    def geom_xml(self, name: str = "object", rgba: str = "0 0 0 1", extra: str = "") -> str:
        """One MJCF `<geom>` element for this object.

        Args:
            name: the geom's name.
            rgba: its colour as MJCF text (black by default, as in GRASP §III-B).
            extra: more MJCF attributes, as text.

        Returns:
            The `<geom .../>` element.
        """
        size = " ".join(f"{s:.4f}" for s in self.size)
        friction = " ".join(f"{f:g}" for f in self.friction)
        return (f'<geom name="{name}" type="{self.geom_type}" size="{size}" mass="{self.mass_kg:g}" '
                f'friction="{friction}" rgba="{rgba}" {extra}/>')


GRASP_OBJECTS: dict[int, GraspObject] = {
    1: GraspObject("large cylinder (bottle)", "cylinder", (0.040, 0.090), 0.30),
    2: GraspObject("thin cylinder (handle)", "cylinder", (0.015, 0.100), 0.15),
    4: GraspObject("medium cylinder (glass)", "cylinder", (0.030, 0.060), 0.15),
    9: GraspObject("small cube", "box", (0.015, 0.015, 0.015), 0.03),
    10: GraspObject("ball", "sphere", (0.045,), 0.20),
    12: GraspObject("disc (lid)", "cylinder", (0.050, 0.010), 0.10),
}

ROBOT_GRASPS: dict[str, tuple[str, ...]] = {
    "barrett": ("Wrap", "Two-finger Thumb", "Precision Disc"),
    "karlsruhe": ("Power", "Wrap", "Sphere", "Disc"),
}
# Human class -> robot preshape. "map2009" is MAP 2009 Fig. 2; "iros2008" is GRASP (IROS 2008) Fig. 2,
# which only has the Barrett hand.
GRASP_MAPPINGS: dict[str, dict[str, dict[int, str]]] = {
    "map2009": {
        "barrett": {1: "Wrap", 2: "Wrap", 4: "Two-finger Thumb", 9: "Two-finger Thumb",
                    10: "Precision Disc", 12: "Precision Disc"},
        "karlsruhe": {1: "Power", 2: "Wrap", 4: "Power", 9: "Power", 10: "Sphere", 12: "Disc"},
    },
    "iros2008": {
        "barrett": {1: "Wrap", 2: "Wrap", 4: "Wrap", 9: "Two-finger Thumb", 10: "Wrap",
                    12: "Precision Disc"},
    },
}


def check_grasp_class(grasp: int, name: str = "grasp") -> int:
    """Check that `grasp` is one of the six grasp classes.

    Args:
        grasp: a Cutkosky number.
        name: the argument name that an error names.

    Returns:
        `grasp` as an int.

    Raises:
        ValueError: `grasp` is not one of `GRASP_CLASSES`, naming `name`.
    """
    return int(check_choice(grasp, name, GRASP_CLASSES))


def robot_grasp_for(grasp: int, hand: str, mapping: str = "map2009") -> str:
    """The robot preshape that a human grasp class maps to (MAP Fig. 2, GRASP Fig. 2).

    Args:
        grasp: the human grasp class (`GRASP_CLASSES`).
        hand: "barrett" or "karlsruhe".
        mapping: "map2009" (MAP Fig. 2) or "iros2008" (GRASP Fig. 2, Barrett only).

    Returns:
        The robot preshape's name, one of `ROBOT_GRASPS[hand]`.

    Raises:
        ValueError: an unknown grasp class, hand or mapping, or a hand the mapping does not have.
    """
    mapping = check_choice(mapping, "mapping", tuple(GRASP_MAPPINGS))
    hand = check_choice(hand, "hand", tuple(GRASP_MAPPINGS[mapping]))
    return GRASP_MAPPINGS[mapping][hand][check_grasp_class(grasp)]
