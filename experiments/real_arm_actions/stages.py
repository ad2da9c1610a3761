"""The stages of the real-arm action study and its `main`: one classification stage per data kind
(joint angles, raw markers), each with the side PHMMs. Each stage returns a `StageResult` (nested
metrics, figures, a report section); `main` writes them through `RunOutput.write_stages`."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from experiments.config import StageResult, parse_config
from experiments.real_arm_actions import evaluation as ev
from experiments.real_arm_actions import plots, report
from experiments.real_arm_actions.config import PRESETS, Config
from experiments.real_arm_actions.data import has_kind, load_dataset
from lfd_common import enable_compilation_cache

KINDS = ("angles", "markers")
PREFIX = {"angles": "", "markers": "markers_"}  # the issue's keys (accuracy_edhmm, ...) are the angles'
SUMMARY = ("accuracy_edhmm", "accuracy_hmm", "accuracy_hmmlearn", "accuracy_dtw", "side_accuracy_phmm",
           "side_accuracy_regression", "markers_accuracy_edhmm", "markers_accuracy_hmm", "markers_accuracy_hmmlearn",
           "markers_accuracy_dtw", "markers_side_accuracy_phmm", "markers_side_accuracy_regression",
           "side_error_phmm", "side_error_regression", "markers_side_error_phmm", "markers_side_error_regression",
           "runtime_s")


def folds_for(cfg: Config, kind: str):
    """Leave-one-person-out over `cfg.data`, or the one fold `cfg.train` -> `cfg.test`."""
    if cfg.train is not None:
        return [(load_dataset(cfg.train, kind, cfg.n_frames, cfg.n_persons, cfg.max_gap_s),
                 load_dataset(cfg.test, kind, cfg.n_frames, cfg.n_persons, cfg.max_gap_s))]
    return ev.leave_one_person_out(load_dataset(cfg.data, kind, cfg.n_frames, cfg.n_persons, cfg.max_gap_s))


def classification_metrics(results: dict[str, ev.MethodResult], side: ev.SideResult | None) -> dict:
    """Nested metrics of one kind (flattened by the writer, keys without the kind's prefix)."""
    metrics = {
        "accuracy": {m: r.accuracy for m, r in results.items()},
        "per_person_accuracy": {m: r.per_person() for m, r in results.items()},
        "confusion": {m: r.confusion().tolist() for m, r in results.items()},
        "train_time_s": {m: r.train_s for m, r in results.items()},
        "train_time_s_median_fold": {m: float(np.median(r.train_s_per_fold)) for m, r in results.items()},
        "test_time_s": {m: r.test_s for m, r in results.items()},
        "selection_time_s": {m: r.selection_s for m, r in results.items()},
        "selected_setting": {m: [str(s) for s in r.settings] for m, r in results.items() if m != "dtw"},
        "n_test_sequences": len(results["edhmm"].truth),
    }
    if side is not None:
        metrics.update({
            "side_accuracy_phmm": float(side.side_correct.mean()),
            "side_accuracy_regression": float(side.regression_correct.mean()),
            "side_error_phmm": float(np.mean(np.abs(side.phi - side.side))),
            "side_error_regression": float(np.mean(np.abs(side.regression - side.side))),
            "per_person_side_accuracy_regression": side.per_person(side.regression_correct),
            "action_accuracy_phmm": float((side.action == side.truth).mean()),
            "per_person_side_accuracy_phmm": side.per_person(side.side_correct),
            "side_floors_chosen": list(side.floors),
            "train_time_s_phmm": side.train_s, "test_time_s_phmm": side.test_s})
    return metrics


def classification_stage(cfg: Config, kind: str) -> StageResult:
    """The four methods and the side PHMMs on one kind of data, on the same folds."""
    folds = folds_for(cfg, kind)
    results, side = ev.evaluate(folds, cfg)
    metrics = classification_metrics(results, side)
    figures = {f"confusion_{kind}.png": plots.plot_confusions(results, kind),
               f"accuracy_per_person_{kind}.png": plots.plot_per_person(results, kind)}
    if side is not None:
        figures[f"side_phi_{kind}.png"] = plots.plot_side_phi(side, kind)
    flat_prefix = PREFIX[kind]
    return StageResult({f"{flat_prefix}{k}": v for k, v in metrics.items()}, figures,
                       report.section(kind, folds, results, side, cfg))


def available_kinds(cfg: Config) -> list[str]:
    roots = [cfg.data] if cfg.train is None else [cfg.train, cfg.test]
    wanted = KINDS if cfg.use_markers else KINDS[:1]
    return [k for k in wanted if all(has_kind(r, k) for r in roots)]


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, name="real_arm_actions", argv=argv)
    kinds = available_kinds(cfg)
    if not kinds:
        where = cfg.data if cfg.train is None else f"{cfg.train} and {cfg.test}"
        message = (f"real_arm_actions: skipped, no UE-ADL data at {where} (expected angles/<person>/... or "
                   "markers/<person>/...; the data set is described in ../shared/data/ue_adl/README.md)")
        print(message, file=sys.stderr)
        return run.write({"skipped": True}, report.skipped(message))
    enable_compilation_cache()
    start = time.perf_counter()
    results = []
    for kind in kinds:
        t0 = time.perf_counter()
        results.append(classification_stage(cfg, kind))
        print(f"{kind}: {time.perf_counter() - t0:.1f} s", flush=True)
    runtime_s = time.perf_counter() - start
    written = run.write_stages(results, report.header(cfg, kinds, runtime_s), skipped=False, runtime_s=runtime_s)
    print(json.dumps({k: written[k] for k in SUMMARY if k in written}, indent=1))
    print(f"written to {Path(run.path)}")
    return written
