"""End-to-end demo on generated data. Each library issue adds its stage to `STAGES`.

    python -m experiments.demo --preset quick --out runs/demo

Stage "sim": report the JAX devices, build a table-top MuJoCo scene, drop objects in a batch of MJX
worlds (vmap over worlds, scan over steps), render one world offscreen and save it as `frame.png`,
plot object heights over time (`heights.png`).
Stage "grasp": grasp recognition from single images (quick preset of experiments.grasp_recognition) and
the robot grasp each recognised human grasp maps to.
Stage "mapping": one human grasp class mapped to the Barrett and Karlsruhe preshapes and executed in
MuJoCo (`grasp_demo.png`; experiments.grasp_mapping).
Stage "phmm": one simulated pointing movement recognised by PHMMs (action and target) and reproduced by
the robot arm (`phmm_demo.png`; experiments.phmm_tabletop).
Stage "oac": one simulated object-action complex classified by a CHCRF (`oac_demo.png`;
experiments.oac_recognition).
Stage "video": one rendered stereo clip segmented into skin, person, object and background, hand and
face tracked (`video_demo_sheet.png`; experiments.video_segmentation).
Stage "lfd": one short long recording (two OACs): the object in the hand from phase differences and
from pixels learnt on the clips, the pick-up / put-down events (the paper's rule and the hand-window
classifier trained on the clips) and the
CHCRF label and Z(x) of each period the classifier found (`lfd_demo_fig8.png`, `lfd_demo_object_masks.png`;
experiments.lfd_demonstration).
Stage "imitation": the first three rendered demonstrations of the seed (point or pick-and-place) through
the whole loop, video to robot, each with its side-by-side video `imitation_demo_<k>.mp4` (the person |
the robot; experiments.imitation).
"""
from __future__ import annotations

import dataclasses
import importlib
import time

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

import sim
from experiments.config import StageResult, markdown_table, parse_config
from experiments.plotting import plt
from lfd_common import enable_compilation_cache
from sim.scenes import random_drop_heights, table_height_m


@dataclasses.dataclass(frozen=True)
class DemoConfig:
    """End-to-end demo of lfd-jax on generated data."""

    seed: int = 0
    n_worlds: int = 64
    n_objects: int = 3
    sim_seconds: float = 1.0
    image_width: int = 320
    image_height: int = 240
    stages: tuple[str, ...] = ()  # empty: every stage of STAGES, in order

    def __post_init__(self):
        if self.n_worlds < 1 or self.n_objects < 1 or self.sim_seconds <= 0:
            raise ValueError("n_worlds, n_objects and sim_seconds must be positive")
        unknown = [s for s in self.stages if s not in STAGES]
        if unknown:
            raise ValueError(f"stages: unknown {unknown}; choose from {list(STAGES)}")


PRESETS = {
    "quick": {"n_worlds": 16, "sim_seconds": 0.6},
    "paper": {"n_worlds": 256, "sim_seconds": 2.0},
}


