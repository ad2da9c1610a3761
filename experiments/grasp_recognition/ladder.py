"""The ladder: where the accuracy goes between the database and the full test images.

Rung r renders the test sets (X and the large set, the same seeds, grasps, stages and viewpoints as the
full test) with one more of the test images' differences from the database switched on than rung r - 1:

1. the database hand in its exact grasp postures, new viewpoints off the grid, black background, the
   renderer's hand mask;
2. + the test hand (anthropometry and skin tone);
3. + posture: the reach stage's posture and object distance, joint noise up to ±15°;
4. + lighting, object colour, camera noise and blur;
5. + the cluttered background, still cropped by the renderer's hand mask;
6. + skin segmentation instead of the mask: the full test (the study's own figures).

Every rung is scored by the same recogniser and `scoring.score_sets`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

import hog_jax
from experiments.data.grasp_tests import ALL_NUISANCES, GraspTestSet, Nuisances, random_set, sequence_set
from experiments.grasp_recognition.config import Config
from experiments.grasp_recognition.pieces import bar
from lfd_jax.grasp import Crops, crops_of
from sim.hands import DEFAULT_SHAPE, TEST_SHAPE, HandShape


class Rung(NamedTuple):
    name: str
    shape: HandShape
    nuisances: Nuisances
    skin_segmentation: bool


RUNGS: tuple[Rung, ...] = (
    Rung("database hand, exact postures, new views, black, renderer mask", DEFAULT_SHAPE,
         Nuisances(posture=False, photometric=False, clutter=False), False),
    Rung("+ test hand", TEST_SHAPE, Nuisances(posture=False, photometric=False, clutter=False), False),
    Rung("+ reach posture, joint noise ±15°", TEST_SHAPE, Nuisances(posture=True, photometric=False, clutter=False),
         False),
    Rung("+ lighting, noise, blur", TEST_SHAPE, Nuisances(posture=True, photometric=True, clutter=False), False),
    Rung("+ clutter (renderer mask)", TEST_SHAPE, ALL_NUISANCES, False),
    Rung("+ skin segmentation (full test)", TEST_SHAPE, ALL_NUISANCES, True),
)


def rung_sets(cfg: Config, rung: Rung) -> dict[str, GraspTestSet]:
    """The rung's X and large set (cached renders; rung 5 and 6 are the study's own test sets)."""
    return {"X": sequence_set(cfg.seed, cfg.frame_size, shape=rung.shape, nuisances=rung.nuisances,
                              progress=bar(f"render X, {rung.name}")),
            "large": random_set(cfg.n_large, cfg.seed, cfg.frame_size, shape=rung.shape, nuisances=rung.nuisances,
                                progress=bar(f"render large, {rung.name}"))}


def mask_crops(test: GraspTestSet, crop_size: int) -> Crops:
    """The renderer's hand mask cropped exactly as the skin segmentation's (`hog_jax.crop_components`,
    seeded at the frame centre)."""
    n, h, w, _ = test.frames.shape
    gray = (test.frames.astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)) / 255.0
    seg = hog_jax.crop_components(gray, test.hand_masks, np.tile([h / 2.0, w / 2.0], (n, 1)), out_size=crop_size)
    return crops_of(seg)
