"""The realism steps of the scene convnet's training frames as a `Config` names them
(`Config.scene_realism`), and the real background texture they paste (`Config.backgrounds`)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from PIL import Image

from experiments.grasp_recognition.config import REALISM_STEPS
from lfd_jax.grasp import Realism, background_patches

# the real video the background patches come from: (folder, frame glob, every n-th frame)
_SOURCES = (("cdnet_highway/input", "in*.jpg", 40), ("cdnet_pedestrians/input", "in*.jpg", 40),
            ("sbi_indoor/Board/input", "in*.jpg", 10), ("sbi_indoor/Candela_m1.10/input", "in*.jpg", 10),
            ("sbi_indoor/HallAndMonitor/input", "in*.jpg", 10), ("sbi_indoor/HumanBody2/input", "in*.jpg", 10))
_GIF = "reach_grasp/teaser_movement.gif"
_N_PATCHES = 2000


def realism_of(steps: str, background_share: float = 1.0) -> Realism:
    """The `lfd_jax.grasp.Realism` of a config's `scene_realism` ("none" or steps joined by "+") and
    `background_share`."""
    names = () if steps == "none" else steps.split("+")
    return Realism(**{name: name in names for name in REALISM_STEPS}, background_share=background_share)


def usable_steps(steps: str, backgrounds: str) -> str:
    """`steps` (a config's `scene_realism`) without the background step where `backgrounds` holds none
    of the real video (`background_frames`: a clone without ../shared/data), saying so."""
    names = [] if steps == "none" else steps.split("+")
    if "background" not in names or any((Path(backgrounds) / folder).is_dir() for folder, _, _ in _SOURCES):
        return steps
    print(f"note: {backgrounds} holds no real video; the scene convnet trains without real backgrounds")
    names.remove("background")
    return "+".join(names) or "none"


def background_frames(data: str | Path) -> list[np.ndarray]:
    """RGB uint8 frames of the real video sequences in `data` (../shared/data: the CDnet highway and
    pedestrians inputs, the four SBI indoor sequences, every n-th frame, and the reach-to-grasp teaser
    clip); none of it is the grasp study's evaluation data.

    Raises:
        ValueError: `data` holds none of them.
    """
    data = Path(data)
    frames = [cv2.imread(str(p))[..., ::-1] for folder, pattern, step in _SOURCES
              for p in sorted((data / folder).glob(pattern))[::step]]
    if (data / _GIF).is_file():
        with Image.open(data / _GIF) as gif:
            for i in range(gif.n_frames):
                gif.seek(i)
                frames.append(np.asarray(gif.convert("RGB")))
    if not frames:
        raise ValueError(f"backgrounds: {data} holds none of the real video sequences (cdnet_*, sbi_indoor)")
    return frames


def scene_patches(data: str | Path, size: int, seed: int) -> np.ndarray:
    """(2000, size, size, 3) uint8 background patches (`lfd_jax.grasp.background_patches`) from the real
    video of `data` (`background_frames`)."""
    return background_patches(background_frames(data), size, _N_PATCHES, seed)
