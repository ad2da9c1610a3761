"""The stages of the PHMM table-top study and its `main`: data, training, synthesis, recognition under
noise, the log-likelihood surface, the robot. Each stage returns a `StageResult` (nested metrics and
figures); `main` times them and writes everything through `RunOutput.write`."""
from __future__ import annotations

import json
import time
from typing import NamedTuple

import numpy as np

import phmm_jax as P
import sim
from experiments.config import StageResult, flatten_metrics, parse_config, progress
from experiments.data import tabletop as tt
from experiments.phmm_tabletop import measures as ms
from experiments.phmm_tabletop import plots
from experiments.phmm_tabletop.config import PRESETS, Config
from experiments.phmm_tabletop.report import report
from lfd_common import enable_compilation_cache

GRIDS = ("2x2", "3x3")


class Data(NamedTuple):
    """The simulated study, resampled, and the test raster's bookkeeping."""

    train: tt.Recordings
    test: tt.Recordings
    X_train: np.ndarray     # (B, S, D)
    X_test: np.ndarray
    test_targets: np.ndarray  # (K, 3)
    corner_targets: np.ndarray
    pos_index: np.ndarray   # (B_test,) test position of each test movement
    inner: np.ndarray       # (K,) off the raster's border

    @property
    def n_positions(self) -> int:
        return len(self.test_targets)


def data_stage(cfg: Config) -> Data:
    train, test = tt.protocol_data(cfg.seed, (3, 3), cfg.train_repetitions, (cfg.test_rows, cfg.test_cols),
                                   cfg.test_repetitions, cfg.n_subjects, cfg.endpoint_sd_cm / 100,
                                   cfg.marker_noise_mm / 1000, cfg.drop_rate)
    n_pos = cfg.test_rows * cfg.test_cols
    return Data(train, test, tt.resample(train, cfg.n_samples), tt.resample(test, cfg.n_samples),
                tt.raster_targets(cfg.test_rows, cfg.test_cols).reshape(-1, 3), tt.raster_targets(3, 3),
                np.tile(np.repeat(np.arange(n_pos), cfg.test_repetitions), len(tt.ACTIONS)),
                ms.inner_mask(cfg.test_rows, cfg.test_cols))


def synthesis_stage(cfg: Config, d: Data, models: dict) -> StageResult:
    """Eq. 25 against the HMM average of the test repetitions, per test position."""
    phi_test = P.target_to_phi(d.corner_targets, d.test_targets)  # (K, 2)
    averages = ms.average_movements(cfg, d.X_test, d.test, d.n_positions)  # (A, K, S, D)
    err = {}
    for grid in GRIDS:
        synth = np.stack([np.asarray(P.synthesize(models[grid][a], phi_test, cfg.n_samples))
                          for a in range(len(tt.ACTIONS))])
        e = ms.synthesis_error(synth.reshape(-1, *synth.shape[2:]), averages.reshape(-1, *averages.shape[2:]))
        err[grid] = e.reshape(len(tt.ACTIONS), d.n_positions) * 100
    reaching, pointing = tt.ACTIONS.index("reaching"), tt.ACTIONS.index("pointing")
    metrics = {"synthesis_error_cm": {
        "inner": float(err["3x3"][:, d.inner].mean()), "all": float(err["3x3"].mean()),
        "inner_2x2": float(err["2x2"][:, d.inner].mean()), "all_2x2": float(err["2x2"].mean()),
        "inner_reaching": float(err["3x3"][reaching, d.inner].mean()),
        "inner_pointing": float(err["3x3"][pointing, d.inner].mean())}}
    fig = plots.plot_maps({f"{g} PHMM, {a}": err[g][k] for g in GRIDS for k, a in enumerate(tt.ACTIONS)},
                          (cfg.test_rows, cfg.test_cols), "Synthesis error (eq. 25) per test position")
    return StageResult(metrics, {"synthesis_error_maps.png": fig})


