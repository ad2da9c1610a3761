"""The colours of the video tests' toy scenes, the skin model fitted on them, and a video file writer."""
import jax
import numpy as np

import hog_jax

SKIN_RGB, PERSON_RGB = np.array([200.0, 140.0, 110.0]), np.array([40.0, 60.0, 170.0])
BACKGROUND_GREYS = (100.0, 150.0)  # the chequerboard of the toy scenes


def toy_skin_model(seed: int = 1) -> hog_jax.SkinModel:
    """The one skin model (`hog_jax.fit_skin_model`, chroma) on noisy skin pixels against the toy scene's
    other colours: its greys and the person's clothing."""
    rng = np.random.default_rng(seed)
    skin = np.clip(SKIN_RGB + rng.normal(0, 4, (400, 3)), 0, 255)
    colours = np.array([[g] * 3 for g in BACKGROUND_GREYS] + [PERSON_RGB])
    other = np.clip(np.repeat(colours, 200, axis=0) + rng.normal(0, 4, (600, 3)), 0, 255)
    return hog_jax.fit_skin_model(jax.random.key(0), skin, other, n_components=2, n_background=3)


def write_video(path, frames: np.ndarray, rate: float = 10.0):
    """`frames` (T, H, W, 3) RGB uint8 written as an MJPG video at `rate` frames/s (OpenCV); its path."""
    import cv2

    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), rate, frames.shape[2:0:-1])
    for f in frames:
        writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    writer.release()
    return path
