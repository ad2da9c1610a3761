"""Scaling out: throughput of every `mesh=` entry point against the number of devices.

    python -m experiments.bench.bench_scaling --preset quick --out runs/bench_scaling   # about 5 min here
    python -m experiments.bench.bench_scaling --preset paper --out runs/bench_scaling   # larger batches

Both presets build the sharded LSH index at `big_rows` = 10 M rows (`--big-lsh false` skips it).

Each device count S of `device_counts` runs in its own subprocess (JAX fixes its devices when it
starts): on a CPU machine with `XLA_FLAGS=--xla_force_host_platform_device_count=S` (S host devices
sharing the machine's cores), on an accelerator machine with the first S accelerators. Every entry
point is called with `mesh=lfd_common.batch_mesh(S)` on the same batch, timed from the user's arrays
to the result (`time_call`: warm-up apart, median of `repeats`), and reported as items per second
beside S = 1.

On a CPU machine the forced devices share its cores, so this measures the overhead of sharding
(padding, transfers, one compiled program per shard, collectives), not a speed-up: XLA:CPU already
spreads one device's work over the cores. A speed-up needs devices that bring their own compute
(several accelerators, or several hosts with `jax.distributed`).

The large LSH stage builds a sharded index of `big_rows` random rows of `big_dim` float32 (default
10,000,000 x 16: 0.64 GB of data; 84-dimensional HOG rows would be 3.4 GB before the tables and the
host copies) on the largest S and reports the build time, queries per second and the bytes each
device holds (data, tables and per-row mask). Writes bench.json and report.md.
"""
from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import time

import numpy as np

from experiments.timing import time_call
from experiments.config import markdown_table, parse_config
from lfd_common import enable_compilation_cache


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """Throughput of the sharded entry points on 1, 2, 4 devices, and a sharded LSH index at 10 M rows."""

    seed: int = 0
    device_counts: tuple[int, ...] = (1, 2, 4)
    hmm_batch: int = 280
    n_frames: int = 100
    hog_batch: int = 512
    lsh_rows: int = 100_000
    n_queries: int = 256
    crf_batch: int = 64
    videos: int = 8
    big_rows: int = 10_000_000
    big_dim: int = 16
    repeats: int = 5
    worker_devices: int = 0  # internal: > 0 runs the entry points on this many devices (a subprocess)
    big_lsh: bool = True

    def __post_init__(self):
        if min(self.device_counts) < 1 or self.repeats < 1 or self.big_rows < 1 or self.big_dim < 1:
            raise ValueError("device_counts, repeats, big_rows and big_dim must be positive")


PRESETS = {
    "quick": {"hmm_batch": 56, "hog_batch": 128, "lsh_rows": 20_000, "n_queries": 64, "crf_batch": 16, "videos": 4,
              "repeats": 3, "big_rows": 10_000_000},
    "paper": {},
}


def _entry_points(cfg: BenchConfig, mesh):
    """{name: (items per call, call)}: every `mesh=` entry point on its batch."""
    import jax

    import crf_jax
    import hog_jax as H
    import phmm_jax as P
    from experiments.bench.bench_hmm import make_data
    from hog_jax.video import run_background_batch
    from hog_jax.video import LevelSetOptions, LevelSetStructure, segment_video

    rng = np.random.default_rng(cfg.seed)
    X = make_data(_HMMData(cfg.seed, cfg.hmm_batch, cfg.n_frames)).astype(np.float32)
    hmm_cfg = P.HMMConfig(n_states=20, min_duration=4, max_duration=6)
    hmm = P.fit_hmm(X, None, hmm_cfg, options=P.FitOptions(max_iter=2))
    one_step = P.FitOptions(max_iter=1)
    images = rng.random((cfg.hog_batch, 64, 64)).astype(np.float32)
    data = rng.normal(size=(cfg.lsh_rows, 84)).astype(np.float32)
    queries = rng.normal(size=(cfg.n_queries, 84)).astype(np.float32)
    index = H.build_index(jax.random.key(cfg.seed), data, 12, 8, mesh=mesh)
    Xc = rng.normal(size=(cfg.crf_batch, 20, 8)).astype(np.float32)
    yc = (Xc[..., 0] > 0).astype(np.int32)
    videos = rng.integers(0, 256, (cfg.videos, 10, 60, 80, 3)).astype(np.uint8)
    scores = np.log(rng.dirichlet(np.ones(3), (cfg.videos, 4, 60, 80))).transpose(0, 1, 4, 2, 3).astype(np.float32)
    structure = LevelSetStructure(3, (60, 80), None)
    return {
        "log_likelihood (seq)": (len(X), lambda: P.log_likelihood(hmm, X, mesh=mesh)),
        "posteriors (seq)": (len(X), lambda: P.posteriors(hmm, X, mesh=mesh)),
        "viterbi (seq)": (len(X), lambda: P.viterbi(hmm, X, mesh=mesh)),
        "EM step (seq)": (len(X), lambda: P.fit_hmm(X, None, init=hmm, options=one_step, mesh=mesh)),
        "hog (image)": (len(images), lambda: H.hog(images, mesh=mesh)),
        "exact_search (query)": (len(queries), lambda: H.exact_search(data, queries, 10, mesh=mesh)),
        "LSH query (query)": (len(queries), lambda: H.query(index, queries, 10)),
        "fit_chain 20 it. (seq)": (len(Xc), lambda: crf_jax.fit_chain(
            Xc, yc, n_labels=2, options=crf_jax.FitOptions(max_iter=20), mesh=mesh).model),
        "run_background_batch (video)": (len(videos), lambda: run_background_batch(videos, mesh=mesh)),
        "segment_video (video)": (len(videos), lambda: segment_video(
            structure, scores, options=LevelSetOptions(it_max=20), mesh=mesh)),
    }


