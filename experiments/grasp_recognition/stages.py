"""The stages of the grasp recognition study and its `main`: database and test sets, recognition
(class, orientation), LSH against exact kNN, the sensitivity sweeps; written through `RunOutput.write`."""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any, NamedTuple

import jax
import numpy as np

import hog_jax
import sim
from experiments.timing import time_call
from experiments.config import StageResult, flatten_metrics, parse_config, progress
from experiments.data.grasp_database import VALIDATION_SHAPE
from experiments.data.grasp_tests import random_set, sequence_set, skin_training_pixels
from experiments.grasp_recognition import plots
from experiments.grasp_recognition.config import EULER_NAMES, PRESETS, Config
from experiments.grasp_recognition.ladder import RUNGS, mask_crops, rung_sets
from experiments.grasp_recognition.real_grasps import evaluate_real_grasps
from experiments.grasp_recognition.real_photos import GTEA_DIR, HGR_DIR, evaluate_real_photos
from experiments.grasp_recognition.pieces import accuracy, bar, held_out_views, robot_accuracy, sweeps
from experiments.grasp_recognition.recogniser import recogniser_of, study_database
from experiments.grasp_recognition.scoring import score_sets
from experiments.grasp_recognition.report import report
from lfd_common import enable_compilation_cache
from lfd_jax import fit_real_skin_model
from lfd_jax.grasp import Crops, Recogniser, net_labels, segment_frames
from sim.grasping import GRASP_CLASSES


class Setup(NamedTuple):
    """The recogniser (database, metric, kNN model, LSH index), the skin model, the segmented test sets
    and their scores, and the setup's metrics."""

    rec: Recogniser
    skin: Any
    tests: dict   # name -> test set (X, large)
    seg: dict     # name -> (images, masks, found)
    scores: Any   # scoring.SetScores of the full test
    metrics: dict


def validation_crops(cfg: Config, skin) -> Crops:
    """Query-like validation images (their own seed and hand, `VALIDATION_SHAPE`, every nuisance of the
    test), skin-segmented like the test."""
    val = random_set(cfg.n_validation, cfg.seed + 1, cfg.frame_size, shape=VALIDATION_SHAPE,
                     progress=bar("render validation set"))
    return segment_frames(skin, val.frames, cfg.crop_size, adaptation=cfg.skin_adaptation)


def setup_stage(cfg: Config) -> Setup:
    """Render the database and the test sets, fit the skin model, segment, build the recogniser (LSH
    tuned on held-out database views or on validation images, `cfg.lsh_tuning`) and score the tests."""
    key = jax.random.key(cfg.seed)
    t0 = time.perf_counter()
    db = study_database(cfg)
    db_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    X = sequence_set(cfg.seed, cfg.frame_size, progress=bar("render X"))
    large = random_set(cfg.n_large, cfg.seed, cfg.frame_size, progress=bar("render large set"))
    skin_px, bg_px = skin_training_pixels(cfg.seed, cfg.n_skin_images)
    skin = hog_jax.fit_skin_model(jax.random.fold_in(key, 1), skin_px, bg_px)
    tests_s = time.perf_counter() - t0

    both = segment_frames(skin, np.concatenate([X.frames, large.frames]), cfg.crop_size,  # one worker for both
                          adaptation=cfg.skin_adaptation)
    seg = {"X": both.take(slice(None, len(X.labels))), "large": both.take(slice(len(X.labels), None))}
    tests = {"X": X, "large": large}
    if cfg.lsh_tuning == "database":
        ho_img, ho_mask = held_out_views(cfg)
        tuning = Crops(ho_img, ho_mask, np.ones(len(ho_img), bool), ho_img)  # database views: black around the hand
    else:
        tuning = validation_crops(cfg, skin)
    rec = recogniser_of(cfg, key, db, tuning, skin)
    scores = score_sets(rec, tests, seg)
    metrics = {"n_database_views": len(db.labels), "n_views_per_grasp": len(db.labels) // len(GRASP_CLASSES),
               "n_test_X": len(X.labels), "n_test_large": len(large.labels), "hog_dim": int(rec.model.data.shape[1]),
               "knn_sigma": float(rec.model.sigma), "time_database_s": db_s, "time_tests_s": tests_s}
    return Setup(rec, skin, tests, seg, scores, metrics)


