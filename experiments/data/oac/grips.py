"""The three objects (MJCF geoms in the grasped-part frame) and how each class holds its object."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from experiments.data.oac.settings import Person


_DARK = "0.13 0.13 0.14 1"
_RIM = "0.3 0.3 0.32 1"
_CERAMIC = "0.9 0.9 0.86 1"
# MJCF geoms of each object in its grasped-part frame: z the grasped axis, x away from the palm.
_OBJECT_GEOMS: tuple[str, ...] = (
    # binoculars: the right barrel is grasped; the left one is 7.5 cm away; eyepieces at -z (the face)
    f"""<geom type="cylinder" size="0.036 0.055" rgba="{_DARK}"/>
        <geom type="cylinder" size="0.036 0.055" pos="0.075 0 0" rgba="{_DARK}"/>
        <geom type="cylinder" size="0.039 0.008" pos="0 0 0.055" rgba="{_RIM}"/>
        <geom type="cylinder" size="0.039 0.008" pos="0.075 0 0.055" rgba="{_RIM}"/>
        <geom type="cylinder" size="0.019 0.016" pos="0 0 -0.07" rgba="{_RIM}"/>
        <geom type="cylinder" size="0.019 0.016" pos="0.075 0 -0.07" rgba="{_RIM}"/>
        <geom type="box" size="0.02 0.012 0.035" pos="0.0375 0 -0.01" rgba="{_DARK}"/>
        <geom type="cylinder" size="0.011 0.013" pos="0.0375 0.012 -0.03" euler="1.5708 0 0" rgba="{_RIM}"/>""",
    # cup: a ceramic cylinder held around its body, the handle away from the palm
    f"""<geom type="cylinder" size="0.034 0.045" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.036 0.004" pos="0 0 0.043" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0.032 0 0.028 0.058 0 0.022" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0.058 0 0.022 0.058 0 -0.018" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0.058 0 -0.018 0.032 0 -0.025" rgba="{_CERAMIC}"/>""",
    # pitcher: the same ceramic, held by its handle; body, rim and spout away from the palm
    f"""<geom type="capsule" size="0.011" fromto="0 0 -0.05 0 0 0.05" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.009" fromto="0 0 0.05 0.045 0 0.068" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.009" fromto="0 0 -0.05 0.045 0 -0.062" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.062 0.1" pos="0.105 0 0" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.065 0.005" pos="0.105 0 0.097" rgba="{_CERAMIC}"/>
        <geom type="box" size="0.025 0.016 0.01" pos="0.172 0 0.092" euler="0 -0.5 0" rgba="{_CERAMIC}"/>""",
)
_CUP_BY_HANDLE_GEOMS = f"""<geom type="capsule" size="0.007" fromto="0 0 -0.02 0 0 0.02" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0 0 0.02 0.026 0 0.028" rgba="{_CERAMIC}"/>
        <geom type="capsule" size="0.006" fromto="0 0 -0.02 0.026 0 -0.025" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.034 0.045" pos="0.058 0 0" rgba="{_CERAMIC}"/>
        <geom type="cylinder" size="0.036 0.004" pos="0.058 0 0.043" rgba="{_CERAMIC}"/>"""


class _Grip(NamedTuple):
    """How an object is held: the Cutkosky grasp, the object's geoms in the grasped-part frame, the
    object window's centre (3,) in that frame and radius (m), and the grasped part's height above the
    table at rest (m)."""

    grasp: int
    geoms: str
    centre_m: np.ndarray
    radius_m: float
    rest_height_m: float


_GRIPS: tuple[_Grip, ...] = (
    _Grip(1, _OBJECT_GEOMS[0], np.array([0.0375, 0.0, 0.0]), 0.10, 0.036),  # binoculars, right barrel
    _Grip(4, _OBJECT_GEOMS[1], np.array([0.01, 0.0, 0.0]), 0.075, 0.045),   # cup, around the body
    _Grip(2, _OBJECT_GEOMS[2], np.array([0.09, 0.0, 0.0]), 0.17, 0.10),     # pitcher, by the handle
    _Grip(2, _CUP_BY_HANDLE_GEOMS, np.array([0.045, 0.0, 0.0]), 0.075, 0.045),  # cup, by the handle
)


def grip_of(cls: int, person: Person) -> _Grip:
    """The person's way of holding the object of class `cls` (some hold the cup by its handle)."""
    return _GRIPS[3] if cls == 1 and person.cup_by_handle else _GRIPS[cls]
