"""Where the imitation loop puts a transfer's object, per half width of the grasp-moment, put-down and
place rule (`Config.place_half_s`; issue 21): transfer demonstrations of a validation seed of their own
(the grasp stage's validation stream, not the evaluated ones) through the loop's front end, online
PHMMs and validation choices; prints per setting the median place error, the share within the task's
5 cm, and the mean absolute pick-up / put-down frame errors, over the transfers recognised as one.

    python experiments/validation/imitation_place.py [--preset paper] [--n 24] [--half-s 0 0.08 0.16 0.24]
"""
import argparse
import dataclasses

import numpy as np

import phmm_jax as P
from experiments.imitation import pipeline as pl
from experiments.imitation.config import PRESETS, VALIDATION_SEED, Config
from experiments.imitation.demonstrations import draw_demos
from experiments.imitation.stages import _tracked_demo, phmm_models, skin_models, validation_stage
from experiments.validation.imitation_grasp import _SEED_OFFSET
from lfd_common import enable_compilation_cache


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="paper", choices=sorted(PRESETS))
    parser.add_argument("--n", type=int, default=24, help="validation transfer demonstrations")
    parser.add_argument("--half-s", type=float, nargs="+", default=[0.0, 0.08, 0.16, 0.24])
    args = parser.parse_args()
    enable_compilation_cache()
    cfg = Config(**PRESETS[args.preset])
    settings = cfg.video_settings()
    _, rgb = skin_models(cfg, settings)
    phmms = phmm_models(cfg, settings)
    offset, sigma, thr, _ = validation_stage(cfg, settings, phmms, rgb)
    online = pl.recognizer(phmms, sigma, thr, cfg.online_window)
    reach = P.with_observation_noise(phmms[pl.REACH], sigma ** 2)
    demos = draw_demos(args.n, cfg.seed + VALIDATION_SEED + _SEED_OFFSET, cfg.demonstrators, cfg.handover_xy,
                       kinds=("transfer",))
    tracks = [_tracked_demo(cfg, settings, demo, rgb) for demo in demos]
    for half_s in args.half_s:
        c = dataclasses.replace(cfg, place_half_s=half_s)
        errors, pick, put = [], [], []
        for demo, (rec, tracked) in zip(demos, tracks):
            r = pl.recognise_demo(online, tracked, offset, c.median_frames, demo.objects_xy, c.handover_xy,
                                  merge_gap=c.merge_gap, reach_phmm=reach, place_half=c.place_half)
            if r.kind != "transfer":
                continue
            errors.append(np.linalg.norm(r.place_xy - demo.place_xy) * 100)
            pick.append(abs(r.grasp_frame - rec.pickup_frames[0]))
            put.append(abs(r.putdown_frame - rec.putdown_frames[0]))
        errors = np.asarray(errors)
        print(f"half {half_s:g} s ({c.place_half} frames): {len(errors)} of {len(demos)} recognised as transfers, "
              f"place error median {np.median(errors):.1f} cm, within 5 cm {np.mean(errors <= 5):.2f}, "
              f"pick-up / put-down {np.mean(pick):.1f} / {np.mean(put):.1f} frames off", flush=True)


if __name__ == "__main__":
    main()
