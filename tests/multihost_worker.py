"""One of two local CPU processes of `tests/test_multihost.py`: `jax.distributed` with the gloo CPU
collectives, 2 devices per process, one mesh of 4 over both.

    python -m tests.multihost_worker PROCESS_ID PORT

Both processes make the same data; each passes only its own rows (process 0: the first 4 sequences
or database rows, process 1: the rest, so the parts differ in size) and must get the one-device
results of the whole batch: one EM step (`fit_hmm`, max_iter=1, sufficient statistics psum-ed across
the processes) and one LSH query (rows sharded across the processes, the top k merged).
Prints "OK <process id>" on success.
"""
from __future__ import annotations

import sys

import jax
import numpy as np


def main(process_id: int, port: int) -> None:
    from lfd_common import cache_dir

    # one compilation cache per process id (concurrent writers to one cache have crashed before)
    jax.config.update("jax_compilation_cache_dir", str(cache_dir(f"jax_multihost_{process_id}")))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.2)
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(f"localhost:{port}", num_processes=2, process_id=process_id,
                               local_device_ids=[0, 1])
    assert jax.process_count() == 2 and jax.device_count() == 4, (jax.process_count(), jax.device_count())

    import hog_jax as H
    import phmm_jax as P
    from lfd_common import batch_mesh
    from tests.sharded_checks import same

    mesh = batch_mesh()
    mine = slice(0, 4) if process_id == 0 else slice(4, None)
    rng = np.random.default_rng(0)
    X = rng.normal(size=(7, 20, 2)).cumsum(1).astype(np.float32)
    lengths = np.array([20, 18, 15, 20, 19, 16, 20])
    cfg, options = P.HMMConfig(n_states=3, min_duration=3, max_duration=8), P.FitOptions(max_iter=1)
    sharded = P.fit_hmm(X[mine], lengths[mine], cfg, options=options, mesh=mesh)
    same(sharded, P.fit_hmm(X, lengths, cfg, options=options), "one EM step across 2 processes")

    data = rng.normal(size=(9, 8)).astype(np.float32)
    queries = rng.normal(size=(3, 8)).astype(np.float32)
    key = jax.random.key(1)
    sharded = H.query(H.build_index(key, data[mine], 4, 3, mesh=mesh), queries, 3)
    same(sharded, H.query(H.build_index(key, data, 4, 3), queries, 3), "LSH query across 2 processes")
    print(f"OK {process_id}", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]))
