"""PHMM recognition with three parameters: peak memory, compile time and time per sequence of `recognize`.

    python -m experiments.bench.bench_phmm_recognize --preset paper --out runs/bench_phmm_recognize

Workload (paper preset): a PHMM of a 3 x 3 x 3 grid (d = 3: target depth, width and height; 20 states,
durations 4-6, D = 21, fitted by our EM on simulated reaching movements of one subject, 4 per grid
corner) and B = 540 reaching movements of T = 100 frames (another subject) to random targets of the
box. `recognize` searches φ from the 13^3 = 2,197-point start lattice (its default for a 3-point
grid), then 6 + 3 quasi-Newton steps. The quick preset: a 2 x 2 x 2 grid (5^3 lattice), B = 20,
chunks of 8.

Side by side, each in its own process (so that its peak resident memory is its own):
* chunked: `recognize(..., chunk_size=128)` (the default; 8 in the quick preset): the batch is
  searched 128 (at most) sequences at a time (540 as 5 chunks of 108);
* one chunk: `recognize(..., chunk_size=B)`: the whole batch at once (the lattice is still scored in
  blocks).
Each process compiles the search ahead of time (`search_parameters.lower(...).compile()`, timed:
the compile time, and XLA's `memory_analysis` of the program: its temporary buffers), then times
`repeats` calls of `recognize` (the compiled program is reused; median, `jax.block_until_ready`) and
reports its peak resident set size (`getrusage` maxrss: JAX's runtime, the data and XLA's buffers).
No persistent compilation cache in these processes, so the compile time is a real compile. Both
sides must return the same labels, φ and log-likelihoods (to float round-off).
"""
from __future__ import annotations

import dataclasses
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

from experiments.config import markdown_table, parse_config
from experiments.data.reaching import movements_at
from experiments.data.tabletop import RASTER_ORIGIN, RASTER_SIZE_M
from experiments.timing import time_call
from lfd_common import enable_compilation_cache

TARGET_HEIGHT_M = 0.30  # the third parameter: how high above the table the target is


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """`recognize` on a d = 3 PHMM: chunked batch against one chunk, memory, compile and time."""

    seed: int = 0
    grid: tuple[int, ...] = (3, 3, 3)
    batch: int = 540
    n_frames: int = 100
    n_states: int = 20
    min_duration: int = 4
    max_duration: int = 6
    per_corner: int = 4  # training movements per grid corner
    em_iterations: int = 10
    lattice_points: int = 13  # recognize's default for a 3-point grid (5 for a 2-point grid)
    chunk_size: int = 128  # the chunked side (recognize's default)
    repeats: int = 1
    worker_chunk: int = 0  # internal: > 0 runs recognize with this chunk size (a subprocess)

    def __post_init__(self):
        if len(self.grid) != 3 or min(self.grid) < 2:
            raise ValueError(f"grid: expected three sizes >= 2, got {self.grid}")
        if min(self.batch, self.per_corner, self.lattice_points, self.chunk_size, self.repeats) < 1:
            raise ValueError("batch, per_corner, lattice_points, chunk_size and repeats must be >= 1")


PRESETS = {
    "quick": {"grid": (2, 2, 2), "batch": 20, "per_corner": 2, "em_iterations": 3, "lattice_points": 5,
              "chunk_size": 8, "repeats": 3},
    "paper": {},
}


def targets_at(phi: np.ndarray) -> np.ndarray:
    """(K, 3) table-top target points of parameters φ (K, 3) in [0, 1]^3: depth, width, height."""
    phi = np.asarray(phi, float)
    return RASTER_ORIGIN + np.stack([phi[:, 1] * RASTER_SIZE_M[0], phi[:, 0] * RASTER_SIZE_M[1],
                                     phi[:, 2] * TARGET_HEIGHT_M], axis=1)


def write_workload(cfg: BenchConfig, folder) -> None:
    """Fit the PHMM and simulate the test movements; write phmm.npz, X.npy and phi.npy to `folder`."""
    import phmm_jax as P

    rng = np.random.default_rng(cfg.seed)
    corners = P.grid_points(cfg.grid)
    groups = movements_at(rng, targets_at(corners), cfg.per_corner, "reaching", cfg.n_frames)
    config = P.HMMConfig(n_states=cfg.n_states, min_duration=cfg.min_duration, max_duration=cfg.max_duration)
    start = time.perf_counter()
    phmm = P.fit_phmm(list(groups), cfg.grid, config, options=P.FitOptions(max_iter=cfg.em_iterations))
    print(f"PHMM of a {'x'.join(map(str, cfg.grid))} grid fitted in {time.perf_counter() - start:.1f} s", flush=True)
    phi = rng.uniform(0.0, 1.0, (cfg.batch, 3))
    X = movements_at(rng, targets_at(phi), 1, "reaching", cfg.n_frames)[:, 0]
    folder.mkdir(parents=True, exist_ok=True)
    P.save(folder / "phmm.npz", phmm)
    np.save(folder / "X.npy", X)
    np.save(folder / "phi.npy", phi)


