"""How far the imitation loop's tracked hand - face lies from the demonstrations' kinematics, per preset:
on each preset's validation demonstrations, the frames that are tracked, plausible and
visible, the median gap (the tracker offset the loop subtracts) and the residual after it.

    python experiments/validation/imitation_tracks.py [PRESET ...]     (default: quick paper)
"""
import sys

import numpy as np

from experiments.imitation import pipeline as pl
from experiments.imitation.config import PRESETS, VALIDATION_SEED, Config
from experiments.imitation.demonstrations import demo_track, draw_demos
from experiments.imitation.stages import tracked_demo, skin_models
from lfd_common import enable_compilation_cache
from lfd_jax import imitation as im


def preset_gaps(preset: str) -> None:
    """Print one line per validation demonstration and the preset's offset and residual (cm)."""
    cfg = Config(**PRESETS[preset])
    settings = cfg.video_settings()
    rgb_skin = skin_models(cfg, settings)
    demos = draw_demos(cfg.n_validation, cfg.seed + VALIDATION_SEED, cfg.demonstrators, cfg.handover_xy)
    actors = pl.Actors(settings)
    gaps = []
    for demo in demos:
        _, tracked = tracked_demo(cfg, settings, demo, rgb_skin)
        x, visible = pl.kinematic_features(actors(demo), demo_track(actors(demo), demo, settings))
        both = im.plausible(tracked, cfg.median_frames) & visible[: len(tracked.found)]
        gap = tracked.diff[both] - x[: len(tracked.found)][both]
        gaps.append(gap)
        median = np.round(np.median(gap, 0) * 100, 1) if len(gap) else "none"
        print(f"{preset} {demo.kind:8s} visible {int(visible.sum()):3d}, tracked, plausible and visible "
              f"{int(both.sum()):3d}, median gap {median} cm")
    gaps = np.concatenate(gaps)
    offset = np.median(gaps, 0)
    residual = np.linalg.norm(gaps - offset, axis=1) * 100
    print(f"{preset}: offset {np.round(offset * 100, 1)} cm, residual after it median {np.median(residual):.1f} cm, "
          f"90th percentile {np.percentile(residual, 90):.1f} cm")


if __name__ == "__main__":
    enable_compilation_cache()
    for name in sys.argv[1:] or ["quick", "paper"]:
        preset_gaps(name)
