"""The test processes' XLA:CPU compile flags, and how a test runs code at XLA's default level.

The suite is compile-bound, so the test processes compile for speed of compiling:

* `FAST_COMPILE`: at LLVM optimisation level 0 XLA:CPU compiles about twice as fast and runs the
  compiled code about twice as slow, so most test files finish sooner. Three checks spend their time
  running, not compiling (the MJX grasp rollouts, the video segmentation and LfD quick presets were
  1.6-2.3x slower at level 0); they run in a subprocess at the default level (`run_module`,
  `run_experiment`). So does the MJX step check: a long pytest worker aborted once in its compile (the
  jaxlib crashes of conftest.py).
* `LOOP_FUSION_EMITTER`: XLA:CPU's older loop-fusion emitter instead of its fusion emitters (the
  default). It compiles about twice as fast (a CRF fit's search: 3.6 s -> 1.7 s; the OAC smoke run:
  49 s -> 29 s; the MJX grasp check at the default level: 69 s -> 37 s, its run included) and gives
  the same results on these checks. Every test process and subprocess uses it, the default-level
  ones too, except the checks of a computation on crops against the same on the whole frame, whose
  float32 round-off bound holds only with the default emitters (`with_default_fusion_emitters`).

LFD_TEST_XLA_OPT=1 keeps XLA's defaults everywhere (neither flag).
"""
import inspect
import json
import os
import subprocess
import sys
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

FAST_COMPILE = "--xla_backend_optimization_level=0"
LOOP_FUSION_EMITTER = "--xla_cpu_use_fusion_emitters=false"
ROOT = Path(__file__).resolve().parents[1]


def use_fast_compile() -> None:
    """Add FAST_COMPILE and LOOP_FUSION_EMITTER to XLA_FLAGS (before JAX starts its CPU back end;
    subprocesses inherit them)."""
    flags = os.environ.get("XLA_FLAGS", "")
    if os.environ.get("LFD_TEST_XLA_OPT") == "1":
        return
    wanted = (FAST_COMPILE, LOOP_FUSION_EMITTER) if _knows_loop_fusion_flag() else (FAST_COMPILE,)
    missing = [f for f in wanted if f not in flags.split()]
    os.environ["XLA_FLAGS"] = " ".join([flags, *missing]).strip()


def _knows_loop_fusion_flag() -> bool:
    """Whether the installed jaxlib is of the series LOOP_FUSION_EMITTER was measured on (0.10.x). XLA
    aborts the process on a flag it does not know, so another series compiles with its defaults until
    the flag is checked there."""
    try:
        return metadata.version("jaxlib").startswith("0.10.")
    except metadata.PackageNotFoundError:
        return False


def forced_devices_env(n_devices: int) -> dict:
    """os.environ for a subprocess on `n_devices` forced CPU devices, the test processes' flags kept."""
    flags = f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count={n_devices}".strip()
    return dict(os.environ, XLA_FLAGS=flags, JAX_PLATFORMS="cpu")


def run_module(module: str, *args: str) -> str:
    """`python -m module *args` in a fresh process at the default level (FAST_COMPILE taken out of
    XLA_FLAGS, LOOP_FUSION_EMITTER kept); its stdout. Asserts exit status 0, with the output's tail as
    the message."""
    env = dict(os.environ, XLA_FLAGS=" ".join(f for f in os.environ.get("XLA_FLAGS", "").split() if f != FAST_COMPILE))
    run = subprocess.run([sys.executable, "-m", module, *args], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, f"exit status {run.returncode}\n{run.stdout[-4000:]}\n{run.stderr[-6000:]}"
    return run.stdout


def with_default_fusion_emitters(check: Callable, *args) -> None:
    """`check(*args)` with XLA:CPU's default fusion emitters (LOOP_FUSION_EMITTER left out), the test
    processes' optimisation level kept: here where this process has them, else in a fresh process.

    For checks whose float32 round-off bound holds only with the default emitters: a result computed on
    crops against the same computed on the whole frame (the loop emitter rounds the two shapes
    differently, up to 2e-3 degrees of gradient phase where the default emitters stay within 1e-4).

    Args:
        check: a module-level function of a module under the repository root (a test module's
            `_check_...`).
        *args: its arguments, values that `repr` writes as Python literals (numbers, strings, tuples).

    Raises:
        AssertionError: the check failed (its traceback's tail as the message).
    """
    flags = os.environ.get("XLA_FLAGS", "").split()
    if LOOP_FUSION_EMITTER not in flags:
        check(*args)
        return
    env = dict(os.environ, XLA_FLAGS=" ".join(f for f in flags if f != LOOP_FUSION_EMITTER))
    module = ".".join(Path(inspect.getfile(check)).resolve().relative_to(ROOT).with_suffix("").parts)
    code = f"import {module} as m; m.{check.__name__}(*{args!r})"
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0, f"{check.__name__}{args!r}: exit status {run.returncode}\n{run.stderr[-6000:]}"


def run_experiment(module: str, argv: list[str], out: Path) -> dict:
    """`run_module(module, *argv)`; its `out`/metrics.json (argv must write there)."""
    run_module(module, *argv)
    return json.loads((Path(out) / "metrics.json").read_text())
