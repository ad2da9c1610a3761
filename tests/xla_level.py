"""The test processes' XLA:CPU optimisation level, and how a test runs code at XLA's default level.

The suite is compile-bound: at LLVM optimisation level 0 XLA:CPU compiles about twice as fast and runs
the compiled code about twice as slow, so most test files finish sooner (README, "Set up and run"). Three checks
spend their time running, not compiling (the MJX grasp rollouts, the video segmentation and LfD quick
presets were 1.6-2.3x slower at level 0); they run in a subprocess at the default level (`run_module`,
`run_experiment`). So does the MJX step check: a long pytest worker aborted once in its compile (the
jaxlib crashes of conftest.py). LFD_TEST_XLA_OPT=1 keeps the default level everywhere.
"""
import json
import os
import subprocess
import sys
from pathlib import Path

FAST_COMPILE = "--xla_backend_optimization_level=0"
ROOT = Path(__file__).resolve().parents[1]


def use_fast_compile() -> None:
    """Add FAST_COMPILE to XLA_FLAGS (before JAX starts its CPU back end; subprocesses inherit it)."""
    flags = os.environ.get("XLA_FLAGS", "")
    if os.environ.get("LFD_TEST_XLA_OPT") != "1" and FAST_COMPILE not in flags.split():
        os.environ["XLA_FLAGS"] = f"{flags} {FAST_COMPILE}".strip()


def forced_devices_env(n_devices: int) -> dict:
    """os.environ for a subprocess on `n_devices` forced CPU devices, the test processes' flags kept."""
    flags = f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count={n_devices}".strip()
    return dict(os.environ, XLA_FLAGS=flags, JAX_PLATFORMS="cpu")


def run_module(module: str, *args: str) -> str:
    """`python -m module *args` in a fresh process at the default level (FAST_COMPILE taken out of
    XLA_FLAGS); its stdout. Asserts exit status 0, with the output's tail as the message."""
    env = dict(os.environ, XLA_FLAGS=" ".join(f for f in os.environ.get("XLA_FLAGS", "").split() if f != FAST_COMPILE))
    run = subprocess.run([sys.executable, "-m", module, *args], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, f"exit status {run.returncode}\n{run.stdout[-4000:]}\n{run.stderr[-6000:]}"
    return run.stdout


def run_experiment(module: str, argv: list[str], out: Path) -> dict:
    """`run_module(module, *argv)`; its `out`/metrics.json (argv must write there)."""
    run_module(module, *argv)
    return json.loads((Path(out) / "metrics.json").read_text())
