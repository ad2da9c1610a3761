"""Whether the video's moved object should overrule the online PHMMs' action: transfer and
pointing demonstrations of a validation seed of their own (the grasp stage's validation stream, not the
evaluated ones) through the loop's front end, online PHMMs and validation choices; prints the action
accuracy from the PHMMs alone and with the loop's rule (a movement the PHMMs call a pointing is a
transfer where the video shows an object moved, and one they call a transfer a pointing where it shows
none moved; `lfd_jax.imitation.recognise_demo` with `stages.scene_reader`), and how many the rule turned, rightly
and wrongly.

    python experiments/validation/imitation_action.py [--preset paper] [--n 24] [--n-point 12]
"""
import argparse

import numpy as np

from experiments.imitation.config import PRESETS, VALIDATION_SEED
from experiments.imitation.demonstrations import draw_demos
from experiments.imitation.stages import tracked_demo, scene_reader
from experiments.validation.imitation_grasp import SEED_OFFSET
from experiments.validation.imitation_place import loop_models
from lfd_jax import imitation as im


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="paper", choices=sorted(PRESETS))
    parser.add_argument("--n", type=int, default=24, help="validation transfer demonstrations")
    parser.add_argument("--n-point", type=int, default=12, help="validation pointing demonstrations")
    args = parser.parse_args()
    cfg, settings, rgb, online, reach, offset = loop_models(args.preset)
    seed = cfg.seed + VALIDATION_SEED + SEED_OFFSET
    demos = (draw_demos(args.n, seed, cfg.demonstrators, cfg.handover_xy, kinds=("transfer",))
             + draw_demos(args.n_point, seed, cfg.demonstrators, cfg.handover_xy, kinds=("point",)))
    rows = []
    for demo in demos:
        rec, tracked = tracked_demo(cfg, settings, demo, rgb)
        r = im.recognise_demo(online, tracked, offset, cfg.median_frames, demo.objects_xy, cfg.handover_xy,
                              merge_gap=cfg.merge_gap, reach_phmm=reach, scene=scene_reader(cfg, rec, tracked))
        rows.append((demo.kind, r.kind_phmm, r.kind))
        print(f"{demo.kind}: the PHMMs {r.kind_phmm}, the loop {r.kind}", flush=True)
    truth, phmm, loop = (np.array([row[k] or "" for row in rows]) for k in range(3))
    for kind in ("transfer", "point"):
        sel = truth == kind
        print(f"{kind} ({sel.sum()}): the PHMMs right {np.mean(phmm[sel] == kind):.2f}, the loop {np.mean(loop[sel] == kind):.2f}")
    print(f"all ({len(rows)}): the PHMMs {np.mean(phmm == truth):.2f}, the loop {np.mean(loop == truth):.2f}")
    for said, now in (("point", "transfer"), ("transfer", "point")):
        turned = (phmm == said) & (loop == now)
        print(f"  the PHMMs' {said} turned into a {now}: {np.sum(turned & (truth == now))} rightly, "
              f"{np.sum(turned & (truth == said))} wrongly")


if __name__ == "__main__":
    main()
