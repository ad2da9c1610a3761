"""The stages of the grasp mapping study and its `main`: every trial of every hand as one batch, the
tables and the paper's claims, the figures; written through `RunOutput.write`."""
from __future__ import annotations

import time

import numpy as np

import sim
from experiments.config import StageResult, parse_config, progress
from experiments.grasp_mapping import plots
from experiments.grasp_mapping.config import PRESETS, Config, conditions
from experiments.grasp_mapping.report import report
from experiments.grasp_mapping.trials import finite_mean, claims, run_hand, summarise
from lfd_common import enable_compilation_cache
from sim.grasping import GRASP_NAMES, VOLAR_GRASPS
from sim.grasping import SUBSTEPS, resolve_backend
from sim.grasping import DONE, n_control_steps


def rollout_stage(cfg: Config, backend: str) -> tuple[dict[str, dict], float]:
    """Every trial of every hand (one batch per hand): (per-hand results, seconds)."""
    start = time.perf_counter()
    results = {hand: run_hand(cfg, hand, backend) for hand in progress(cfg.hands, desc=f"grasp trials ({backend})")}
    return results, time.perf_counter() - start


def hand_metrics(h: str, r: dict) -> dict:
    """Success, VF errors without pose error, slip during the hold, unfinished trials, time of hand `h`."""
    lifted, none = r["outcomes"].lifted, (r["cond"] == 0) & r["tactile"]
    slip = r["outcomes"].slip_mm[lifted & np.isfinite(r["outcomes"].slip_mm)]
    return {f"success_rate_{h}": float(lifted.mean()), f"success_rate_{h}_no_error": float(lifted[none].mean()),
            f"vf_position_error_mm_{h}_no_error": finite_mean(r["pos_err"][none]),
            f"vf_orientation_error_deg_{h}_no_error": finite_mean(r["ang_err"][none]),
            f"slip_mm_{h}_median": float(np.median(slip)) if slip.size else float("nan"),
            f"slip_mm_{h}_p95": float(np.percentile(slip, 95)) if slip.size else float("nan"),
            f"unfinished_rate_{h}": float(np.mean(r["outcomes"].phase != DONE)), f"rollout_s_{h}": r["rollout_s"]}


def evaluation_stage(cfg: Config, backend: str, results: dict, runtime_s: float) -> StageResult:
    """Flat summary metrics, the nested per hand x grasp x condition tables, the claims, the figures."""
    tables = summarise(cfg, results)
    claim_rows, claim_metrics = claims(cfg, results)
    n_trials = sum(len(r["grasp"]) for r in results.values())
    volar = [GRASP_NAMES[g] for g in cfg.grasps if g in VOLAR_GRASPS]
    pos_labels = [c.name for c in conditions(cfg) if c.kind == "pos"]
    tactile_gain = {h: {v: finite_mean(np.array([tables["vf_position_error_mm"][h][v][c + "_no_tactile"]
                                           - tables["vf_position_error_mm"][h][v][c] for c in pos_labels]))
                        for v in volar} for h in results}
    flat = {"backend": backend, "trials": n_trials, "runtime_s": runtime_s,
            "rollout_s": sum(r["rollout_s"] for r in results.values()),
            "physics_steps": n_trials * n_control_steps() * SUBSTEPS, **claim_metrics}
    for h, r in results.items():
        flat.update(hand_metrics(h, r))
    nested = {"success_rate": {h: flat[f"success_rate_{h}"] for h in results},
              "success_rate_by_condition": tables["success"], "vf_position_error_mm": tables["vf_position_error_mm"],
              "vf_orientation_error_deg": tables["vf_orientation_error_deg"], "no_contact_rate": tables["no_contact"],
              "tactile_gain_mm": tactile_gain}
    figures = {"fig4.png": plots.plot_fig4(cfg, results), "success.png": plots.plot_success(cfg, tables),
               **plots.render_frames(cfg, results)}
    return StageResult({**flat, **nested}, figures, report(cfg, results, tables, claim_rows, flat))


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, name="grasp_mapping", argv=argv)
    sim.setup_rendering()
    enable_compilation_cache()
    try:
        backend = resolve_backend(cfg.backend)
    except ValueError as err:
        raise SystemExit(f"python -m experiments.grasp_mapping: error: {err}") from err
    results, runtime_s = rollout_stage(cfg, backend)
    result = evaluation_stage(cfg, backend, results, runtime_s)
    run.write(result.metrics, result.report, result.figures)
    print(f"{result.metrics['trials']} trials on {backend} in {runtime_s:.1f} s; wrote {run.path}")
    return result.metrics  # nested: the tables by hand, grasp and condition
