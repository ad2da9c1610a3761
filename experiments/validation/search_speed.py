"""`recognize` against the recognition of another revision of this repository (for instance
one with the former 20-step Adam search): time per sequence and how often the returned φ is
within 1 nat of a dense search, on `bench_hmm`'s recognition workload (2 PHMMs of a 2x2 grid, batch
70) for several seeds.

    python experiments/validation/search_speed.py OUT --revision REV [--seeds 0,1,2] [--rounds 5]

The workloads (data and PHMMs, fitted here and written with `phmm_jax.save`) are the same for both
revisions. Each side runs in its own process (the other revision's packages come from `git archive`),
the two alternating `rounds` times per seed so that a load drifting over the run reaches both alike;
a process warms up (compiles) and then times `repeats` calls of `recognize(phmms, X)`. The figure
is the median over the rounds of each process's median. The dense reference is `bench_hmm`'s: the
best of a 21^d lattice and 30 + 10 quasi-Newton steps, per sequence and PHMM. Writes OUT/speed.json.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import numpy as np

from experiments.bench import bench_hmm
from lfd_common import enable_compilation_cache

ROOT = Path(__file__).resolve().parents[2]

# Runs in a fresh interpreter with the side's tree first on sys.path; prints one JSON line.
WORKER = """
import json, sys, time
import numpy as np, jax
try:
    from lfd_common import enable_compilation_cache
    enable_compilation_cache()
except ImportError:
    pass
import phmm_jax as P
folder, repeats = sys.argv[1], int(sys.argv[2])
X = np.load(folder + "/X.npy")
phmms = [P.load(folder + f"/phmm{k}.npz") for k in range(2)]
jax.block_until_ready(P.recognize(phmms, X).loglik)
times = []
for _ in range(repeats):
    start = time.perf_counter()
    result = jax.block_until_ready(P.recognize(phmms, X))
    times.append(time.perf_counter() - start)
print(json.dumps({"median_s": float(np.median(times)), "loglik": np.asarray(result.loglik).tolist()}))
"""


def export_workload(seed: int, folder: Path) -> np.ndarray:
    """Write seed's workload to `folder` (X.npy, phmm0.npz, phmm1.npz); returns the dense search's
    log-likelihoods (B, 2)."""
    import phmm_jax as P

    cfg = bench_hmm.BenchConfig(seed=seed)
    hmm_cfg = P.HMMConfig(n_states=cfg.n_states, min_duration=cfg.min_duration, max_duration=cfg.max_duration)
    phmms, X = bench_hmm.recognition_workload(cfg, hmm_cfg)
    folder.mkdir(parents=True, exist_ok=True)
    np.save(folder / "X.npy", X)
    for k, phmm in enumerate(phmms):
        P.save(folder / f"phmm{k}.npz", phmm)
    return bench_hmm.dense_search_logliks(phmms, X)


def unpack_revision(revision: str, folder: Path) -> Path:
    """The packages of `revision` (git archive of this repository) under `folder`."""
    archive = folder / "tree.tar"
    subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", "-o", str(archive), revision], check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(folder / "tree", filter="data")
    return folder / "tree"


def run_side(tree: Path, workload: Path, repeats: int) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run([sys.executable, "-c", WORKER, str(workload), str(repeats)], env=env, cwd=str(tree),
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--revision", required=True, help="the other side (a git revision of this repository)")
    ap.add_argument("--seeds", default="0,1,2", help="comma-separated workload seeds")
    ap.add_argument("--rounds", type=int, default=5, help="alternating process pairs per seed")
    ap.add_argument("--repeats", type=int, default=5, help="timed calls per process")
    args = ap.parse_args(argv)
    if args.rounds < 1 or args.repeats < 1:
        raise SystemExit("--rounds and --repeats must be >= 1")
    enable_compilation_cache()
    args.out.mkdir(parents=True, exist_ok=True)
    sides = {"this": ROOT}
    report = {"revision": args.revision, "rounds": args.rounds, "repeats": args.repeats, "seeds": {}}
    with tempfile.TemporaryDirectory() as workdir:
        sides["other"] = unpack_revision(args.revision, Path(workdir))
        for seed in (int(s) for s in args.seeds.split(",")):
            workload = Path(workdir) / f"seed{seed}"
            dense = export_workload(seed, workload)
            runs = {name: [] for name in sides}
            for _ in range(args.rounds):
                for name, tree in sides.items():
                    runs[name].append(run_side(tree, workload, args.repeats))
            row = {}
            for name, results in runs.items():
                gap = bench_hmm.search_gap(results[-1]["loglik"], dense)
                row[name] = {"ms_per_seq": 1e3 * float(np.median([r["median_s"] for r in results])) / dense.shape[0],
                             "within_1_nat": float(np.mean(gap <= 1.0)), "gap_median": float(np.median(gap)),
                             "gap_max": float(gap.max())}
            row["ratio"] = row["this"]["ms_per_seq"] / row["other"]["ms_per_seq"]
            report["seeds"][seed] = row
            print(f"seed {seed}: this {row['this']['ms_per_seq']:.2f} ms/seq ({row['this']['within_1_nat']:.1%} "
                  f"within 1 nat, max gap {row['this']['gap_max']:.1f}), {args.revision} "
                  f"{row['other']['ms_per_seq']:.2f} ms/seq ({row['other']['within_1_nat']:.1%}, max gap "
                  f"{row['other']['gap_max']:.1f}); ratio {row['ratio']:.3f}", flush=True)
    (args.out / "speed.json").write_text(json.dumps(report, indent=2))
    return report


if __name__ == "__main__":
    main()
