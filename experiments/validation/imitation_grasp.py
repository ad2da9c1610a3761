"""How well the imitation loop's grasp stage recognises the grasp class of the demonstrating hand, per
database and crop window: on transfer demonstrations of a validation seed of their own (not
the evaluated ones, not the loop's other validation ones, not the "demonstrations" database's), the
left view at the true pick-up frame shifted by the loop's `grasp_frames_s`, cut at the renderer's
right-hand centroid (the tracker taken out) and skin-segmented as the loop does. Prints the accuracy
and the confusion matrix of each setting.

    python experiments/validation/imitation_grasp.py [--preset paper] [--n 24]
        [--databases study demonstrations] [--windows 0 0.06 0.1 0.15] [--pixels 0 16]
"""
import argparse
import dataclasses

import numpy as np

from experiments.imitation.config import PRESETS, VALIDATION_SEED, Config
from experiments.imitation.grasp_stage import demonstration_crops, grasp_recogniser
from experiments.imitation.stages import skin_models
from lfd_common import enable_compilation_cache
from lfd_jax.grasp import features, net_labels, recognise
from sim.grasping import GRASP_CLASSES

SEED_OFFSET = 77  # a validation stream of its own: not the loop's threshold/offset demonstrations


def evaluate(cfg: Config, chroma, n: int) -> float:
    """Accuracy of cfg's grasp stage on n validation transfers' crops (and its confusion, printed)."""
    settings = cfg.video_settings()
    crops, grasps, _ = demonstration_crops(cfg, settings, chroma, n, cfg.seed + VALIDATION_SEED + SEED_OFFSET)
    found = crops.found
    _, recogniser = grasp_recogniser(cfg, settings, chroma)
    out = recognise(recogniser, features(recogniser, crops.images, crops.masks, found), found, exact=True,
                    labels=net_labels(recogniser, crops))
    pred = np.array([GRASP_CLASSES[k] if k >= 0 else -1 for k in out.labels])
    classes = list(GRASP_CLASSES)
    confusion = np.zeros((len(classes), len(classes) + 1), int)
    for t, p in zip(grasps, pred):
        confusion[classes.index(t), classes.index(p) if p in classes else -1] += 1
    accuracy = float(np.mean(pred == grasps))
    print(f"database {cfg.grasp_database} (study preset {cfg.grasp_preset}, {cfg.grasp_db_pixels or 'full'} px), "
          f"window {cfg.grasp_window_frac:g}: accuracy {accuracy:.3f} of {len(grasps)} crops of {n} transfers, "
          f"hand found {found.mean():.2f}", flush=True)
    print("  true \\ recognised " + " ".join(f"{c:>3d}" for c in classes) + "  none")
    for c, row in zip(classes, confusion):
        print(f"  {c:>17d} " + " ".join(f"{v:>3d}" for v in row))
    return accuracy


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="paper", choices=sorted(PRESETS))
    parser.add_argument("--n", type=int, default=24, help="validation transfer demonstrations")
    parser.add_argument("--databases", nargs="+", default=["study", "demonstrations"])
    parser.add_argument("--windows", type=float, nargs="+", default=[0.0, 0.06, 0.1, 0.15])
    parser.add_argument("--pixels", type=int, nargs="+", default=[0], help="study database resolutions (0: as rendered)")
    args = parser.parse_args()
    enable_compilation_cache()
    base = Config(**PRESETS[args.preset])
    chroma = skin_models(base, base.video_settings())
    for database in args.databases:
        for window in args.windows:
            for pixels in args.pixels if database == "study" else [0]:
                evaluate(dataclasses.replace(base, grasp_database=database, grasp_window_frac=window,
                                             grasp_db_pixels=pixels), chroma, args.n)


if __name__ == "__main__":
    main()
