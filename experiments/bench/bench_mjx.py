"""Grasp-trial throughput on every physics backend present, beside a serial `mj_step` loop.

    python -m experiments.bench.bench_mjx --preset quick|paper --out DIR

The same batch of grasp trials (one hand; grasp classes, position/orientation errors and seeds cycled
as in the MAP sweep) runs on:

* ``serial``: one `mujoco.MjData` per trial, a Python loop of `mj_step` with the same controller
  (jitted, batch of one) every 10 steps; run on `serial_trials` trials and scaled per trial.
* ``native``: `sim.grasp_rollout` on `mujoco.batch.Batch` (all cores), controller on the bound arrays.
* ``mjx-jax``: the vmap/scan rollout, `mjx_trials` trials (its CPU compile takes minutes, so a small
  batch); compile time reported apart.
* ``mjx-warp``: the same on an NVIDIA GPU, where Warp is installed.

Reported per backend: trials/s, physics steps/s (trials x control steps x 10, the horizon; `native` and
`serial` stop stepping a trial once it is done, so their steps/s count the horizon they did not
need to simulate: the trials/s column is the fair one), compile time, and for `native` where the time
goes (the jitted controller alone on the same batch vs the rest). Then trials/s against batch size
(`sizes`) as `scaling.png`. Timings: one warm-up, median of `repeats`.

Writes DIR/bench.json with `trials_per_s` and `steps_per_s` (dicts by backend), `device`,
`ratio_native_vs_serial` and, on a GPU, `ratio_mjx_warp_vs_native`.
"""
from __future__ import annotations

import dataclasses
import os

import numpy as np

import sim
from experiments.timing import time_call
from experiments.config import markdown_table, parse_config
from lfd_common import enable_compilation_cache
from sim.grasping import SUBSTEPS, rollout_grasps, warp_status
from sim.grasping import n_control_steps


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """Grasp trials per second on every physics backend present."""

    seed: int = 0
    hand: str = "barrett"
    n_trials: int = 864
    serial_trials: int = 24
    mjx_trials: int = 6
    sizes: tuple[int, ...] = (16, 64, 256, 1024, 4096)
    repeats: int = 3
    nthread: int = 0

    def __post_init__(self):
        if min(self.n_trials, self.serial_trials, self.repeats) < 1 or self.mjx_trials < 0:
            raise ValueError("n_trials, serial_trials and repeats must be positive, mjx_trials >= 0")
        if not self.sizes or min(self.sizes) < 1:
            raise ValueError("sizes: expected positive batch sizes")


PRESETS = {"quick": {"n_trials": 96, "serial_trials": 6, "sizes": (16, 96), "repeats": 1},
           "paper": {"sizes": (16, 64, 256, 1024, 4096, 32768)}}


