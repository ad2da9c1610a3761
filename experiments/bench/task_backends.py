"""The robot's pick-and-place task (`sim.robot.run_task`) on each physics backend: same outcomes, time per task.

    python -m experiments.bench.task_backends [--repeats N]

A few tasks (hands, grasp classes and objects that differ), each run with `TaskOptions(backend=...)`
"native" and "mjx-jax", the same controller on both. Printed per task: success and failed stage on
each backend, the distance between the object's final positions, and the wall time per task (the
first MJX-JAX run of a hand and object class includes its compile; then the median of `repeats`).
Outcomes count as equal when success and failed stage are, and the final positions are within
`END_TOLERANCE_M` (the grasp study's native/MJX tolerance).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from lfd_common import enable_compilation_cache
from sim import TaskOptions, TaskSpec, run_task

END_TOLERANCE_M = 0.01
TASKS = (
    TaskSpec(objects=(1,), object_xy=[(0.0, -0.40)], target=0, grasp=1, place_xy=(0.20, -0.40), hand="barrett"),
    TaskSpec(objects=(10,), object_xy=[(0.0, -0.40)], target=0, grasp=10, place_xy=(0.20, -0.40), hand="karlsruhe"),
    TaskSpec(objects=(12,), object_xy=[(0.0, -0.40)], target=0, grasp=12, place_xy=(-0.25, -0.35), hand="barrett"),
)


def compare(tasks=TASKS, repeats: int = 1) -> list[dict]:
    """Run every task on both backends; one dict per task (outcomes, end distance, times in s)."""
    rows = []
    for spec in tasks:
        row = dict(hand=spec.hand, grasp=spec.grasp, place=tuple(spec.place_xy))
        for backend in ("native", "mjx-jax"):
            times, res = [], None
            for _ in range(1 + repeats):
                t0 = time.perf_counter()
                res = run_task(spec, options=TaskOptions(backend=backend))
                times.append(time.perf_counter() - t0)
            row[backend] = res
            row[f"{backend}_first_s"], row[f"{backend}_s"] = times[0], float(np.median(times[1:]))
        a, b = row["native"], row["mjx-jax"]
        row["end_m"] = float(np.linalg.norm(a.object_pos - b.object_pos))
        row["equal"] = (a.success == b.success and a.failed_stage == b.failed_stage and row["end_m"] <= END_TOLERANCE_M)
        rows.append(row)
        print(f"{spec.hand:9s} grasp {spec.grasp:2d}: native {'ok' if a.success else 'FAIL ' + a.failed_stage:12s} "
              f"mjx-jax {'ok' if b.success else 'FAIL ' + b.failed_stage:12s} end {1e3 * row['end_m']:6.1f} mm "
              f"equal {row['equal']:d} | native {row['native_s']:.1f} s (first {row['native_first_s']:.1f}) "
              f"mjx-jax {row['mjx-jax_s']:.1f} s (first, compile included, {row['mjx-jax_first_s']:.1f})", flush=True)
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=1, help="timed runs per task and backend after the first")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        raise ValueError(f"repeats: expected >= 1, got {args.repeats}")
    enable_compilation_cache()
    rows = compare(repeats=args.repeats)
    print(f"{sum(r['equal'] for r in rows)} of {len(rows)} tasks with equal outcomes")


if __name__ == "__main__":
    main()