def recognition_stage(cfg: Config, d: Data, models: dict) -> StageResult:
    """Action and table position of every test movement, for each noise sigma (0: the noise-free
    protocol); classical HMMs and the diagnostic-feature baseline beside the PHMMs."""
    rng = np.random.default_rng(cfg.seed + 1)
    test = d.test
    rate, err, labels, hmm_rate, hmm_correct = {g: {} for g in GRIDS}, {g: {} for g in GRIDS}, {}, {}, {}
    aware_rate, aware_err, sigma_estimate, regression_err = {}, {}, {}, {}
    for sigma in progress(cfg.noise_cm, desc="noise levels"):
        X = d.X_test + (sigma / 100) * rng.standard_normal(d.X_test.shape) if sigma > 0 else d.X_test
        for grid in GRIDS:
            r = P.recognize(models[grid], X, n_steps=cfg.recognition_steps)
            label, phi = np.asarray(r.label), np.asarray(r.phi)
            phi_true = phi[np.arange(len(X)), test.action]  # the PHMM of the true action
            err[grid][sigma] = np.linalg.norm(ms.phi_to_position(d.corner_targets, phi_true) - test.target,
                                              axis=-1) * 100
            rate[grid][sigma] = np.mean(label == test.action)
            labels[grid, sigma] = label
        regression = ms.regression_baseline(d.X_train, d.train.target, d.train.action, X, test.action)
        regression_err[sigma] = np.linalg.norm(regression - test.target, axis=-1) * 100
        # The 3x3 PHMMs with the noise term Σ + σ̂² I, σ̂² read off the test movements (phmm_jax.noise).
        variance = P.estimate_noise_variance(X)
        sigma_estimate[sigma] = 100 * np.sqrt(variance)
        r = P.recognize([P.with_observation_noise(m, variance) for m in models["3x3"]], X, n_steps=cfg.recognition_steps)
        phi_true = np.asarray(r.phi)[np.arange(len(X)), test.action]
        aware_err[sigma] = np.linalg.norm(ms.phi_to_position(d.corner_targets, phi_true) - test.target, axis=-1) * 100
        aware_rate[sigma] = np.mean(np.asarray(r.label) == test.action)
        ll = np.stack([np.asarray(P.log_likelihood(h, X)) for h in models["hmm"]], axis=1)
        hmm_correct[sigma] = np.argmax(ll, 1) == test.action
        hmm_rate[sigma] = float(np.mean(hmm_correct[sigma]))

    inner_seq = d.inner[d.pos_index]
    err0 = {g: err[g][0.0] for g in GRIDS}
    hand_regression = ms.regression_baseline(d.X_train, d.train.target, d.train.action, d.X_test, test.action,
                                             ("index_knuckle", "index_tip", "thumb_tip"))
    hand_err = np.linalg.norm(hand_regression - test.target, axis=-1) * 100
    correct = {"phmm_2x2": labels["2x2", 0.0] == test.action, "phmm_3x3": labels["3x3", 0.0] == test.action,
               "hmm": hmm_correct[0.0]}
    noise = lambda values: {f"{s:g}cm": float(values[s]) for s in cfg.noise_cm}  # noqa: E731
    metrics = {
        "param_error_cm": {"inner": float(err0["3x3"][inner_seq].mean()), "all": float(err0["3x3"].mean()),
                           "inner_2x2": float(err0["2x2"][inner_seq].mean()), "all_2x2": float(err0["2x2"].mean()),
                           "noise": noise({s: e.mean() for s, e in err["3x3"].items()}),
                           "noise_2x2": noise({s: e.mean() for s, e in err["2x2"].items()}),
                           "noise_aware": noise({s: e.mean() for s, e in aware_err.items()}),
                           "noise_regression": noise({s: e.mean() for s, e in regression_err.items()}),
                           **{f"{name}_{part}": float(e[mask].mean()) for name, e in
                              (("regression", regression_err[0.0]), ("regression_hand", hand_err))
                              for part, mask in (("inner", inner_seq), ("all", slice(None)))}},
        "noise_sigma_estimate_cm": noise(sigma_estimate),
        "classification_rate": {
            "phmm_2x2": float(rate["2x2"][0.0]), "phmm_3x3": float(rate["3x3"][0.0]), "hmm": hmm_rate[0.0],
            **{f"{name}_{a}": float(np.mean(c[test.action == k])) for name, c in correct.items()
               for k, a in enumerate(tt.ACTIONS)},
            "diagnostic_baseline": ms.diagnostic_baseline(d.train, test),
            "noise": noise(rate["3x3"]), "noise_2x2": noise(rate["2x2"]), "noise_hmm": noise(hmm_rate),
            "noise_aware": noise(aware_rate)},
    }
    n_pos, shape = d.n_positions, (cfg.test_rows, cfg.test_cols)
    per_position = lambda e: np.bincount(d.pos_index, e, n_pos) / np.bincount(d.pos_index, minlength=n_pos)  # noqa: E731
    per_pos = {**{f"{g} PHMM (both actions)": per_position(err0[g]) for g in GRIDS},
               "regression from the final finger": per_position(regression_err[0.0])}
    wrong = {f"{g} PHMM, {a}": 100 * np.bincount(d.pos_index[test.action == k],
                                                 labels[g, 0.0][test.action == k] != k, n_pos)
             / cfg.test_repetitions for g in GRIDS for k, a in enumerate(tt.ACTIONS)}
    figures = {
        "param_error_maps.png": plots.plot_maps(per_pos, shape,
                                                "Parameter (table position) error per test position"),
        "classification_error_maps.png": plots.plot_maps(
            wrong, shape, "Misclassified test movements per position (noise-free)", unit="%"),
        "noise_robustness.png": plots.plot_noise(
            cfg.noise_cm, {**{g: {s: e.mean() for s, e in err[g].items()} for g in GRIDS},
                           "3x3, Σ + σ̂² I": {s: e.mean() for s, e in aware_err.items()},
                           "regression (final finger)": {s: e.mean() for s, e in regression_err.items()}},
            {**rate, "3x3, Σ + σ̂² I": aware_rate}, hmm_rate),
    }
    return StageResult(metrics, figures)


