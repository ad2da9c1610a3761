"""Offscreen rendering with MuJoCo's renderer, and the explicit choice of its OpenGL backend.

MuJoCo reads the environment variable `MUJOCO_GL` once, when `mujoco` is first imported
(`mujoco/rendering/classic/gl_context.py` picks a `GLContext` class: GLFW when the variable is unset,
which needs a display), and `mujoco.Renderer` builds its context from that module's `GLContext` when
it is constructed. `import sim` changes nothing there; `setup_rendering` makes the choice explicitly,
and works whenever it is called: before `mujoco` is imported it sets the variable, after it points
the renderer's `GLContext` at the chosen backend's class. Entry points (experiment scripts, tests that
render through `mujoco.Renderer` themselves) call it once; `render_frame` and
`sim.grasping.GraspRenderer` call it before they create a context, so they work without it.
"""
from __future__ import annotations

import importlib
import os

import mujoco
import numpy as np

from lfd_common import as_array, check_choice, check_int

__all__ = ["render_frame", "setup_rendering"]

RENDER_BACKENDS: tuple[str, ...] = ("egl", "osmesa", "glfw")


def _gl_context_module():
    """The module whose `GLContext` `mujoco.Renderer` instantiates (MuJoCo 4; `mujoco.gl_context` in 3.x)."""
    try:
        return importlib.import_module("mujoco.rendering.classic.gl_context")
    except ImportError:
        return importlib.import_module("mujoco.gl_context")


def setup_rendering(backend: str = "egl") -> str:
    """Make `mujoco.Renderer` use an OpenGL backend, whenever this is called.

    A `MUJOCO_GL` already in the environment is the user's choice and wins over `backend`; otherwise
    `MUJOCO_GL` is set to `backend`. If the `GLContext` class MuJoCo picked at import is not that
    backend's, it is replaced by `mujoco.<backend>.GLContext` (in MuJoCo's `gl_context` module, where
    `mujoco.Renderer` looks it up, and as `mujoco.GLContext`). Other `MUJOCO_GL` values ("glx",
    "disable", ...) are left to MuJoCo. Calling it again changes nothing. EGL (Mesa or NVIDIA) is the
    backend that works on machines without a display.

    Args:
        backend: "egl", "osmesa" or "glfw".

    Returns:
        The backend in use.

    Raises:
        ValueError: an unknown `backend`.
        RuntimeError: the chosen backend cannot be loaded.
    """
    check_choice(backend, "backend", RENDER_BACKENDS)
    chosen = os.environ.setdefault("MUJOCO_GL", backend).strip().lower()
    if chosen not in RENDER_BACKENDS:
        return chosen
    module = _gl_context_module()
    current = getattr(module, "GLContext", None)
    if current is not None and current.__module__ == f"mujoco.{chosen}":
        return chosen
    try:
        context_class = importlib.import_module(f"mujoco.{chosen}").GLContext
    except (ImportError, AttributeError, OSError) as err:
        raise RuntimeError(f"backend: MuJoCo's {chosen!r} OpenGL backend cannot be loaded ({err})") from err
    module.GLContext = context_class
    if hasattr(mujoco, "GLContext"):
        mujoco.GLContext = context_class
    return chosen


def render_frame(model: mujoco.MjModel, qpos: np.ndarray, width: int = 320, height: int = 240,
                 camera: str | int = -1) -> np.ndarray:
    """Render a scene at given joint positions, offscreen (calls `setup_rendering` first).

    Args:
        model: the compiled scene.
        qpos: (nq,) joint positions.
        width: the image width (px, at least 8, at most the model's offscreen width).
        height: the image height (px, at least 8, at most the model's offscreen height).
        camera: a camera's name or id; -1: the free camera.

    Returns:
        (height, width, 3) uint8 RGB image.

    Raises:
        ValueError: a size out of range or qpos of the wrong shape.
        RuntimeError: the OpenGL backend cannot be loaded.
    """
    width = check_int(width, "width", min_value=8, max_value=model.vis.global_.offwidth)
    height = check_int(height, "height", min_value=8, max_value=model.vis.global_.offheight)
    qpos = as_array(qpos, "qpos", shape=(model.nq,))
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    setup_rendering()
    with mujoco.Renderer(model, height=height, width=width) as renderer:
        renderer.update_scene(data, camera=camera)
        return renderer.render().copy()