def recognition_stage(cfg: Config, s: Setup) -> tuple[StageResult, dict]:
    """Class (eq. 3) and orientation (eq. 4) of every test image, by LSH and by exact kNN: accuracies
    with intervals, per reach stage, robot preshapes, orientation errors; the per-image results
    (lists, confusion matrices) as a second, nested return value."""
    X, large = s.tests["X"], s.tests["large"]
    sc = s.scores
    res = {name: r[0] for name, r in sc.results.items()}
    m = {k_: v for k_, v in sc.metrics.items() if not isinstance(v, list)}
    for name, t in s.tests.items():
        m.update({f"{k_}_{name}": v for k_, v in robot_accuracy(res[name].labels, t.labels).items()})
        for j, an in enumerate(EULER_NAMES):
            m[f"orientation_error_deg_{an}_{name}"] = sc.metrics[f"orientation_euler_error_deg_{name}"][j]
    for st, sname in enumerate(("stage0", "stage1", "stage2")):
        sel = large.stage == st
        m[f"accuracy_large_{sname}"] = accuracy(res["large"].labels[sel], large.labels[sel])
    # the headline key: on X's correctly classified images, like the plain `orientation_geodesic_error_deg`
    m["orientation_geodesic_error_deg_correct"] = m["orientation_geodesic_error_deg_X_correct"]
    m["lsh_recall_at_k_test_queries"] = m.pop("lsh_recall_at_k_large")
    m.pop("lsh_recall_at_k_X")
    mats = {name: sc.mats[name] for name in ("X", "Xp", "Xpp", "large")}
    accs = {name: m[f"accuracy_{name}"] for name in mats}
    errs = {name: np.asarray(sc.metrics[f"orientation_euler_error_deg_{name}"]) for name in s.tests}
    geo = {name: m[f"orientation_geodesic_error_deg_{name}"] for name in s.tests}
    nested = {"orientation_error_deg": errs["X"].tolist(), "orientation_error_deg_large": errs["large"].tolist(),
              "orientation_geodesic_error_deg": geo["X"],
              "confusion_X": mats["X"].tolist(), "confusion_large": mats["large"].tolist(),
              "true_class_X": [GRASP_CLASSES[i] for i in X.labels],
              "recognised_class_X": [GRASP_CLASSES[i] if i >= 0 else -1 for i in res["X"].labels],
              "stage_X": X.stage.tolist()}
    found = s.seg["X"].found
    picks = [i for i in np.flatnonzero(found)][:: max(1, int(found.sum()) // 6)][:6]
    figures = {
        "confusion.png": plots.plot_confusions(mats, accs),
        "orientation.png": plots.plot_orientation(errs, geo),
        "neighbours.png": plots.plot_neighbours([(s.seg["X"].images[i], i) for i in picks], s.rec.db, res["X"].indices,
                                                res["X"].distances, X.labels, res["X"].labels),
        "contact_sheet.png": plots.plot_contact_sheet(s.rec.db, X, s.seg["X"].images, cfg.n_azimuth * cfg.n_elevation),
    }
    return StageResult(m, figures), {**nested, "mats": mats}


def ladder_stage(cfg: Config, s: Setup) -> StageResult:
    """The ladder (`ladder.RUNGS`): rungs 1-5 rendered and cropped by the renderer's hand mask, rung 6 the
    full test; per rung the scores of `scoring.score_sets` (flattened under `ladder_`) and the figure."""
    per_rung = []
    for r, rung in enumerate(progress(RUNGS, desc="ladder")):
        if rung.skin_segmentation:
            per_rung.append(s.scores.metrics)
            continue
        tests = rung_sets(cfg, rung)
        per_rung.append(score_sets(s.rec, tests, {n: mask_crops(t, cfg.crop_size) for n, t in tests.items()}).metrics)
    keys = ("accuracy_X", "accuracy_Xp", "accuracy_Xpp", "accuracy_large", "accuracy_large_ci95_low",
            "accuracy_large_ci95_high", "orientation_geodesic_error_deg_large",
            "orientation_geodesic_error_deg_large_correct", "orientation_geodesic_error_deg_X_correct",
            "lsh_recall_at_k_large", "accuracy_large_exact_knn")
    m = {f"ladder_{k_}": [float(p[k_]) for p in per_rung] for k_ in keys}
    m["ladder_accuracy"] = m["ladder_accuracy_large"]
    m["ladder_rungs"] = [rung.name for rung in RUNGS]
    return StageResult(m, {"ladder.png": plots.plot_ladder(m)})


def lsh_stage(cfg: Config, s: Setup) -> StageResult:
    """LSH against exact kNN on the large set's queries: recall@k and query time (features to label)."""
    rec = s.rec
    q = s.scores.features["large"][s.seg["large"].found]
    exact = hog_jax.exact_search(rec.model.data, q, cfg.k)
    lsh_args = {k_: v for k_, v in rec.lsh.items() if k_ != "index"}
    approx = hog_jax.query(rec.lsh["index"], q, cfg.k, **lsh_args)
    t_lsh = time_call(lambda: hog_jax.predict(rec.model, q, cfg.k, **rec.lsh).label, cfg.timing_repeats).median_s
    t_exact = time_call(lambda: hog_jax.predict(rec.model, q, cfg.k).label, cfg.timing_repeats).median_s
    net = {}
    if rec.net is not None:  # the network's class of the same found crops (orientation: eq. 4, as timed above)
        found_crops = s.seg["large"].take(s.seg["large"].found)
        t_net = time_call(lambda: net_labels(rec, found_crops), cfg.timing_repeats).median_s
        net = {"classifier_ms": 1e3 * t_net / len(q)}
    return StageResult({**net, "lsh_recall_at_k": hog_jax.recall_at_k(approx.indices, exact.indices),
                        "lsh_recall_at_k_tuning": float(rec.tune.recall), "lsh_n_bits": rec.tune.n_bits,
                        "lsh_n_tables": rec.tune.n_tables, "lsh_max_rerank": rec.tune.max_rerank,
                        "lsh_n_probes": cfg.lsh_probes, "lsh_tuning": cfg.lsh_tuning,
                        "lsh_mean_scanned": float(np.mean(np.asarray(approx.n_scanned))),
                        "query_ms": 1e3 * t_lsh / len(q), "query_ms_exact": 1e3 * t_exact / len(q),
                        "n_queries_timed": len(q)})


def sweep_stage(cfg: Config, s: Setup) -> StageResult:
    """Accuracy (exact kNN, plain HOG) against k, the database grid and (B, L)."""
    if not cfg.sweeps:
        return StageResult({}, {})
    sw = sweeps(cfg, s.rec.db, s.tests, s.seg, cfg.k)
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


def real_photos_stage(cfg: Config, s: Setup | None) -> StageResult:
    """Hands found on the real photos of `cfg.real_photos` (`real_photos.evaluate_real_photos`): metrics
    `real_<set>_<method>_<figure>`; the grasp class of the real hands at their true boxes by the study's
    recogniser (`s.rec`, `real_grasps.evaluate_real_grasps`): `real_grasp_<method>_<figure>`; skipped,
    saying so, when the folder lacks the two sets (where `s` is not used)."""
    if cfg.real_photos == "none":
        return StageResult({}, {})
    data = Path(cfg.real_photos)
    if not (data / GTEA_DIR).is_dir() or not (data / HGR_DIR).is_dir():
        print(f"note: {data} lacks {GTEA_DIR}/ or {HGR_DIR}/; the real-photo stage is skipped")
        return StageResult({"real_photos_scored": False}, {})
    metrics, figures = evaluate_real_photos(data)
    metrics.pop("options")
    grasps, grasp_figures = evaluate_real_grasps(s.rec, fit_real_skin_model(data, seed=cfg.seed), data, cfg.crop_size)
    return StageResult({"real_photos_scored": True, **flatten_metrics(metrics, "real_"),
                        **flatten_metrics(grasps, "real_grasp_")}, {**figures, **grasp_figures})


def run_experiment(cfg: Config) -> tuple[StageResult, dict]:
    """Every stage: (flat metrics, figures and report; nested per-image results)."""
    t_start = time.perf_counter()
    s = setup_stage(cfg)
    recognition, nested = recognition_stage(cfg, s)
    lsh, sweep = lsh_stage(cfg, s), sweep_stage(cfg, s)
    ladder = ladder_stage(cfg, s) if cfg.ladder else StageResult({}, {})
    real = real_photos_stage(cfg, s)
    mats = nested.pop("mats")
    m = {**s.metrics, **recognition.metrics, **lsh.metrics, **sweep.metrics, **ladder.metrics, **real.metrics}
    m["time_total_s"] = time.perf_counter() - t_start
    figures = {**recognition.figures, **sweep.figures, **ladder.figures, **real.figures}
    return StageResult(m, figures, report(cfg, m, nested, mats)), nested


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, "grasp_recognition", argv)
    sim.setup_rendering()
    enable_compilation_cache()
    result, nested = run_experiment(cfg)
    run.write({**result.metrics, **nested}, result.report, result.figures)  # nested: per-image lists
    print(result.report)
    return result.metrics
