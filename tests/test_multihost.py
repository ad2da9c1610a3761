"""Two local CPU processes (`jax.distributed.initialize`, gloo collectives), each loading its own part
of the data (`jax.make_array_from_process_local_data` via `lfd_common.shard`): an EM step and an LSH
query equal the single-process results (`tests/multihost_worker.py`)."""
from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

from tests.xla_level import forced_devices_env

ROOT = Path(__file__).resolve().parents[1]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def test_em_step_and_lsh_query_across_two_processes_equal_one_process():
    port = _free_port()
    env = forced_devices_env(2)
    procs = [subprocess.Popen([sys.executable, "-m", "tests.multihost_worker", str(i), str(port)], cwd=ROOT,
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in range(2)]
    try:
        outs = [p.communicate(timeout=300) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    for i, (p, (out, err)) in enumerate(zip(procs, outs)):
        assert p.returncode == 0 and f"OK {i}" in out, f"process {i}:\n{out}\n{err[-4000:]}"