def worker(cfg: BenchConfig, folder) -> dict:
    """In the subprocess: compile the search ahead of time, time `recognize` on the workload in
    `folder`, report the peak RSS."""
    import jax
    import jax.numpy as jnp

    import phmm_jax as P
    from lfd_common import float_dtype

    phmm = P.load(folder / "phmm.npz")
    X = np.load(folder / "X.npy")
    lengths = jnp.full(len(X), X.shape[1], jnp.int32)
    # The program `recognize` runs (same static arguments), compiled here so that it is timed alone;
    # `recognize` then finds it compiled.
    start = time.perf_counter()
    compiled = P.search_parameters.lower(phmm, jnp.asarray(X, float_dtype()), lengths, 0.1, 6, cfg.lattice_points, 3,
                                         cfg.worker_chunk).compile()
    compile_s = time.perf_counter() - start
    memory = compiled.memory_analysis()
    t = time_call(lambda: P.recognize(phmm, X, lattice_points=cfg.lattice_points, chunk_size=cfg.worker_chunk),
                  cfg.repeats, warmup=None)
    result = t.result
    np.savez(folder / f"result_{cfg.worker_chunk}.npz", label=np.asarray(result.label), phi=np.asarray(result.phi),
             loglik=np.asarray(result.loglik))
    return {"chunk_size": cfg.worker_chunk, "compile_s": compile_s, "temp_mb": memory.temp_size_in_bytes / 1e6,
            "ms_per_seq": 1e3 * t.median_s / len(X), "times_s": list(t.times_s),
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, "device": str(jax.devices()[0])}


def spawn(cfg: BenchConfig, run, chunk: int) -> dict:
    """Run `worker` with `chunk` sequences per chunk in a fresh process (writing to the subfolder
    chunk_<chunk>); its results as a dict."""
    sub = run.file(f"chunk_{chunk}")
    args = [sys.executable, "-m", "experiments.bench.bench_phmm_recognize", "--out", str(sub),
            "--worker-chunk", str(chunk)]
    for field in dataclasses.fields(cfg):
        if field.name != "worker_chunk":
            value = getattr(cfg, field.name)
            args += [f"--{field.name.replace('_', '-')}", ",".join(map(str, value)) if isinstance(value, tuple) else str(value)]
    subprocess.run(args, env=dict(os.environ), check=True)
    return json.loads((sub / "worker.json").read_text())


def main(argv=None) -> dict:
    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_phmm_recognize", argv=argv)
    if cfg.worker_chunk:
        out = worker(cfg, run.path.parent)
        run.write_json("worker.json", out)
        print(f"chunk_size {out['chunk_size']:4d}: compile {out['compile_s']:.1f} s, XLA temp {out['temp_mb']:.0f} MB, "
              f"{out['ms_per_seq']:.1f} ms/seq, peak RSS {out['peak_rss_mb']:.0f} MB", flush=True)
        return out
    enable_compilation_cache()  # the fit only; the workers compile without it
    write_workload(cfg, run.path)
    sides = {"chunked": spawn(cfg, run, min(cfg.chunk_size, cfg.batch)), "one chunk": spawn(cfg, run, cfg.batch)}
    results = {name: np.load(run.file(f"result_{side['chunk_size']}.npz")) for name, side in sides.items()}
    a, b = results["chunked"], results["one chunk"]
    agree = {"labels_equal": bool(np.array_equal(a["label"], b["label"])),
             "max_abs_dphi": float(np.max(np.abs(a["phi"] - b["phi"]))),
             "max_rel_dloglik": float(np.max(np.abs(a["loglik"] - b["loglik"]) / np.abs(b["loglik"])))}
    truth = np.load(run.file("phi.npy"))
    rows = [[name, side["chunk_size"], f"{side['peak_rss_mb']:.0f}", f"{side['temp_mb']:.0f}", f"{side['compile_s']:.1f}",
             f"{side['ms_per_seq']:.1f}", f"{np.median(np.abs(results[name]['phi'][:, 0] - truth)):.3f}"]
            for name, side in sides.items()]
    grid = "x".join(map(str, cfg.grid))
    report = "\n".join([
        f"# PHMM recognition, d = 3: {grid} grid, B = {cfg.batch} sequences of {cfg.n_frames} x 21 "
        f"({sides['chunked']['device']})", "",
        f"`recognize` with a {cfg.lattice_points}^3 = {cfg.lattice_points ** 3}-point start lattice, 6 + 3 steps; "
        f"each side in its own process; time per sequence: median of {cfg.repeats} call(s) of the whole batch; "
        "compile: `search_parameters.lower(...).compile()` without a persistent cache; XLA temp: the compiled "
        "program's temporary buffers; peak RSS: the process's maxrss.", "",
        markdown_table(["side", "chunk_size", "peak RSS (MB)", "XLA temp (MB)", "compile (s)", "ms / sequence",
                        "median |φ − φ_true|"], rows), "",
        f"Same results: labels equal {agree['labels_equal']}, max |Δφ| {agree['max_abs_dphi']:.2e}, max relative "
        f"|Δ log-likelihood| {agree['max_rel_dloglik']:.2e}.",
    ])
    print(report)
    run.write({"sides": sides, "agreement": agree, "grid": list(cfg.grid), "batch": cfg.batch}, report,
              filename="bench.json", flat=False)
    print(f"wrote {run.file('bench.json')}")
    return {"sides": sides, "agreement": agree}


if __name__ == "__main__":
    main()
