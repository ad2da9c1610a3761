"""PHMM recognition with three parameters: peak memory, compile time and time per sequence of `recognize`.

    python -m experiments.bench.bench_phmm_recognize --preset paper --out runs/bench_phmm_recognize

Workload (paper preset): a PHMM of a 3 x 3 x 3 grid (d = 3: target depth, width and height; 20 states,
durations 4-6, D = 21, fitted by our EM on simulated reaching movements of one subject, 4 per grid
corner) and B = 540 reaching movements of T = 100 frames (another subject) to random targets of the
box. `recognize` searches φ from the 13^3 = 2,197-point start lattice (its default for a 3-point
grid), found coarse to fine (its default: the 7^3 points of every second index, then around each
sequence's 4 best of them the 3^3 lattice points within one step), then 6 + 3 quasi-Newton steps.
The quick preset: a 2 x 2 x 2 grid (5^3 lattice, scored whole), B = 20, chunks of 8.

Side by side, each in its own process (so that its peak resident memory is its own):
* chunked: `recognize(..., chunk_size=128)` (the default; 8 in the quick preset): the batch is
  searched 128 (at most) sequences at a time (540 as 5 chunks of 108);
* one chunk: `recognize(..., chunk_size=B)`: the whole batch at once (the lattice is still scored in
  blocks).
The chunked process also runs the whole-lattice start (`coarse_stride=1`, the search before the
coarse-to-fine start), compiled and timed in turn with the default (`time_interleaved`), and
counts the sequences whose log-likelihood the default leaves more than 1 nat below it (worse
optima); its peak RSS then covers both programs.
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
from experiments.timing import time_interleaved
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
    coarse_stride: int = 2  # recognize's default coarse-to-fine start (1: the whole lattice)
    coarse_top: int = 4  # recognize's default
    chunk_size: int = 128  # the chunked side (recognize's default)
    repeats: int = 3
    worker_chunk: int = 0  # internal: > 0 runs recognize with this chunk size (a subprocess)

    def __post_init__(self):
        if len(self.grid) != 3 or min(self.grid) < 2:
            raise ValueError(f"grid: expected three sizes >= 2, got {self.grid}")
        if min(self.batch, self.per_corner, self.lattice_points, self.chunk_size, self.repeats, self.coarse_stride,
               self.coarse_top) < 1:
            raise ValueError("batch, per_corner, lattice_points, chunk_size, repeats, coarse_stride and coarse_top "
                             "must be >= 1")


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
    `folder` (the chunked side: in turn with the whole-lattice start), report the peak RSS."""
    import jax
    import jax.numpy as jnp

    import phmm_jax as P
    from lfd_common import float_dtype

    phmm = P.load(folder / "phmm.npz")
    X = np.load(folder / "X.npy")
    lengths = jnp.full(len(X), X.shape[1], jnp.int32)
    starts = {"default": (cfg.coarse_stride, cfg.coarse_top)}
    if cfg.worker_chunk < cfg.batch and cfg.coarse_stride > 1:
        starts["whole lattice"] = (1, 1)
    # The programs `recognize` runs (same static arguments), compiled here so that they are timed
    # alone; `recognize` then finds them compiled.
    compiled = {}
    for name, (stride, top) in starts.items():
        start = time.perf_counter()
        program = P.search_parameters.lower(phmm, jnp.asarray(X, float_dtype()), lengths, 0.1, 6, cfg.lattice_points,
                                            3, cfg.worker_chunk, stride, top).compile()
        compiled[name] = (time.perf_counter() - start, program.memory_analysis().temp_size_in_bytes / 1e6)
    calls = {name: (lambda s, k: lambda: P.recognize(phmm, X, lattice_points=cfg.lattice_points,
                                                     chunk_size=cfg.worker_chunk, coarse_stride=s, coarse_top=k))(*st)
             for name, st in starts.items()}
    timings = time_interleaved(calls, cfg.repeats)
    out = {"chunk_size": cfg.worker_chunk, "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
           "device": str(jax.devices()[0]), "load_average": [round(x, 2) for x in os.getloadavg()]}
    for name, t in timings.items():
        result = t.result
        np.savez(folder / f"result_{cfg.worker_chunk}_{name.replace(' ', '_')}.npz", label=np.asarray(result.label),
                 phi=np.asarray(result.phi), loglik=np.asarray(result.loglik))
        out[name] = {"compile_s": compiled[name][0], "temp_mb": compiled[name][1],
                     "ms_per_seq": 1e3 * t.median_s / len(X), "times_s": list(t.times_s)}
    return out


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
        for name in ("default", "whole lattice"):
            if name in out:
                print(f"chunk_size {out['chunk_size']:4d}, {name} start: compile {out[name]['compile_s']:.1f} s, "
                      f"XLA temp {out[name]['temp_mb']:.0f} MB, {out[name]['ms_per_seq']:.1f} ms/seq", flush=True)
        print(f"peak RSS {out['peak_rss_mb']:.0f} MB, load average {out['load_average']}", flush=True)
        return out
    enable_compilation_cache()  # the fit only; the workers compile without it
    write_workload(cfg, run.path)
    sides = {"chunked": spawn(cfg, run, min(cfg.chunk_size, cfg.batch)), "one chunk": spawn(cfg, run, cfg.batch)}
    runs = {(side, name): np.load(run.file(f"result_{out['chunk_size']}_{name.replace(' ', '_')}.npz"))
            for side, out in sides.items() for name in ("default", "whole lattice") if name in out}
    a, b = runs["chunked", "default"], runs["one chunk", "default"]
    agree = {"labels_equal": bool(np.array_equal(a["label"], b["label"])),
             "max_abs_dphi": float(np.max(np.abs(a["phi"] - b["phi"]))),
             "max_rel_dloglik": float(np.max(np.abs(a["loglik"] - b["loglik"]) / np.abs(b["loglik"])))}
    if ("chunked", "whole lattice") in runs:
        whole = runs["chunked", "whole lattice"]
        agree["labels_equal_whole_lattice"] = bool(np.array_equal(a["label"], whole["label"]))
        agree["worse_optima_vs_whole_lattice"] = int(np.sum(a["loglik"] < whole["loglik"] - 1.0))
    truth = np.load(run.file("phi.npy"))
    rows = [[side, name, sides[side]["chunk_size"], f"{sides[side]['peak_rss_mb']:.0f}",
             f"{sides[side][name]['temp_mb']:.0f}", f"{sides[side][name]['compile_s']:.1f}",
             f"{sides[side][name]['ms_per_seq']:.1f}", f"{np.median(np.abs(result['phi'][:, 0] - truth)):.3f}"]
            for (side, name), result in runs.items()]
    grid = "x".join(map(str, cfg.grid))
    whole_line = ("" if "worse_optima_vs_whole_lattice" not in agree else
                  f" Default against the whole-lattice start (chunked): labels equal "
                  f"{agree['labels_equal_whole_lattice']}, {agree['worse_optima_vs_whole_lattice']} of {cfg.batch} "
                  "sequences more than 1 nat worse.")
    report = "\n".join([
        f"# PHMM recognition, d = 3: {grid} grid, B = {cfg.batch} sequences of {cfg.n_frames} x 21 "
        f"({sides['chunked']['device']})", "",
        f"`recognize` with a {cfg.lattice_points}^3 = {cfg.lattice_points ** 3}-point start lattice, found coarse to "
        f"fine (default: stride {cfg.coarse_stride}, {cfg.coarse_top} best refined) or whole, 6 + 3 steps; each side "
        f"in its own process; time per sequence: median of {cfg.repeats} call(s) of the whole batch (the two starts "
        "in turn); compile: `search_parameters.lower(...).compile()` without a persistent cache; XLA temp: the "
        "compiled program's temporary buffers; peak RSS: the process's maxrss; load average (1, 5, 15 min) at the "
        f"end: {sides['chunked']['load_average']} (chunked), {sides['one chunk']['load_average']} (one chunk).", "",
        markdown_table(["side", "start", "chunk_size", "peak RSS (MB)", "XLA temp (MB)", "compile (s)",
                        "ms / sequence", "median |φ − φ_true|"], rows), "",
        f"Chunked against one chunk (default start): labels equal {agree['labels_equal']}, max |Δφ| "
        f"{agree['max_abs_dphi']:.2e}, max relative |Δ log-likelihood| {agree['max_rel_dloglik']:.2e}." + whole_line,
    ])
    print(report)
    run.write({"sides": sides, "agreement": agree, "grid": list(cfg.grid), "batch": cfg.batch}, report,
              filename="bench.json", flat=False)
    print(f"wrote {run.file('bench.json')}")
    return {"sides": sides, "agreement": agree}


if __name__ == "__main__":
    main()