def surface_stage(cfg: Config, d: Data, models: dict) -> StageResult:
    """Log-likelihood surface of one pointing movement at an inner position (3x3 PHMM)."""
    pointing = tt.ACTIONS.index("pointing")
    probe = int(np.flatnonzero((d.test.action == pointing) & d.inner[d.pos_index])[0])
    axis, surface = ms.loglik_surface(models["3x3"][pointing], d.X_test[probe])
    maxima = ms.local_maxima(surface)
    n_max = len(maxima)
    metrics = {"loglik_surface": {
        "local_maxima": n_max,
        "second_maximum_gap": float(maxima[0] - maxima[1]) if n_max > 1 else float("inf"),
        "range": float(surface.max() - surface.min())}}
    true_phi = P.target_to_phi(d.corner_targets, d.test.target[probe])
    return StageResult(metrics, {"loglik_surface.png": plots.plot_loglik_surface(axis, surface, true_phi, n_max)})


def robot_stage(cfg: Config, d: Data, models: dict) -> StageResult:
    """Synthesised reaching (3x3 PHMM) to every test target, retargeted and played back in MuJoCo."""
    setup = ms.RobotSetup(d.train, d.test_targets)
    phi_test = P.target_to_phi(d.corner_targets, d.test_targets)
    synth = np.asarray(P.synthesize(models["3x3"][tt.ACTIONS.index("reaching")], phi_test, cfg.n_samples))
    angles, qpos, playbacks = setup.play(synth)
    metrics, reach_err = ms.robot_metrics(setup, angles, playbacks)
    k = len(playbacks) // 2
    frame = ms.render_reach(setup, qpos[k, np.argmin(np.linalg.norm(playbacks[k].grasp - setup.targets[k], axis=-1))])
    return StageResult(metrics, {"robot_trajectories.png": plots.plot_robot(setup, playbacks, reach_err),
                                 "robot_frame.png": frame})


STAGES = {"synthesis": synthesis_stage, "recognition": recognition_stage, "loglik_surface": surface_stage,
          "robot": robot_stage}
SUMMARY = ("synthesis_error_cm_inner", "param_error_cm_inner", "classification_rate_phmm_2x2",
           "classification_rate_phmm_3x3", "classification_rate_hmm", "classification_rate_diagnostic_baseline",
           "robot_reach_error_cm_mean", "runtime_s")


class Laps:
    """Wall time of each step as `time_<name>_s`, printed as it ends."""

    def __init__(self):
        self.start = time.perf_counter()
        self.metrics: dict[str, float] = {}

    def __call__(self, name: str, fn, *args):
        t0 = time.perf_counter()
        out = fn(*args)
        self.metrics[f"time_{name}_s"] = time.perf_counter() - t0
        print(f"{name}: {self.metrics[f'time_{name}_s']:.1f} s", flush=True)
        return out


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, name="phmm_tabletop", argv=argv)
    sim.setup_rendering()
    enable_compilation_cache()
    lap = Laps()
    d = lap("data", data_stage, cfg)
    models = lap("training", ms.train_models, cfg, d.X_train, d.train, cfg.train_repetitions)
    results = [lap(name, stage, cfg, d, models) for name, stage in STAGES.items()]
    metrics = flatten_metrics({"n_test_sequences": len(d.X_test), "n_train_sequences": len(d.X_train),
                               **{k: v for r in results for k, v in r.metrics.items()},
                               "runtime_s": time.perf_counter() - lap.start, **lap.metrics})
    written = run.write(metrics, report(cfg, metrics), {k: v for r in results for k, v in r.figures.items()})
    print(json.dumps({k: written[k] for k in SUMMARY}, indent=1))
    return written
