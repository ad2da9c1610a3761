"""The side PHMMs of `experiments.real_arm_actions` beside the regression baseline, on real
UE-ADL recordings with every person held out once, with one fixed explicit-duration setting instead of
the study's per-fold selection (the study's selection runs all four classifiers; this is the cheap
check of the parameter side). The covariance floor is chosen per fold on the training persons, as in
the study (`evaluation.select_side_floor`), from `--floors` (default the study's `side_floors`; one
value: that floor, no selection).

    python experiments/validation/real_side.py OUT [--data ../shared/data/ue_adl] [--states 5]
        [--covariance diag] [--kinds markers,angles] [--floors 0.01,0.1,1,10,100]

Prints and writes OUT/side.json: per kind, the side accuracy and mean |φ − side| of the PHMMs and of
the regression from the final fingertips (`evaluation.side_regression`), per held-out person, and the
fraction of recognised φ on the edge of the search box [−ε, 1 + ε] (ε = 0.1, `recognize`'s default).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from experiments.data.ue_adl import UE_ADL_DIR
from experiments.real_arm_actions import evaluation as ev
from experiments.real_arm_actions.config import METHODS, Config
from experiments.real_arm_actions.data import has_kind, load_dataset
from experiments.real_arm_actions.methods import Setting
from lfd_common import enable_compilation_cache


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--data", type=Path, default=Path(UE_ADL_DIR))
    ap.add_argument("--states", type=int, default=5)
    ap.add_argument("--covariance", default="diag")
    ap.add_argument("--kinds", default="markers,angles")
    ap.add_argument("--floors", default=None, help="comma-separated covariance floors to choose from")
    args = ap.parse_args(argv)
    enable_compilation_cache()
    cfg = Config(data=args.data)
    if args.floors is not None:
        cfg = dataclasses.replace(cfg, side_floors=tuple(float(f) for f in args.floors.split(",")))
    results = {}
    for kind in args.kinds.split(","):
        if not has_kind(args.data, kind):
            print(f"{kind}: no data under {args.data}, skipped")
            continue
        folds = ev.leave_one_person_out(load_dataset(args.data, kind, cfg.n_frames, None, cfg.max_gap_s))
        side = ev.run_side_phmm(folds, [Setting(args.states, args.covariance)] * len(folds), cfg,
                                np.random.default_rng([cfg.seed, len(METHODS)]))
        edge = (side.phi <= -0.1 + 1e-3) | (side.phi >= 1.1 - 1e-3)
        results[kind] = {
            "n_trials": int(len(side.phi)), "n_persons": len(folds),
            "side_accuracy_phmm": float(side.side_correct.mean()),
            "side_accuracy_regression": float(side.regression_correct.mean()),
            "side_error_phmm": float(np.mean(np.abs(side.phi - side.side))),
            "side_error_regression": float(np.mean(np.abs(side.regression - side.side))),
            "action_accuracy_phmm": float(np.mean(side.action == side.truth)),
            "phi_on_edge": float(edge.mean()), "floors_chosen": list(side.floors),
            "per_person_side_accuracy_phmm": side.per_person(side.side_correct),
            "per_person_side_accuracy_regression": side.per_person(side.regression_correct),
            "per_person_side_error_phmm": {p: float(np.mean(np.abs(side.phi - side.side)[side.person == p]))
                                           for p in sorted(set(side.person.tolist()))},
            "per_person_side_error_regression": {
                p: float(np.mean(np.abs(side.regression - side.side)[side.person == p]))
                for p in sorted(set(side.person.tolist()))},
        }
        print(kind, json.dumps(results[kind]), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "side.json").write_text(json.dumps(results, indent=1))
    return results


if __name__ == "__main__":
    main()
