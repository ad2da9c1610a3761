"""The stages of the grasp recognition study and its `main`: database and test sets, recognition
(class, orientation), LSH against exact kNN, the sensitivity sweeps; written through `RunOutput.write`."""
from __future__ import annotations

import time
from typing import Any, NamedTuple

import jax
import numpy as np

import hog_jax
import sim
from experiments.bench.timing import time_call
from experiments.config import StageResult, parse_config
from experiments.data.grasp_tests import random_set, sequence_set, skin_training_pixels, stage_subsets
from experiments.grasp_recognition import plots
from experiments.grasp_recognition.config import EULER_NAMES, PRESETS, Config
from experiments.grasp_recognition.pieces import (accuracy, bar, render_database, hog_features, held_out_views, knn_predict,
                                                  robot_accuracy, segment_frames, sweeps, confusion,
                                                  orientation_errors_deg, wilson_interval)
from experiments.grasp_recognition.report import report
from lfd_common import enable_compilation_cache
from sim.grasp_objects import GRASP_CLASSES


class Setup(NamedTuple):
    """The database and its kNN model and LSH index, the segmented test sets and their features."""

    db: Any
    db_x: np.ndarray
    model: Any
    tune: Any
    lsh: dict
    tests: dict   # name -> test set (X, large)
    seg: dict     # name -> (images, masks, found)
    feats: dict   # name -> HOG (N, D)
    metrics: dict


def setup_stage(cfg: Config) -> Setup:
    """Render the database and the test sets, fit the skin model, segment, HOG, kNN model, tuned LSH."""
    hcfg = hog_jax.HOGConfig(n_bins=cfg.n_bins, n_levels=cfg.n_levels)
    key = jax.random.key(cfg.seed)
    t0 = time.perf_counter()
    db = render_database(cfg, cfg.n_azimuth, cfg.n_elevation)
    db_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    X = sequence_set(cfg.seed, cfg.frame_size, progress=bar("render X"))
    large = random_set(cfg.n_large, cfg.seed, cfg.frame_size, progress=bar("render large set"))
    skin_px, bg_px = skin_training_pixels(cfg.seed, cfg.n_skin_images)
    skin = hog_jax.fit_skin_model(jax.random.fold_in(key, 1), skin_px, bg_px)
    tests_s = time.perf_counter() - t0

    both = segment_frames(skin, np.concatenate([X.frames, large.frames]), cfg.crop_size)  # one worker for both
    seg = {"X": tuple(a[: len(X.labels)] for a in both), "large": tuple(a[len(X.labels):] for a in both)}
    tests = {"X": X, "large": large}
    db_x = hog_features(db.images, db.masks, np.ones(len(db.labels), bool), hcfg)
    model = hog_jax.fit(db_x, db.labels, db.euler, n_classes=len(GRASP_CLASSES), seed=cfg.seed)
    ho_img, ho_mask = held_out_views(cfg)
    ho_x = hog_features(ho_img, ho_mask, np.ones(len(ho_img), bool), hcfg)
    tune = hog_jax.tune(jax.random.fold_in(key, 2), db_x, ho_x, k=cfg.k, target_recall=cfg.lsh_target_recall)
    index = hog_jax.build_index(jax.random.fold_in(key, 3), db_x, tune.n_bits, tune.n_tables)
    lsh = dict(index=index, n_per_table=tune.n_per_table, n_tables=tune.n_tables, max_rerank=tune.max_rerank)
    feats = {name: hog_features(*seg[name], hcfg) for name in tests}
    metrics = {"n_database_views": len(db.labels), "n_views_per_grasp": cfg.n_azimuth * cfg.n_elevation,
               "n_test_X": len(X.labels), "n_test_large": len(large.labels), "hog_dim": int(db_x.shape[1]),
               "knn_sigma": float(model.sigma), "time_database_s": db_s, "time_tests_s": tests_s}
    return Setup(db, db_x, model, tune, lsh, tests, seg, feats, metrics)