@dataclasses.dataclass(frozen=True)
class _HMMData:
    """The fields `bench_hmm.make_data` reads."""

    seed: int
    batch: int
    n_frames: int


def _device_bytes(arrays) -> dict[str, int]:
    """Bytes of `arrays`' shards held by each device."""
    held: dict[str, int] = {}
    for a in arrays:
        for s in a.addressable_shards:
            held[str(s.device)] = held.get(str(s.device), 0) + s.data.nbytes
    return held


def _big_lsh(cfg: BenchConfig, mesh) -> dict:
    import jax

    import hog_jax as H

    rng = np.random.default_rng(cfg.seed)
    data = rng.standard_normal((cfg.big_rows, cfg.big_dim), np.float32)
    queries = rng.standard_normal((cfg.n_queries, cfg.big_dim), np.float32)
    start = time.perf_counter()
    index = jax.block_until_ready(H.build_index(jax.random.key(cfg.seed), data, 20, 4, mesh=mesh))
    build_s = time.perf_counter() - start
    del data
    t = time_call(lambda: H.query(index, queries, 10, n_per_table=32), repeats=cfg.repeats)
    ix = index.index
    held = _device_bytes([ix.data, ix.keys, ix.order, index.mask])
    return {"rows": cfg.big_rows, "dim": cfg.big_dim, "devices": mesh.size, "build_s": build_s,
            "queries_per_s": cfg.n_queries / t.median_s, "compile_s": t.compile_s,
            "bytes_per_device_max": max(held.values()), "bytes_per_device": held}


def worker(cfg: BenchConfig) -> dict:
    """In the subprocess: every entry point on `cfg.worker_devices` devices (and the big LSH index)."""
    import jax

    from lfd_common import batch_mesh

    mesh = batch_mesh(cfg.worker_devices)
    out = {"devices": mesh.size, "device": str(jax.devices()[0]), "per_s": {}, "compile_s": {}}
    for name, (items, call) in _entry_points(cfg, mesh).items():
        t = time_call(call, repeats=cfg.repeats)
        out["per_s"][name], out["compile_s"][name] = items / t.median_s, t.compile_s
        print(f"S={mesh.size} {name:32s} {items / t.median_s:12.1f}/s   compile+first ~ {t.compile_s:6.2f} s",
              flush=True)
    if cfg.big_lsh and mesh.size == max(cfg.device_counts):
        out["big_lsh"] = _big_lsh(cfg, mesh)
        print(f"S={mesh.size} LSH {cfg.big_rows:,} x {cfg.big_dim}: {out['big_lsh']}", flush=True)
    return out


def _spawn(cfg: BenchConfig, run, devices: int) -> dict:
    """Run `worker` for `devices` devices in a fresh process; its results as a dict."""
    import jax

    sub = run.file(f"devices_{devices}")
    env = dict(os.environ)
    if jax.default_backend() == "cpu":
        env["XLA_FLAGS"] = f"{env.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count={devices}".strip()
    args = [sys.executable, "-m", "experiments.bench.bench_scaling", "--out", str(sub), "--worker-devices",
            str(devices)]
    for field in dataclasses.fields(cfg):
        if field.name != "worker_devices":
            value = getattr(cfg, field.name)
            text = ",".join(map(str, value)) if isinstance(value, tuple) else str(value)
            args += [f"--{field.name.replace('_', '-')}", text]
    subprocess.run(args, env=env, check=True)
    return json.loads((sub / "scaling.json").read_text())


def main(argv=None):
    enable_compilation_cache()
    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_scaling", argv=argv)
    if cfg.worker_devices:
        run.write_json("scaling.json", worker(cfg))
        return
    results = {str(s): _spawn(cfg, run, s) for s in cfg.device_counts}
    names = list(results[str(cfg.device_counts[0])]["per_s"])
    base = results[str(min(cfg.device_counts))]["per_s"]
    rows = [[name] + [f"{r['per_s'][name]:,.1f} ({r['per_s'][name] / base[name]:.2f}x)" for r in results.values()]
            for name in names]
    device = results[str(cfg.device_counts[0])]["device"]
    note = ("CPU host devices forced with --xla_force_host_platform_device_count share this machine's cores: "
            "the ratios measure the overhead of sharding, not a speed-up." if "cpu" in device.lower() else
            "one accelerator per device.")
    report = (f"# Scaling out: items/s against the number of devices ({device})\n\n{note}\n\n"
              + markdown_table(["entry point (unit)"] + [f"S = {s}" for s in cfg.device_counts], rows))
    big = results[str(max(cfg.device_counts))].get("big_lsh")
    if big:
        report += (f"\n\nSharded LSH index: {big['rows']:,} rows x {big['dim']} float32 on {big['devices']} devices: "
                   f"build {big['build_s']:.1f} s, {big['queries_per_s']:,.0f} queries/s, at most "
                   f"{big['bytes_per_device_max'] / 2**20:,.0f} MiB per device (data, tables, mask).\n")
    run.write({"per_s": {s: r["per_s"] for s, r in results.items()}, "big_lsh": big, "device": device},
              report, filename="bench.json", flat=False)
    print(report)
    print(f"wrote {run.file('bench.json')}")


if __name__ == "__main__":
    main()
