"""MJCF scenes, written in code so that every model the project simulates is reviewable text.

The table-top drop scene here is the plain MJX example (a table, falling spheres and boxes); the
helpers write the `<asset>` and `<visual>` elements the other scenes share."""
from __future__ import annotations

import numpy as np

from lfd_common import check_int, check_real

_TABLE_HEIGHT_M = 0.75
_OBJECT_COLOURS = ("0.85 0.2 0.2 1", "0.2 0.6 0.85 1", "0.95 0.75 0.2 1", "0.3 0.75 0.35 1")


def checker_asset_xml(rgb1: str, rgb2: str, texrepeat: int = 8, texture_px: int = 256) -> str:
    """An MJCF `<asset>` with a checker texture and the material "grid" that floors and tables use.

    Args:
        rgb1: the first colour, MJCF text ("0.8 0.8 0.8").
        rgb2: the second colour.
        texrepeat: repeats of the texture on a geom, each way.
        texture_px: the texture's side (px).

    Returns:
        The `<asset>` element.
    """
    return (f'<asset><texture name="grid" type="2d" builtin="checker" rgb1="{rgb1}" rgb2="{rgb2}" '
            f'width="{texture_px}" height="{texture_px}"/>'
            f'<material name="grid" texture="grid" texrepeat="{texrepeat} {texrepeat}"/></asset>')


def offscreen_visual_xml(image_px: int, ambient: float, diffuse: float, offsamples: int | None = None) -> str:
    """An MJCF `<visual>` for offscreen images: the buffer's size, a grey headlight, no shadow maps.

    Args:
        image_px: the offscreen buffer is `image_px` x `image_px`.
        ambient: the headlight's ambient level, in [0, 1].
        diffuse: its diffuse level, in [0, 1] (and a faint specular).
        offsamples: the multisampling (MuJoCo's default when None; 0 turns it off).

    Returns:
        The `<visual>` element.
    """
    samples = "" if offsamples is None else f' offsamples="{offsamples:d}"'
    a, d = f"{ambient:.3f}", f"{diffuse:.3f}"
    return (f'<visual><global offwidth="{image_px:d}" offheight="{image_px:d}"/>'
            f'<headlight ambient="{a} {a} {a}" diffuse="{d} {d} {d}" specular="0.05 0.05 0.05"/>'
            f'<quality shadowsize="0"{samples}/></visual>')


def tabletop_drop_scene(n_objects: int = 3, timestep_s: float = 0.004) -> str:
    """MJCF of a table with free spheres and boxes above it, and a fixed camera named "front".

    Each object has one free joint, so `qpos` has 7 entries per object (position, quaternion) in the
    order the objects are listed: object k's height is `qpos[7 * k + 2]`.

    Args:
        n_objects: objects (in [1, 16]), alternately spheres and boxes.
        timestep_s: the physics time step (s, in (0, 0.1]).

    Returns:
        The MJCF text.

    Raises:
        ValueError: an argument out of range, naming it.
    """
    n_objects = check_int(n_objects, "n_objects", min_value=1, max_value=16)
    timestep_s = check_real(timestep_s, "timestep_s", min_value=0.0, max_value=0.1, exclusive_min=True)
    bodies = []
    for k in range(n_objects):
        x = -0.2 + 0.4 * k / max(n_objects - 1, 1)
        colour = _OBJECT_COLOURS[k % len(_OBJECT_COLOURS)]
        geom = (f'<geom type="sphere" size="0.04" rgba="{colour}" mass="0.2"/>' if k % 2 == 0
                else f'<geom type="box" size="0.035 0.035 0.035" rgba="{colour}" mass="0.2"/>')
        bodies.append(f'<body name="object{k}" pos="{x:.3f} 0 {_TABLE_HEIGHT_M + 0.3:.3f}">'
                      f'<freejoint/>{geom}</body>')
    return f"""<mujoco model="tabletop_drop">
  <option timestep="{timestep_s}"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  {checker_asset_xml(".55 .55 .6", ".45 .45 .5", texrepeat=6)}
  <worldbody>
    <light pos="0.3 -0.5 2.2" dir="-0.1 0.2 -1" diffuse="0.8 0.8 0.8"/>
    <camera name="front" pos="0 -0.95 1.5" xyaxes="1 0 0 0 0.7 0.714"/>
    <geom name="floor" type="plane" size="2 2 0.1" material="grid"/>
    <geom name="table" type="box" pos="0 0 {_TABLE_HEIGHT_M / 2:.3f}" size="0.45 0.3 {_TABLE_HEIGHT_M / 2:.3f}" rgba="0.55 0.4 0.25 1"/>
    {"".join(bodies)}
  </worldbody>
</mujoco>"""


def table_height_m() -> float:
    """The height of the table top of `tabletop_drop_scene`.

    Returns:
        The height in metres.
    """
    return _TABLE_HEIGHT_M


def random_drop_heights(rng: np.random.Generator, n_worlds: int, n_objects: int) -> np.ndarray:
    """Random drop heights above the table top of `tabletop_drop_scene`.

    Args:
        rng: the random generator.
        n_worlds: worlds.
        n_objects: objects per world.

    Returns:
        (n_worlds, n_objects) heights, uniform in [0.05, 0.4] m.
    """
    return rng.uniform(0.05, 0.4, size=(n_worlds, n_objects))
