"""Offscreen rendering with MuJoCo's renderer (EGL unless MUJOCO_GL says otherwise: see `sim/__init__`)."""
from __future__ import annotations

import mujoco
import numpy as np

from lfd_common import as_array, check_int


def render_frame(model: mujoco.MjModel, qpos: np.ndarray, width: int = 320, height: int = 240,
                 camera: str | int = -1) -> np.ndarray:
    """Render the scene at joint positions `qpos` (nq,) and return an RGB image (height, width, 3) uint8."""
    width = check_int(width, "width", min_value=8, max_value=model.vis.global_.offwidth)
    height = check_int(height, "height", min_value=8, max_value=model.vis.global_.offheight)
    qpos = as_array(qpos, "qpos", shape=(model.nq,))
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    with mujoco.Renderer(model, height=height, width=width) as renderer:
        renderer.update_scene(data, camera=camera)
        return renderer.render().copy()
