"""Where the imitation loop puts a transfer's object: transfer demonstrations of a validation
seed of their own (the grasp stage's validation stream, not the evaluated ones) through the loop's
front end, online PHMMs and validation choices; prints the median place error, the share within the
task's 5 cm, and the mean absolute pick-up / put-down frame errors, over the transfers recognised as
one, with the place read from the tracked hand (`lfd_jax.imitation.recognise_demo` without a scene reader), from
the object's displacement in the video where it is found and the hand's elsewhere (the loop's
`stages.scene_reader`), and, for comparison, from the renderer's true hand at the detected and at the
true pick-up and put-down frames; and how often the target object is right from the PHMMs alone
and in the loop, where the video's moved object overrules them.

    python experiments/validation/imitation_place.py [--preset paper] [--n 24]
"""
import argparse

import numpy as np

import phmm_jax as P
from experiments.imitation import pipeline as pl
from experiments.imitation.config import PRESETS, VALIDATION_SEED, Config
from experiments.imitation.demonstrations import demo_track, draw_demos
from experiments.imitation.stages import tracked_demo, phmm_models, scene_reader, skin_models, validation_stage
from experiments.validation.imitation_grasp import SEED_OFFSET
from lfd_common import enable_compilation_cache
from lfd_jax import imitation as im


def loop_models(preset: str):
    """(config, video settings, RGB skin model, online recogniser, reach PHMM, tracker offset) of the loop's
    `preset`, its validation choices made as the loop makes them."""
    enable_compilation_cache()
    cfg = Config(**PRESETS[preset])
    settings = cfg.video_settings()
    rgb = skin_models(cfg, settings)
    phmms = phmm_models(cfg, settings)
    offset, sigma, thr, _ = validation_stage(cfg, settings, phmms, rgb)
    online = im.recognizer(phmms, sigma, thr, cfg.online_window)
    return cfg, settings, rgb, online, P.with_observation_noise(phmms[pl.REACH], sigma ** 2), offset


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="paper", choices=sorted(PRESETS))
    parser.add_argument("--n", type=int, default=24, help="validation transfer demonstrations")
    args = parser.parse_args()
    cfg, settings, rgb, online, reach, offset = loop_models(args.preset)
    demos = draw_demos(args.n, cfg.seed + VALIDATION_SEED + SEED_OFFSET, cfg.demonstrators, cfg.handover_xy,
                       kinds=("transfer",))
    actors = pl.Actors(settings)
    rows = []
    for demo in demos:
        rec, tracked = tracked_demo(cfg, settings, demo, rgb)
        r = im.recognise_demo(online, tracked, offset, cfg.median_frames, demo.objects_xy, cfg.handover_xy,
                              merge_gap=cfg.merge_gap, reach_phmm=reach)
        if r.kind != "transfer":
            continue
        seen = im.recognise_demo(online, tracked, offset, cfg.median_frames, demo.objects_xy, cfg.handover_xy,
                                 merge_gap=cfg.merge_gap, reach_phmm=reach, scene=scene_reader(cfg, rec, tracked))
        x, _ = pl.kinematic_features(actors(demo), demo_track(actors(demo), demo, settings))
        true_g, true_p = int(rec.pickup_frames[0]) - 1, int(rec.putdown_frames[0])
        start = np.asarray(demo.objects_xy)[demo.target]
        rows.append([np.linalg.norm(r.place_xy - demo.place_xy) * 100,
                     np.linalg.norm(start + x[r.putdown_frame, :2] - x[r.grasp_frame, :2] - demo.place_xy) * 100,
                     np.linalg.norm(start + x[true_p, :2] - x[true_g, :2] - demo.place_xy) * 100,
                     np.linalg.norm(seen.place_xy - demo.place_xy) * 100,
                     abs(r.grasp_frame - true_g), abs(r.putdown_frame - true_p), seen.place_from == "scene",
                     r.target == demo.target, seen.target == demo.target, seen.target != seen.target_phmm])
    rows = np.asarray(rows)
    names = ("tracked hand, detected frames", "true hand, detected frames", "true hand, true frames",
             "the object in the video where found, else the tracked hand")
    scene = rows[:, 6] > 0
    print(f"the object's displacement found in {scene.sum():.0f} of {len(rows)}: there median "
          f"{np.median(rows[scene, 3]) if scene.any() else np.nan:.1f} cm, within 5 cm {np.mean(rows[scene, 3] <= 5):.2f}; "
          f"the tracked hand on the same: median {np.median(rows[scene, 0]) if scene.any() else np.nan:.1f} cm")
    for k, name in enumerate(names):
        print(f"{name}: place error median {np.median(rows[:, k]):.1f} cm, within 5 cm {np.mean(rows[:, k] <= 5):.2f} "
              f"({len(rows)} of {len(demos)} recognised as transfers)")
    print(f"pick-up / put-down frames off: {rows[:, 4].mean():.1f} / {rows[:, 5].mean():.1f}")
    print(f"target object right: the PHMMs {rows[:, 7].mean():.2f}, the loop (the object the video shows moved, "
          f"where it decides) {rows[:, 8].mean():.2f}; the video overruled the PHMMs in {rows[:, 9].sum():.0f}")


if __name__ == "__main__":
    main()
