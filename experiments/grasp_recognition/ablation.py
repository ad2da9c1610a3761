"""What each improvement beyond the paper contributes, by exact kNN on one split.

    python -m experiments.grasp_recognition.ablation --split validation --out DIR
    python -m experiments.grasp_recognition.ablation --split test --out DIR

Every variant is the paper preset with a few settings changed (`VARIANTS`). `validation`: images of
their own seed and their own hand (`experiments.data.grasp_database.VALIDATION_SHAPE`, every nuisance
of the test, skin-segmented): the split the best preset is chosen on. `test`: the study's test sets
(reported, never chosen on). Exact search isolates the database, features and metric from the index;
the LSH settings are measured by the study itself. Writes ablation.json and ablation.md.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import jax
import numpy as np

import hog_jax
import sim
from experiments.config import markdown_table, progress
from experiments.data.grasp_database import VALIDATION_SHAPE
from experiments.data.grasp_tests import random_set, sequence_set, skin_training_pixels, stage_subsets
from experiments.grasp_recognition.config import PRESETS, Config
from experiments.grasp_recognition.pieces import accuracy, bar, orientation_errors_deg, wilson_interval
from experiments.grasp_recognition.recogniser import recogniser_of, study_database
from lfd_common import enable_compilation_cache
from lfd_jax.grasp import features, net_labels, recognise, segment_frames

VARIANTS: dict[str, dict] = {
    "paper (60 x 15 grid, B4 L3, plain HOG)": {},
    "DR, same budget (30 x 15 grid + 450 random per grasp)": dict(n_azimuth=30, n_random_views=450),
    "DR, 3x (grid + 1800 random per grasp)": dict(n_random_views=1800),
    "DR, 10x (grid + 8100 random per grasp)": dict(n_random_views=8100),
    "whitened LDA metric": dict(metric="lda"),
    "soft binning": dict(hog_binning="soft"),
    "per-cell normalisation": dict(hog_normalize="cell"),
    "B6 L4": dict(n_bins=6, n_levels=4),
    "k = 20": dict(k=20),
    "skin model adapted per frame (background)": dict(skin_adaptation="background"),
    "skin model adapted per frame (both)": dict(skin_adaptation="both"),
    "DR 10x + LDA": dict(n_random_views=8100, metric="lda"),
    "DR 10x + LDA (5 components)": dict(n_random_views=8100, metric="lda", metric_components=5),
    "DR 10x + LDA (shrinkage 0.5)": dict(n_random_views=8100, metric="lda", metric_shrinkage=0.5),
    "DR 10x + LDA + soft binning": dict(n_random_views=8100, metric="lda", hog_binning="soft"),
    "DR 10x + LDA + cell normalisation": dict(n_random_views=8100, metric="lda", hog_normalize="cell"),
    "DR 10x + LDA + B6 L4": dict(n_random_views=8100, metric="lda", n_bins=6, n_levels=4),
    "DR 10x + LDA + k = 20": dict(n_random_views=8100, metric="lda", k=20),
    "MLP on HOG (grid only)": dict(classifier="mlp"),
    "DR 10x + MLP on HOG": dict(n_random_views=8100, classifier="mlp"),
    "DR 10x + MLP on HOG B6 L4 soft": dict(n_random_views=8100, classifier="mlp", n_bins=6, n_levels=4,
                                           hog_binning="soft"),
    "DR 10x + LDA + skin model adapted (background)": dict(n_random_views=8100, metric="lda",
                                                           skin_adaptation="background"),
    "DR 10x + MLP on HOG B6 L4 soft + skin model adapted (background)": dict(
        n_random_views=8100, classifier="mlp", n_bins=6, n_levels=4, hog_binning="soft", skin_adaptation="background"),
    "DR 10x + convnet on the crops": dict(n_random_views=8100, classifier="cnn"),
    "DR 10x + LDA + skin model adapted (background) + convnet": dict(n_random_views=8100, metric="lda",
                                                                     skin_adaptation="background", classifier="cnn"),
    "skin model adapted (background) + scene convnet on the unmasked boxes (30 epochs)": dict(
        skin_adaptation="background", classifier="scene_cnn", cnn_epochs=30),
    "DR 10x + LDA + skin model adapted (background) + scene convnet (30 epochs)": dict(
        n_random_views=8100, metric="lda", skin_adaptation="background", classifier="scene_cnn", cnn_epochs=30),
    "DR 10x + LDA + skin model adapted (background) + scene convnet (60 epochs)": dict(
        n_random_views=8100, metric="lda", skin_adaptation="background", classifier="scene_cnn", cnn_epochs=60),
}


def split_sets(cfg: Config, split: str) -> dict:
    """{'X': ..., 'large': ...} of the split (see the module docstring)."""
    if split == "validation":
        return {"X": sequence_set(cfg.seed + 1, cfg.frame_size, shape=VALIDATION_SHAPE, progress=bar("render val X")),
                "large": random_set(cfg.n_validation, cfg.seed + 1, cfg.frame_size, shape=VALIDATION_SHAPE,
                                    progress=bar("render val large"))}
    return {"X": sequence_set(cfg.seed, cfg.frame_size, progress=bar("render X")),
            "large": random_set(cfg.n_large, cfg.seed, cfg.frame_size, progress=bar("render large"))}


def evaluate(cfg: Config, sets: dict, crops: dict, skin) -> dict:
    """Exact-kNN accuracy (large with its interval, X / X' / X'') and geodesic error on the correct."""
    rec = recogniser_of(cfg, jax.random.key(cfg.seed), study_database(cfg), None, skin)
    out = {"n_database_views": len(rec.db.labels)}
    for name, t in sets.items():
        c = crops[name]
        found = c.found
        r = recognise(rec, features(rec, c.images, c.masks, found), found, exact=True, labels=net_labels(rec, c))
        out[f"accuracy_{name}"] = accuracy(r.labels, t.labels)
        if name == "large":
            out["ci95"] = wilson_interval(int(np.sum(r.labels == t.labels)), len(t.labels))
            right = found & (r.labels == t.labels)
            _, g = orientation_errors_deg(r.euler[right], t.euler[right], r.quat[right], t.quat[right])
            out["geodesic_correct_large"] = float(g.mean()) if right.any() else float("nan")
        else:
            for sub, sel in stage_subsets(t.stage).items():
                out[f"accuracy_{sub}"] = accuracy(r.labels[sel], t.labels[sel])
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--split", choices=("validation", "test"), required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--variants", default="", help="comma-separated indices into VARIANTS (default: all)")
    args = parser.parse_args(argv)
    sim.setup_rendering()
    enable_compilation_cache()
    base = Config(**PRESETS["paper"])
    names = list(VARIANTS)
    if args.variants:
        names = [names[int(i)] for i in args.variants.split(",")]
    sets = split_sets(base, args.split)
    skin = hog_jax.fit_skin_model(jax.random.fold_in(jax.random.key(base.seed), 1),
                                  *skin_training_pixels(base.seed, base.n_skin_images))
    crops = {}  # adaptation -> set name -> crops
    rows, results = [], {}
    for name in progress(names, desc="variants"):
        t0 = time.perf_counter()
        cfg = dataclasses.replace(base, **VARIANTS[name])
        if cfg.skin_adaptation not in crops:
            crops[cfg.skin_adaptation] = {n: segment_frames(skin, t.frames, base.crop_size,
                                                            adaptation=cfg.skin_adaptation) for n, t in sets.items()}
        r = evaluate(cfg, sets, crops[cfg.skin_adaptation], skin)
        r["time_s"] = time.perf_counter() - t0
        results[name] = r
        rows.append((name, r["n_database_views"], f"{100 * r['accuracy_large']:.1f} [{100 * r['ci95'][0]:.1f}, "
                     f"{100 * r['ci95'][1]:.1f}]", f"{100 * r['accuracy_X']:.0f} / {100 * r['accuracy_Xp']:.0f} / "
                     f"{100 * r['accuracy_Xpp']:.0f}", f"{r['geodesic_correct_large']:.1f}", f"{r['time_s']:.0f}"))
        print(rows[-1], flush=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "ablation.json").write_text(json.dumps(results, indent=1))
    table = markdown_table(("variant", "views", f"{args.split} large % [95 %]", "X / X' / X'' %",
                            "geodesic error, correct (deg)", "time (s)"), rows)
    (out / "ablation.md").write_text(f"# Ablation on the {args.split} split (exact kNN)\n\n{table}\n")
    print(table)
    return results


if __name__ == "__main__":
    main()
