"""The online-recognition measurements of `bench_hmm` (BMVC 2008 §5.4): what one frame of
a live stream costs `phmm_jax`'s online recogniser, and how many streams one core keeps in real time.

* `online_ms_per_frame`: 2 actions (the recognition workload's PHMMs, reaching and pointing, 2x2
  grid, N = 20 x durations 4-6, D = 21; 5^2 candidates φ each) x 1 stream: the jitted per-frame step
  fed frame by frame as a live loop would (each frame's result ready before the next), median over
  repeats of a whole stream, after a warm-up. The stream: one simulated subject pointing at one
  target and reaching for another, with rests before, between and after.
* `online_run_ms`: the recorded stream through `run_online` (lax.scan, then one `recognize` per
  movement); the movements found, how many have the true class, and how many the class `recognize`
  gives on the true segments (the workload's PHMMs are each fitted on one simulated subject, so
  the second isolates what the online segmentation costs from what the models can do).
* `online_streams_per_core_realtime`: S vmapped streams timed in a subprocess pinned to one core
  (taskset), S = 16 ... 1024; the answer is never extrapolated upwards: the largest S that met
  the 40 ms budget of a 25 fps frame, or a slower S scaled down to it, whichever is larger.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time

import jax
import jax.numpy as jnp
import numpy as np

import phmm_jax as P
from experiments.timing import time_call
from experiments.data.tabletop import raster_targets, resample, sample_subject, simulate
from lfd_common import enable_compilation_cache
from phmm_jax import online_step_batch_jit, online_step_jit

ONLINE_FPS = 25.0  # a video tracker's frame rate: the real-time budget of one frame is 40 ms
ONLINE_STREAMS = (16, 64, 256, 1024)  # vmapped streams timed on one core
KINDS = ("reaching", "pointing")  # the classes of the recognition workload, in its order
NOISE_M = 0.002  # marker noise (m) of the simulated recordings, as in the workload


def online_stream(seed: int, n_frames: int = 100, rest_frames: int = 30):
    """(stream (T, 21), true class per movement, (first, last) frame per movement, threshold): one
    subject points at a target of the
    5x7 test raster and then reaches for another, with rests (the adjacent pose held, plus marker
    noise); the detector's threshold is three times the typical norm of a displacement of the marker
    noise (σ √(2D))."""
    rng = np.random.default_rng(seed + 2)
    subject = [sample_subject(rng)]
    targets = raster_targets(5, 7).reshape(-1, 3)
    moves = [resample(simulate(rng, subject, targets[[i]], 1, kind, marker_noise_m=NOISE_M), n_frames)[0]
             for i, kind in ((10, "pointing"), (24, "reaching"))]
    stream_dim = moves[0].shape[-1]
    parts, segments = [], []
    for move in moves:
        parts += [move[0] + NOISE_M * rng.normal(size=(rest_frames, stream_dim)), move]
        first = sum(len(p) for p in parts) - len(move)
        segments.append((first, first + len(move) - 1))
    parts.append(moves[-1][-1] + NOISE_M * rng.normal(size=(rest_frames, stream_dim)))
    threshold = 3.0 * NOISE_M * np.sqrt(2.0 * stream_dim)  # 3 sigma of a displacement of white marker noise
    truth = [KINDS.index("pointing"), KINDS.index("reaching")]
    return np.concatenate(parts).astype(np.float32), truth, segments, threshold


def online_stage(phmms, seed: int, repeats: int) -> dict:
    """The measurements of the module docstring, printed and returned (flat keys)."""
    stream, truth, segments, threshold = online_stream(seed)
    rec = P.online_recognizer(phmms, threshold)
    frames = jnp.asarray(stream)

    def live_loop():
        state = P.init_online(rec)
        for x in frames:
            state, out = online_step_jit(rec, state, x)
            jax.block_until_ready(out)
        return state.t

    loop = time_call(live_loop, max(3, repeats // 2))
    ms_per_frame = loop.median_s * 1e3 / len(stream)
    start = time.perf_counter()
    events = P.run_online(rec, stream)  # the scan, then one recognize per movement (first call compiles)
    first_run_s = time.perf_counter() - start
    run = time_call(lambda: P.run_online(rec, stream), 1, warmup=None)
    offline = [int(P.recognize(phmms, stream[a:b + 1]).label[0]) for a, b in segments]  # on the true segments
    same_count = len(events.label) == len(truth)
    correct = int(same_count and np.sum(events.label == np.asarray(truth)))
    as_offline = int(same_count and np.sum(events.label == np.asarray(offline)))
    print(f"{'ours online step (2 actions x 25 phi, 1 stream)':48s} {ms_per_frame:9.3f} ms/frame   "
          f"compile+first ~{loop.first_s - loop.median_s:6.2f} s")
    print(f"{'ours run_online (scan + refinement)':48s} {run.median_s * 1e3:9.1f} ms for {len(stream)} frames: "
          f"{len(events.found)} movements at {events.start.tolist()}-{events.end.tolist()}, labels "
          f"{events.label.tolist()} (true {truth} at {segments}; recognize on the true segments {offline}; "
          f"first call {first_run_s:.1f} s)")
    ms = streams_on_one_core(phmms, stream, threshold, repeats)
    budget = 1e3 / ONLINE_FPS  # never extrapolated upwards: S that met the budget, or S scaled down to it
    streams = max([n for n in ms if ms[n] <= budget] + [int(n * budget / ms[n]) for n in ms if ms[n] > budget])
    for n, value in sorted(ms.items()):
        print(f"{'ours online step, ' + str(n) + ' streams (vmap, 1 core)':48s} {value:9.3f} ms/frame")
    print(f"{'streams one core keeps at 25 fps':48s} {streams:9d}")
    return {"online_ms_per_frame": ms_per_frame, "online_compile_s": loop.first_s - loop.median_s,
            "online_stream_frames": len(stream), "online_movements_found": int(np.sum(events.found)),
            "online_movements_correct": correct, "online_labels_as_offline": as_offline,
            "online_run_ms": run.median_s * 1e3,
            **{f"online_ms_per_frame_{n}_streams_1_core": value for n, value in sorted(ms.items())},
            "online_streams_per_core_realtime": streams}


def streams_on_one_core(phmms, stream: np.ndarray, threshold: float, repeats: int) -> dict[int, float]:
    """{S: ms per frame of S vmapped streams}, measured by `online_core_worker` in a subprocess pinned
    to one core (the models pass through `phmm_jax.save` / `load`)."""
    with tempfile.TemporaryDirectory() as folder:
        paths = [os.path.join(folder, f"phmm{k}.npz") for k in range(len(phmms))]
        for path, phmm in zip(paths, phmms):
            P.save(path, phmm)
        stream_path = os.path.join(folder, "stream.npy")
        np.save(stream_path, stream)
        code = ("from experiments.bench.online_stage import online_core_worker; "
                f"online_core_worker({paths!r}, {stream_path!r}, {float(threshold)!r}, {int(repeats)})")
        done = subprocess.run(["taskset", "-c", str(min(os.sched_getaffinity(0))), sys.executable, "-c", code],
                              capture_output=True, text=True, check=True)
    return {int(k): v for k, v in json.loads(done.stdout.strip().splitlines()[-1]).items()}


def online_core_worker(paths, stream_path, threshold, repeats, n_frames: int = 50):
    """Runs in the pinned subprocess: prints {S: ms per frame of S vmapped streams} as JSON."""
    enable_compilation_cache()
    rec = P.online_recognizer([P.load(p) for p in paths], threshold)
    stream = np.load(stream_path)
    out = {}
    for n in ONLINE_STREAMS:
        frames = jnp.asarray(np.stack([np.roll(stream, 7 * s, axis=0) for s in range(n)], axis=1))  # (T, S, D)

        def loop():
            states = P.init_online(rec, n)
            for x in frames[:n_frames]:
                states, result = online_step_batch_jit(rec, states, x)
                jax.block_until_ready(result)
            return states.t

        out[n] = time_call(loop, max(3, repeats // 2)).median_s * 1e3 / n_frames
    print(json.dumps(out))
