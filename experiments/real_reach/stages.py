"""The stages of the real-reach study and its `main`: one size stage per feature normalisation
(offline and online accuracy of every method, PHMM diagnostics) and one event stage (onset and
contact). Each returns a `StageResult`; `main` writes them through `RunOutput.write_stages`."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from experiments.config import StageResult, parse_config
from experiments.real_reach import evaluation as ev
from experiments.real_reach import plots, report
from experiments.real_reach.config import METHODS, PRESETS, Config
from experiments.real_reach.data import load_movements, npz_path
from lfd_common import enable_compilation_cache

SUMMARY = tuple(f"{n}_accuracy_{m}" for n in ("person", "pixels") for m in METHODS) + (
    "person_accuracy_60pct_phmm", "person_accuracy_60pct_aperture", "person_phmm_edge_share",
    "onset_median_abs_error_frames_speed", "contact_median_abs_error_frames_speed", "runtime_s")


def _pct(f: float) -> str:
    return f"{round(100 * f)}pct"


def size_metrics(r: ev.SizeResult, cfg: Config) -> dict:
    """Nested metrics of one size stage (flattened by the writer)."""
    metrics = {
        "accuracy": {m: r.accuracy(m) for m in METHODS},
        "per_person_accuracy": {m: r.per_person(m) for m in METHODS},
        "confusion": {m: r.confusion(m).tolist() for m in METHODS},
        "phmm_lattice_accuracy": float(np.mean(r.lattice_full == r.truth)),
        "phmm_edge_share": r.edge_share,
        "phmm_median_abs_error_cm": float(np.median(np.abs(r.phmm_cm - np.array([2.5, 5.5, 7.5])[r.truth]))),
        "phmm_loglik_range_per_frame_median": float(np.median(r.ll_range_per_frame)),
        "phmm_loglik_gap_true_median": float(np.median(r.ll_gap_true)),
        "phmm_recognition_ms_per_reach": 1000 * r.recognition_s_per_reach,
        "selected_setting": {m: [str(s) for s in r.settings[m]] for m in r.settings},
        "n_test_reaches": len(r.truth),
    }
    for f in cfg.fractions:
        metrics[f"accuracy_{_pct(f)}"] = {m: r.accuracy(m, f) for m in METHODS}
        metrics[f"per_person_accuracy_{_pct(f)}"] = {m: r.per_person(m, f) for m in METHODS}
    return metrics


def size_stage(movements, normalisation: str, cfg: Config) -> StageResult:
    """Sizes by every method with the features of `normalisation`: metrics, figures, report section."""
    result = ev.evaluate_sizes(movements, normalisation, cfg)
    metrics = size_metrics(result, cfg)
    figures = {f"accuracy_vs_reach_{normalisation}.png": plots.plot_online(result, cfg, normalisation),
               f"confusion_{normalisation}.png": plots.plot_confusions(result, normalisation),
               f"phmm_phi_{normalisation}.png": plots.plot_phi(result, normalisation)}
    return StageResult({f"{normalisation}_{k}": v for k, v in metrics.items()}, figures,
                       report.size_section(result, metrics, normalisation, cfg))


def event_stage(movements, cfg: Config) -> StageResult:
    """Onset and contact by both detectors: metrics, the error histograms, report section."""
    r = ev.evaluate_events(movements, cfg)
    metrics = {}
    for name in r.onset_error:
        key = name.replace(" ", "_")
        for event, err, lat in (("onset", r.onset_error, r.onset_latency), ("contact", r.contact_error, r.contact_latency)):
            metrics[f"{event}_median_abs_error_frames_{key}"] = float(np.median(np.abs(err[name])))
            metrics[f"{event}_median_error_frames_{key}"] = float(np.median(err[name]))
            metrics[f"{event}_median_latency_frames_{key}"] = float(np.median(lat[name]))
            metrics[f"{event}_p90_latency_frames_{key}"] = float(np.percentile(lat[name], 90))
            metrics[f"{event}_per_person_median_abs_error_frames_{key}"] = {
                f"P{p}": float(np.median(np.abs(err[name][r.person == p]))) for p in sorted(set(r.person.tolist()))}
    metrics["speed_selected"] = [str(p) for p in r.speed_params]
    return StageResult(metrics, {"event_errors.png": plots.plot_events(r)}, report.event_section(r, metrics, cfg))


def main(argv=None) -> dict:
    """Run the study from command-line flags (`experiments.config.parse_config`); returns the metrics."""
    cfg, run = parse_config(Config, PRESETS, name="real_reach", argv=argv)
    if not npz_path(cfg.data).is_file():
        message = (f"real_reach: skipped, no reach-grasp data at {cfg.data} (expected {npz_path(cfg.data).name}; "
                   "the data set is described in ../shared/data/README.md)")
        print(message, file=sys.stderr)
        return run.write({"skipped": True}, report.skipped(message))
    enable_compilation_cache()
    start = time.perf_counter()
    movements = load_movements(cfg.data, cfg.n_persons, cfg.max_gap_s, cfg.per_class)
    results = []
    for normalisation in cfg.normalisations:
        t0 = time.perf_counter()
        results.append(size_stage(movements, normalisation, cfg))
        print(f"sizes ({normalisation}): {time.perf_counter() - t0:.1f} s", flush=True)
    t0 = time.perf_counter()
    results.append(event_stage(movements, cfg))
    print(f"events: {time.perf_counter() - t0:.1f} s", flush=True)
    runtime_s = time.perf_counter() - start
    written = run.write_stages(results, report.header(cfg, movements, runtime_s), skipped=False, runtime_s=runtime_s)
    print(json.dumps({k: written[k] for k in SUMMARY if k in written}, indent=1))
    print(f"written to {Path(run.path)}")
    return written