def sim_stage(cfg: DemoConfig) -> StageResult:
    """Drop objects on a table in `cfg.n_worlds` MJX worlds; render and plot one of them."""
    model = mujoco.MjModel.from_xml_string(sim.tabletop_drop_scene(cfg.n_objects))
    mjx_model = mjx.put_model(model)
    rng = np.random.default_rng(cfg.seed)
    qpos = np.tile(model.qpos0, (cfg.n_worlds, 1))
    z_index = 7 * np.arange(cfg.n_objects) + 2
    qpos[:, z_index] = table_height_m() + 0.04 + random_drop_heights(rng, cfg.n_worlds, cfg.n_objects)
    worlds = sim.worlds_from_qpos(mjx_model, jnp.asarray(qpos, dtype=jnp.float32))
    record_every = 5
    n_steps = record_every * max(1, round(cfg.sim_seconds / model.opt.timestep / record_every))

    start = time.perf_counter()
    compiled = sim.batched_rollout.lower(mjx_model, worlds, n_steps, record_every).compile()
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    final, trajectory = jax.block_until_ready(compiled(mjx_model, worlds))
    run_s = time.perf_counter() - start

    final_qpos = np.asarray(final.qpos)
    heights = np.asarray(trajectory)[:, :, z_index]  # (steps, W, objects)
    frame = sim.render_frame(model, final_qpos[0], cfg.image_width, cfg.image_height, camera="front")

    fig, ax = plt.subplots(figsize=(6, 3.5))
    t = np.arange(1, heights.shape[0] + 1) * record_every * model.opt.timestep
    for k in range(cfg.n_objects):
        ax.plot(t, heights[:, 0, k], label=f"object {k} (world 0)")
    ax.axhline(table_height_m(), color="k", lw=0.8, ls="--", label="table top")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("height (m)")
    ax.set_title(f"MJX drop test, {cfg.n_worlds} worlds in one vmap")
    ax.legend(fontsize=7)

    above_table = final_qpos[:, z_index] - table_height_m()
    metrics = {
        "sim_worlds": cfg.n_worlds,
        "sim_steps": n_steps,
        "sim_compile_s": compile_s,
        "sim_run_s": run_s,
        "sim_world_steps_per_s": cfg.n_worlds * n_steps / run_s,
        "sim_final_height_above_table_m_min": float(above_table.min()),
        "sim_final_height_above_table_m_max": float(above_table.max()),
        "sim_frame_png": "frame.png",
    }
    report = "\n".join([
        "## Stage sim: MJX batched drop test",
        "",
        f"{cfg.n_worlds} worlds x {n_steps} steps of {model.opt.timestep * 1e3:.0f} ms, "
        f"{cfg.n_objects} objects each, on `{jax.devices()[0].platform}`.",
        "",
        markdown_table(["quantity", "value"], [
            ("compile (s)", compile_s),
            ("run (s)", run_s),
            ("world-steps / s", metrics["sim_world_steps_per_s"]),
            ("final height above table, min (m)", metrics["sim_final_height_above_table_m_min"]),
            ("final height above table, max (m)", metrics["sim_final_height_above_table_m_max"]),
        ]),
        "",
        "![frame](frame.png) ![heights](heights.png)",
    ])
    return StageResult(metrics, {"frame.png": frame, "heights.png": fig}, report)


def _lazy_stage(module: str, name: str = "demo_stage"):
    """A stage that imports its experiment module only when it runs, so `--help` stays fast."""
    def stage(cfg: DemoConfig) -> StageResult:
        return getattr(importlib.import_module(module), name)(cfg)

    stage.__doc__ = f"Stage from `{module}.{name}`."
    return stage


# Each stage: cfg -> StageResult (metrics, figures, report section). Order: physics smoke test, then the papers'
# pipelines on generated data.
STAGES = {
    "sim": sim_stage,
    "grasp": _lazy_stage("experiments.grasp_recognition"),
    "mapping": _lazy_stage("experiments.grasp_mapping", "grasp_demo_stage"),
    "phmm": _lazy_stage("experiments.phmm_tabletop"),
    "oac": _lazy_stage("experiments.oac_recognition"),
    "video": _lazy_stage("experiments.video_segmentation.demo"),
    "lfd": _lazy_stage("experiments.lfd_demonstration.demo"),
    "imitation": _lazy_stage("experiments.imitation.demo"),
}


def main(argv=None) -> dict:
    cfg, run = parse_config(DemoConfig, PRESETS, name="demo", argv=argv)
    sim.setup_rendering()
    enable_compilation_cache()
    devices = jax.devices()
    print(f"jax {jax.__version__}, devices: {', '.join(str(d) for d in devices)}")
    results = []
    for name in cfg.stages or tuple(STAGES):
        print(f"stage {name} ...", flush=True)
        results.append(STAGES[name](cfg))
    header = f"# lfd-jax demo\n\nJAX {jax.__version__} on {', '.join(str(d) for d in devices)}."
    written = run.write_stages(results, header, jax_version=jax.__version__, jax_backend=devices[0].platform,
                               jax_device_count=len(devices))
    print(f"wrote {run.path}/: " + ", ".join(sorted(p.name for p in run.path.iterdir())))
    return written


if __name__ == "__main__":
    main()