def recognition_stage(cfg: Config, s: Setup) -> tuple[StageResult, dict]:
    """Class (eq. 3) and orientation (eq. 4) of every test image, by LSH and by exact kNN: accuracies
    with intervals, per reach stage, robot preshapes, orientation errors; the per-image results
    (lists, confusion matrices) as a second, nested return value."""
    X, large = s.tests["X"], s.tests["large"]
    res, res_exact = {}, {}
    for name in s.tests:
        res[name] = knn_predict(s.model, s.feats[name], s.seg[name][2], cfg.k, **s.lsh)
        res_exact[name] = knn_predict(s.model, s.feats[name], s.seg[name][2], cfg.k)
    m: dict = {}
    mats, accs = {}, {}
    subsets = {**{k_: (X, res["X"], v) for k_, v in stage_subsets(X.stage).items()},
               "large": (large, res["large"], np.ones(len(large.labels), bool))}
    for name, (t, r, sel) in subsets.items():
        accs[name] = accuracy(r[0][sel], t.labels[sel])
        mats[name] = confusion(t.labels[sel], r[0][sel], len(GRASP_CLASSES))
        m[f"accuracy_{name}"] = accs[name]
    for name, t in s.tests.items():
        m[f"segmentation_found_rate_{name}"] = float(np.mean(s.seg[name][2]))
        m[f"accuracy_{name}_exact_knn"] = accuracy(res_exact[name][0], t.labels)
        lo, hi = wilson_interval(int(np.sum(res[name][0] == t.labels)), len(t.labels))
        m[f"accuracy_{name}_ci95_low"], m[f"accuracy_{name}_ci95_high"] = lo, hi
        m.update({f"{k_}_{name}": v for k_, v in robot_accuracy(res[name][0], t.labels).items()})
    for st, sname in enumerate(("stage0", "stage1", "stage2")):
        sel = large.stage == st
        m[f"accuracy_large_{sname}"] = accuracy(res["large"][0][sel], large.labels[sel])

    # orientation (eq. 4), over every test image with a hand found, and over the correctly classified ones
    errs, geo = {}, {}
    for name, t in s.tests.items():
        ok = s.seg[name][2]
        e, g = orientation_errors_deg(res[name][1][ok], t.euler[ok], res[name][2][ok], t.quat[ok])
        right = res[name][0][ok] == t.labels[ok]
        errs[name], geo[name] = e.mean(0), float(g.mean())
        for j, an in enumerate(EULER_NAMES):
            m[f"orientation_error_deg_{an}_{name}"] = float(e[:, j].mean())
            m[f"orientation_error_deg_{an}_{name}_correct"] = float(e[right, j].mean()) if right.any() else float("nan")
        m[f"orientation_geodesic_error_deg_{name}"] = geo[name]
        m[f"orientation_geodesic_error_deg_{name}_correct"] = float(g[right].mean()) if right.any() else float("nan")
        m[f"orientation_geodesic_error_deg_{name}_median"] = float(np.median(g))
    nested = {"orientation_error_deg": [float(v) for v in errs["X"]],
              "orientation_error_deg_large": [float(v) for v in errs["large"]],
              "orientation_geodesic_error_deg": geo["X"],
              "confusion_X": mats["X"].tolist(), "confusion_large": mats["large"].tolist(),
              "true_class_X": [GRASP_CLASSES[i] for i in X.labels],
              "recognised_class_X": [GRASP_CLASSES[i] if i >= 0 else -1 for i in res["X"][0]],
              "stage_X": X.stage.tolist()}
    found = s.seg["X"][2]
    picks = [i for i in np.flatnonzero(found)][:: max(1, int(found.sum()) // 4)][:4]
    figures = {
        "confusion.png": plots.plot_confusions(mats, accs),
        "orientation.png": plots.plot_orientation(errs, geo),
        "neighbours.png": plots.plot_neighbours([(s.seg["X"][0][i], i) for i in picks], s.db, res["X"][3],
                                                res["X"][4], X.labels, res["X"][0]),
        "contact_sheet.png": plots.plot_contact_sheet(s.db, X, s.seg["X"][0], cfg.n_azimuth * cfg.n_elevation),
    }
    return StageResult(m, figures), {**nested, "mats": mats}


def lsh_stage(cfg: Config, s: Setup) -> StageResult:
    """LSH against exact kNN on the large set: recall@k and query time."""
    q = s.feats["large"][s.seg["large"][2]]
    tune = s.tune
    exact = hog_jax.exact_search(s.db_x, q, cfg.k)
    approx = hog_jax.query(s.lsh["index"], q, cfg.k, tune.n_per_table, tune.n_tables, max_rerank=tune.max_rerank)
    t_lsh = time_call(lambda: hog_jax.predict(s.model, q, cfg.k, **s.lsh).label, cfg.timing_repeats).median_s
    t_exact = time_call(lambda: hog_jax.predict(s.model, q, cfg.k).label, cfg.timing_repeats).median_s
    return StageResult({"lsh_recall_at_k": hog_jax.recall_at_k(approx.indices, exact.indices),
                        "lsh_recall_at_k_held_out": float(tune.recall), "lsh_n_bits": tune.n_bits,
                        "lsh_n_tables": tune.n_tables, "lsh_max_rerank": tune.max_rerank,
                        "lsh_mean_scanned": float(np.mean(np.asarray(approx.n_scanned))),
                        "query_ms": 1e3 * t_lsh / len(q), "query_ms_exact": 1e3 * t_exact / len(q),
                        "n_queries_timed": len(q)})


def sweep_stage(cfg: Config, s: Setup) -> StageResult:
    """Accuracy (exact kNN) against k, the database grid and (B, L)."""
    sw = sweeps(cfg, s.db, s.tests, s.seg, cfg.k)
    m = {}
    for name, accs_k in sw["k"].items():
        m.update({f"accuracy_{name}_k{kk}": v for kk, v in accs_k.items()})
    for name, accs_d in sw["db"].items():
        m.update({f"accuracy_{name}_db{n}": v for n, v in accs_d.items()})
    for name, accs_bl in sw["bl"].items():
        m.update({f"accuracy_{name}_B{b}_L{lv}": v for (b, lv), v in accs_bl.items()})
        vals = np.array(list(accs_bl.values()))
        m[f"accuracy_{name}_BL_range"] = float(vals.max() - vals.min())
    return StageResult(m, {"sweeps.png": plots.plot_sweeps(sw, cfg)})


def run_experiment(cfg: Config) -> tuple[StageResult, dict]:
    """Every stage: (flat metrics, figures and report; nested per-image results)."""
    t_start = time.perf_counter()
    s = setup_stage(cfg)
    recognition, nested = recognition_stage(cfg, s)
    lsh, sweep = lsh_stage(cfg, s), sweep_stage(cfg, s)
    mats = nested.pop("mats")
    m = {**s.metrics, **recognition.metrics, **lsh.metrics, **sweep.metrics}
    m["time_total_s"] = time.perf_counter() - t_start
    return StageResult(m, {**recognition.figures, **sweep.figures}, report(cfg, m, nested, mats)), nested


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, "grasp_recognition", argv)
    sim.setup_rendering()
    enable_compilation_cache()
    result, nested = run_experiment(cfg)
    run.write({**result.metrics, **nested}, result.report, result.figures)  # nested: per-image lists
    print(result.report)
    return result.metrics
