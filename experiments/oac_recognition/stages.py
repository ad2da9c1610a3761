"""The stages of the OAC study and its `main`: the simulated data set, the jackknife over persons
(every model per fold), the figures; written through `RunOutput.write`."""
from __future__ import annotations

import time

import sim
from experiments.config import StageResult, parse_config, progress
from experiments.data import oac
from experiments.data.oac_protocol import evaluate, with_units
from experiments.oac_recognition import plots
from experiments.oac_recognition.config import PRESETS, Config
from experiments.oac_recognition.report import report
from lfd_common import enable_compilation_cache


def data_stage(cfg: Config) -> tuple[oac.OACData, dict]:
    """The simulated recordings (from the cache when present) and their size."""
    start = time.perf_counter()
    data = oac.generate(cfg.data_settings(), progress=progress)
    return data, {"data_s": time.perf_counter() - start, "n_recordings": int(len(data.action)),
                  "n_runs": cfg.n_runs, "mean_frames": float(data.lengths.mean())}


def evaluation_stage(cfg: Config, data: oac.OACData) -> tuple[dict, StageResult]:
    """Every jackknife run: the papers' tables (nested {median, max} error % over the runs), and as a
    stage result with their unit, and the figures."""
    t, _ = evaluate(cfg.protocol(), data)
    return t, StageResult(with_units(t), {"trajectories.png": plots.plot_trajectories(data),
                                          "views.png": plots.plot_views(cfg), "errors.png": plots.plot_errors(t)})


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, name="oac_recognition", argv=argv)
    sim.setup_rendering()
    enable_compilation_cache()
    start = time.perf_counter()
    data, data_metrics = data_stage(cfg)
    tables, result = evaluation_stage(cfg, data)
    runtime = time.perf_counter() - start
    written = run.write({**result.metrics, "runtime_s": runtime, **data_metrics},
                        report(cfg, data, tables, runtime, data_metrics["data_s"]), result.figures)
    print(f"wrote {run.path}/ in {runtime:.0f} s")
    return written
