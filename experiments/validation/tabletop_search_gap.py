"""How close `recognize`'s φ comes to the maximum on the PHMM table-top study itself: the
study's data and PHMMs (`experiments.phmm_tabletop`, 2x2 and 3x3 grids, reaching and pointing), its
test movements with noise σ added as in its recognition stage, and for every sequence and PHMM the
gap between the log-likelihood at the returned φ and at the best of a dense search (a 21^d lattice
and 30 + 10 quasi-Newton steps, `bench_hmm`'s reference).

    python experiments/validation/tabletop_search_gap.py OUT [--preset quick|paper] [--noise-cm 0,5,10]

Both the library's default search (`recognize(phmms, X)`) and the study's (`n_steps` =
`recognition_steps`) are measured. Prints and writes OUT/gap.json: per grid, noise level and search,
the fraction within 1 nat, the median, 90th percentile and largest gap.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

import phmm_jax as P
from experiments.bench.bench_hmm import dense_search_logliks, search_gap
from experiments.phmm_tabletop import measures as ms
from experiments.phmm_tabletop.config import PRESETS, Config
from experiments.phmm_tabletop.stages import GRIDS, data_stage
from lfd_common import enable_compilation_cache


def summary(gap: np.ndarray) -> dict:
    return {"within_1_nat": float(np.mean(gap <= 1.0)), "median": float(np.median(gap)),
            "p90": float(np.percentile(gap, 90)), "max": float(gap.max()), "n_pairs": int(gap.size)}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--preset", default="paper", choices=sorted(PRESETS))
    ap.add_argument("--noise-cm", default="0,5,10", help="comma-separated noise sigmas (cm)")
    args = ap.parse_args(argv)
    enable_compilation_cache()
    cfg = dataclasses.replace(Config(), **PRESETS[args.preset])
    d = data_stage(cfg)
    models = ms.train_models(cfg, d.X_train, d.train, cfg.train_repetitions)
    rng = np.random.default_rng(cfg.seed + 1)
    searches = {"default": {}, f"study ({cfg.recognition_steps} steps)": {"n_steps": cfg.recognition_steps}}
    out = {}
    for sigma in (float(s) for s in args.noise_cm.split(",")):
        X = d.X_test + (sigma / 100) * rng.standard_normal(d.X_test.shape) if sigma > 0 else d.X_test
        for grid in GRIDS:
            dense = dense_search_logliks(models[grid], X)
            for name, options in searches.items():
                row = summary(search_gap(P.recognize(models[grid], X, **options).loglik, dense))
                out[f"{grid}, sigma {sigma:g} cm, {name}"] = row
                print(f"{grid} sigma {sigma:g} cm {name:18s} within 1 nat {row['within_1_nat']:.1%} of "
                      f"{row['n_pairs']} pairs, median {row['median']:.3f}, p90 {row['p90']:.2f}, "
                      f"max {row['max']:.1f}", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "gap.json").write_text(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
