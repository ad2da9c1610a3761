"""The stages of the skin study on real photos and its `main`: the skin model fitted on
UCI pixels with its threshold chosen on held-out UCI pixels, then every HGR photo through ours, the
YCrCb rule and GrabCut; figures, a per-photo table and one writer."""
from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np

from experiments.config import StageResult, flatten_metrics, parse_config, progress
from experiments.data.hand_photos import hgr_names, load_photo, missing_data
from experiments.skin_real import plots
from experiments.skin_real.config import PRESETS, Config
from experiments.skin_real.evaluate import GRABCUT, METHODS, OURS, Evaluation, evaluate_photos
from experiments.skin_real.metrics import curve_scores, per_photo_iou, pooled_scores, threshold_counts
from experiments.skin_real.one_model import VARIANTS, run_one_model
from experiments.skin_real.report import one_model_report, report
from lfd_common import enable_compilation_cache
from lfd_jax import UCI_FILE, fit_thresholded_skin, load_uci_pixels


def skin_model_stage(cfg: Config):
    """(model, threshold, UCI validation curve (precision, recall) at cfg.curve_thresholds, StageResult).

    The UCI pixels are split at random (cfg.seed) into a fitting part and a held-out
    `validation_fraction`; the threshold is the IoU-best on the held-out pixels (unfiltered: single
    pixels have no neighbours), or cfg.threshold when given. The HGR photos are never looked at."""
    t0 = time.perf_counter()
    rgb, is_skin = load_uci_pixels(Path(cfg.data) / UCI_FILE)
    fitted = fit_thresholded_skin(rgb, is_skin, cfg.seed, cfg.validation_fraction, cfg.n_components,
                                  cfg.n_background, cfg.n_iter, cfg.threshold)
    model, threshold, best, best_iou = fitted.model, fitted.threshold, fitted.best_threshold, fitted.best_iou
    ratio, held_out_skin = fitted.held_out_log_ratio, fitted.held_out_is_skin
    at_threshold = pooled_scores(threshold_counts(ratio, held_out_skin, [threshold]))
    at_zero = pooled_scores(threshold_counts(ratio, held_out_skin, [0.0]))
    curve = curve_scores(threshold_counts(ratio, held_out_skin, cfg.curve_thresholds))[:2]
    metrics = {
        "threshold_ours": threshold, "threshold_source": "uci_validation" if cfg.threshold is None else "given",
        "threshold_uci_best": best, "uci_fit_pixels": fitted.n_fit, "uci_validation_pixels": len(ratio),
        "uci_validation": {"iou_ours": at_threshold["iou"], "precision_ours": at_threshold["precision"],
                           "recall_ours": at_threshold["recall"], "iou_ours_threshold_0": at_zero["iou"]},
        "uci_best_iou": best_iou, "fit_s": time.perf_counter() - t0,
    }
    return model, threshold, curve, StageResult(metrics)


def photos_stage(cfg: Config, model, threshold: float, uci_curve) -> tuple[StageResult, Evaluation]:
    """Every selected HGR photo through the three methods: pooled and per-photo scores, hand-found
    rates, times; the contact sheet and the precision/recall figure."""
    names = hgr_names(cfg.data, cfg.n_photos)
    t0 = time.perf_counter()
    photos = [load_photo(cfg.data, name) for name in progress(names, desc="reading photos")]
    load_s = time.perf_counter() - t0
    ev = evaluate_photos(cfg, model, threshold, photos)
    metrics: dict = {"n_photos": len(photos), "n_pixels": int(sum(p.truth.size for p in photos)),
                     "true_skin_fraction": float(np.mean([p.truth.mean() for p in photos])),
                     "grabcut_not_run": ev.grabcut_not_run, "load_s": load_s, "compile_s": ev.seconds["compile"],
                     "time_s_curve": ev.seconds["curve"], "time_s_components": ev.seconds["components"]}
    for m in METHODS:
        pooled = pooled_scores(ev.counts[m])
        metrics.update({f"precision_{m}": pooled["precision"], f"recall_{m}": pooled["recall"],
                        f"iou_{m}": pooled["iou"], f"iou_per_photo_mean_{m}": float(per_photo_iou(ev.counts[m]).mean()),
                        f"hand_found_rate_{m}": float(ev.found[m].mean()),
                        f"largest_component_iou_mean_{m}": float(ev.largest_iou[m].mean())})
    for m in (OURS, "ycrcb", GRABCUT):
        metrics[f"time_s_{m}"] = ev.seconds[m]
    precision, recall, iou = curve_scores(ev.curve)
    metrics["curve"] = {"thresholds": list(cfg.curve_thresholds), "precision_ours": precision.tolist(),
                        "recall_ours": recall.tolist(), "iou_ours": iou.tolist()}
    points = {m: (metrics[f"precision_{m}"], metrics[f"recall_{m}"]) for m in METHODS}
    figures = {"contact_sheet.png": plots.contact_sheet(ev.sheet),
               "precision_recall.png": plots.precision_recall(
                   cfg.curve_thresholds, {"HGR photos (median filtered)": (precision, recall),
                                          "UCI held-out pixels": uci_curve}, points, threshold)}
    return StageResult(metrics, figures), ev


def write_per_photo(path: Path, ev: Evaluation) -> None:
    """per_photo.csv: each photo's IoU and hand-found flag per method."""
    ious = {m: per_photo_iou(ev.counts[m]) for m in METHODS}
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["name"] + [f"iou_{m}" for m in METHODS] + [f"hand_found_{m}" for m in METHODS])
        for i, name in enumerate(ev.names):
            out.writerow([name] + [f"{ious[m][i]:.4f}" for m in METHODS] + [int(ev.found[m][i]) for m in METHODS])


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, name="skin_real", argv=argv)
    message = missing_data(cfg.data)
    if message:
        raise SystemExit(message)
    enable_compilation_cache()
    if cfg.study == "one_model":
        return one_model_main(cfg, run)
    start = time.perf_counter()
    model, threshold, uci_curve, model_result = skin_model_stage(cfg)
    photos_result, ev = photos_stage(cfg, model, threshold, uci_curve)
    runtime = time.perf_counter() - start
    write_per_photo(run.file("per_photo.csv"), ev)
    metrics = flatten_metrics({**model_result.metrics, **photos_result.metrics})
    written = run.write_stages([model_result, photos_result], header=report(cfg, metrics, runtime), runtime_s=runtime)
    print(f"IoU ours {written['iou_ours']:.3f}, YCrCb {written['iou_ycrcb']:.3f}, "
          f"GrabCut {written['iou_grabcut']:.3f}; "
          f"hand found ours {written['hand_found_rate_ours']:.3f} on {written['n_photos']} photos; "
          f"wrote {run.path}/ in {runtime:.0f} s")
    return written


def one_model_main(cfg: Config, run) -> dict:
    """The one-model study: fit, choose on validation, report on every real set; writes the model
    (skin_model.npz, its threshold the generic variant's chosen one; `hog_jax.load_skin_model` reads it)."""
    from hog_jax import save_skin_model
    metrics, figures, settings = run_one_model(cfg)
    generic = settings["generic"]
    save_skin_model(run.file("skin_model.npz"), generic.model._replace(threshold=np.float32(generic.threshold)))
    written = run.write_stages([StageResult(metrics, figures)], header=one_model_report(cfg, metrics),
                               runtime_s=metrics["total_s"])
    line = ", ".join(f"{v} {metrics['hgr_test'][v]['iou']:.3f}" for v in VARIANTS)
    print(f"HGR held-out IoU: {line}; wrote {run.path}/ in {metrics['total_s']:.0f} s")
    return written
