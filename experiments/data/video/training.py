"""What the video front end learns from the simulated recordings before it segments: where a
recording's training phase ends (`segmentation_start`), and the skin models fitted on the hand and
face pixels of the clips of some persons (`fit_skin_models`), who are then left out of the evaluation."""
from __future__ import annotations

from collections.abc import Callable, Container, Iterator

import jax
import numpy as np

import hog_jax
from experiments.config import progress
from experiments.data.video.render import clip_scripts, render_recording
from experiments.data.video.settings import Recording, VideoSettings


def segmentation_start(settings: VideoSettings) -> int:
    """The first segmented frame: the empty frames, the entry and the settling (TR §3: after the
    training phase; in a real setup the person would say when)."""
    return int(round(settings.n_empty + (settings.entry_s + settings.settle_s) * settings.fps))


def selected_clips(settings: VideoSettings, where: Callable[[int, int, int], bool]
                   ) -> Iterator[tuple[int, int, int, Recording]]:
    """(person, class, repetition, Recording) of the clips that `where(person, class, repetition)`
    accepts, one at a time (the others are neither loaded nor rendered)."""
    for p, c, r, script in clip_scripts(settings):
        if where(p, c, r):
            yield p, c, r, render_recording(settings, script, progress=progress)


def fit_skin_models(settings: VideoSettings, persons: Container[int], seed: int):
    """The skin model of stills and video (`hog_jax.fit_skin_model` over (Cr, Cb, Y), as the real-pixel
    model `lfd_jax.fit_real_skin_model`) from the hand and face
    pixels of the clips of `persons` (left views, every third frame, 5 % of the skin and 0.5 % of the
    other pixels drawn with `seed`): (the `hog_jax.SkinModel`, {"skin_pixels", "non_skin_pixels"}
    counts)."""
    skin, other = [], []
    rng = np.random.default_rng(seed)
    for _, _, _, rec in selected_clips(settings, lambda p, c, r: p in persons):
        lab = rec.left_labels[::3]
        is_skin = (lab == 2) | (lab == 3)
        skin.append(rec.left[::3][is_skin][rng.random(is_skin.sum()) < 0.05])
        other.append(rec.left[::3][~is_skin][rng.random((~is_skin).sum()) < 0.005])
    skin, other = np.concatenate(skin), np.concatenate(other)
    model = hog_jax.fit_skin_model(jax.random.key(seed), skin, other, luma=True)
    return model, {"skin_pixels": len(skin), "non_skin_pixels": len(other)}