def bench_trials(hand: str, n: int, seed: int):
    """n trials of `hand`: grasp classes, the sweep's conditions and seeds cycled. (params, object_start)."""
    from sim.grasping import GRASP_CLASSES
    from sim.grasping import plan_trials

    k = np.arange(n)
    grasps = np.asarray(GRASP_CLASSES)[k % len(GRASP_CLASSES)]
    cond = (k // len(GRASP_CLASSES)) % 9           # 0 none, 1-6 position 5 cm, 7-8 rotation 15/30 deg
    ang = np.pi / 3 * (cond - 1)
    offsets = np.where((cond >= 1) & (cond <= 6), 1.0, 0.0)[:, None] * 0.05 * np.stack([np.cos(ang), np.sin(ang)], -1)
    tilts = np.where(cond == 7, 15.0, np.where(cond == 8, 30.0, 0.0))
    return plan_trials(hand, grasps, offsets, tilts, np.ones(n, bool), seed * 100_000 + k)


def serial_rollout(hand: str, params, object_start) -> None:
    """The baseline: each trial on its own MjData, `mj_step` in a Python loop, the controller (B = 1)
    every control step; a trial stops when its controller is done."""
    import jax
    import jax.numpy as jnp
    import mujoco

    from sim.grasping import SUBSTEPS, first_readings, initial_qpos, object_gravcomp
    from sim.grasping import DONE, TrialParams, controller_step, initial_state, n_control_steps
    from sim.hands import grasp_model

    model, layout = grasp_model(hand)
    control = jax.jit(lambda s, d, p: controller_step(s, d, p, layout))
    qpos = initial_qpos(model, hand, layout, params, object_start)
    grav = object_gravcomp(model, layout, params.obj)
    for i in range(len(qpos)):  # the serial baseline loops over trials by definition
        p = TrialParams(*[np.asarray(x)[i:i + 1] for x in params])
        model.body_gravcomp[:] = grav[i]
        data = mujoco.MjData(model)
        data.qpos[:] = qpos[i]
        state = initial_state(p, layout.n_links)
        sensors = first_readings(1, model)
        for _ in range(n_control_steps()):
            state, ctrl = control(state, jnp.asarray(sensors, jnp.float32), p)
            if int(state.phase[0]) == DONE:
                break
            data.ctrl[:] = np.asarray(ctrl)[0]
            for _ in range(SUBSTEPS):
                mujoco.mj_step(model, data)
            sensors = data.sensordata[None]


def controller_only(hand: str, params) -> float:
    """Seconds the jitted controller alone takes for one rollout's control steps on this batch."""
    import jax
    import jax.numpy as jnp

    from sim.grasping import jitted_controller, grasp_scene
    from sim.grasping import initial_state, n_control_steps

    model, layout = grasp_scene(hand)
    control = jitted_controller(hand)
    sensors = np.zeros((len(params.goal), model.nsensordata), np.float32)
    state0 = initial_state(params, layout.n_links)

    def steps():
        state = state0
        for _ in range(n_control_steps()):
            state, ctrl = control(state, jnp.asarray(sensors), params)
            np.asarray(ctrl)

    warmup = lambda: jax.block_until_ready(control(state0, jnp.asarray(sensors), params))  # noqa: E731
    return time_call(steps, 1, warmup=warmup, block=False).median_s


def backends_stage(cfg: BenchConfig, backends: list[str], steps_per_trial: int) -> dict[str, dict]:
    """Per backend (serial first): trials, run seconds (median), compile seconds, trials/s, steps/s."""
    sp, ss = bench_trials(cfg.hand, cfg.serial_trials, cfg.seed)
    t = time_call(lambda: serial_rollout(cfg.hand, sp, ss), cfg.repeats, block=False)  # warm-up: controller compile
    results = {"serial": {"trials": cfg.serial_trials, "run_s": t.median_s, "compile_s": 0.0}}
    print(f"  serial: {cfg.serial_trials} trials in {t.median_s:.2f} s", flush=True)
    params, start = bench_trials(cfg.hand, cfg.n_trials, cfg.seed)
    for backend in backends:
        n = cfg.n_trials if backend != "mjx-jax" else cfg.mjx_trials
        if n == 0:
            continue
        p, s = (params, start) if n == cfg.n_trials else bench_trials(cfg.hand, n, cfg.seed)
        t = time_call(lambda: rollout_grasps(cfg.hand, p, s, backend=backend, nthread=cfg.nthread), cfg.repeats,
                      block=False)
        results[backend] = {"trials": n, "run_s": t.median_s, "compile_s": t.compile_s}
        print(f"  {backend}: {n} trials in {t.median_s:.2f} s (compile and first call {t.compile_s:.1f} s)", flush=True)
    results["native"]["controller_s"] = controller_only(cfg.hand, params)
    for r in results.values():
        r["trials_per_s"] = r["trials"] / r["run_s"]
        r["steps_per_s"] = r["trials"] * steps_per_trial / r["run_s"]
    return results


def scaling_stage(cfg: BenchConfig, backends: list[str], results: dict) -> dict[str, dict]:
    """Trials/s against batch size per batched backend (MJX-JAX and serial: their one batch)."""
    scaling = {}
    for backend in [b for b in backends if b != "mjx-jax"]:
        scaling[backend] = {}
        for n in cfg.sizes:
            p, s = bench_trials(cfg.hand, n, cfg.seed)
            t = time_call(lambda: rollout_grasps(cfg.hand, p, s, backend=backend, nthread=cfg.nthread),
                          max(1, cfg.repeats if n <= 1024 else 1), block=False)
            scaling[backend][n] = n / t.median_s
            print(f"  {backend} B={n}: {n / t.median_s:,.0f} trials/s")
    if "mjx-jax" in results:
        scaling["mjx-jax"] = {results["mjx-jax"]["trials"]: results["mjx-jax"]["trials_per_s"]}
    scaling["serial"] = {cfg.serial_trials: results["serial"]["trials_per_s"]}
    return scaling


def plot_scaling(cfg: BenchConfig, scaling: dict, steps_per_trial: int, device: str):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for name, values in scaling.items():
        xs = sorted(values)
        ax.plot(xs, [values[x] for x in xs], "o-", label=name)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("batch size (trials)")
    ax.set_ylabel("trials / s")
    ax.set_title(f"grasp trials ({cfg.hand}, {steps_per_trial} steps each), {device}", fontsize=8)
    ax.legend()
    return fig


def summary(cfg: BenchConfig, results: dict, scaling: dict, steps_per_trial: int, device: str) -> dict:
    out = {
        "device": device,
        "hand": cfg.hand,
        "steps_per_trial": steps_per_trial,
        "trials_per_s": {k: r["trials_per_s"] for k, r in results.items()},
        "steps_per_s": {k: r["steps_per_s"] for k, r in results.items()},
        "compile_s": {k: r["compile_s"] for k, r in results.items()},
        "batch": {k: r["trials"] for k, r in results.items()},
        "native_controller_share": results["native"]["controller_s"] / results["native"]["run_s"],
        "ratio_native_vs_serial": results["native"]["trials_per_s"] / results["serial"]["trials_per_s"],
        "trials_per_s_vs_batch": {k: {str(n): v for n, v in d.items()} for k, d in scaling.items()},
    }
    if "mjx-warp" in results:
        out["ratio_mjx_warp_vs_native"] = results["mjx-warp"]["trials_per_s"] / results["native"]["trials_per_s"]
    return out


def report(results: dict, out: dict) -> tuple[str, str]:
    rows = [(k, r["trials"], r["trials_per_s"], r["steps_per_s"], r["compile_s"]) for k, r in results.items()]
    table = markdown_table(["backend", "batch", "trials/s", "steps/s", "compile (s)"], rows)
    return table, "\n".join([
        "# Grasp-trial throughput", "", f"Device: {out['device']}. Hand: {out['hand']}; {out['steps_per_trial']} "
        "physics steps per trial (horizon).", "", table, "",
        f"native vs serial: {out['ratio_native_vs_serial']:.2f}x. The jitted controller takes "
        f"{100 * out['native_controller_share']:.0f} % of the native run time; the rest is MuJoCo's batch step.",
        "", "![scaling](scaling.png)"])


def main(argv=None):
    enable_compilation_cache()
    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_mjx", argv=argv)
    sim.setup_rendering()
    import jax

    steps_per_trial = n_control_steps() * SUBSTEPS
    backends = ["native", "mjx-jax"] + ([] if warp_status() else ["mjx-warp"])
    gpu = [d for d in jax.devices() if d.platform == "gpu"]
    device = (f"{os.cpu_count()} CPU cores" + (f", {gpu[0].device_kind}" if gpu else "")
              + f", jax {jax.__version__}")
    print(f"device: {device}; backends: serial, {', '.join(backends)}; mjx-warp: {warp_status() or 'present'}")
    results = backends_stage(cfg, backends, steps_per_trial)
    scaling = scaling_stage(cfg, backends, results)
    out = summary(cfg, results, scaling, steps_per_trial, device)
    table, text = report(results, out)
    run.write(out, text, {"scaling.png": plot_scaling(cfg, scaling, steps_per_trial, device)}, filename="bench.json",
              flat=False)
    print(table)
    print(f"ratio native vs serial: {out['ratio_native_vs_serial']:.2f}")
    return out


if __name__ == "__main__":
    main()
