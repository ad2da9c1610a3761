"""The `mesh=` option of every library (lfd_common.sharding) against the one-device results.

JAX fixes its device count when it starts, so the sharded checks (`tests/sharded_checks.py`) run in
one subprocess with 4 forced CPU devices; the argument checks run here on this process's device.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import crf_jax
import hog_jax as H
import phmm_jax as P
from lfd_common import batch_mesh, check_mesh, shard, unshard
from tests.xla_level import forced_devices_env

ROOT = Path(__file__).resolve().parents[1]


def test_every_mesh_entry_point_equals_one_device_on_four_forced_devices():
    env = forced_devices_env(4)
    run = subprocess.run([sys.executable, "-m", "tests.sharded_checks"], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=540)
    assert run.returncode == 0 and "ALL OK" in run.stdout, run.stdout + run.stderr[-4000:]


def test_shard_pads_with_row_zero_masks_and_unshards():
    mesh = batch_mesh(1)
    x = np.arange(6.0).reshape(3, 2)
    batch = shard(mesh, x)
    assert batch.n_local == 3 and batch.arrays[0].shape == (3, 2)
    np.testing.assert_array_equal(np.asarray(batch.mask), [True, True, True])
    np.testing.assert_array_equal(batch.row_ids, [0, 1, 2])
    np.testing.assert_array_equal(np.asarray(unshard(mesh, batch.arrays[0], batch.n_local)), x)


@pytest.mark.parametrize("call", [
    lambda: check_mesh("cpu"),
    lambda: P.log_likelihood(None, np.zeros((1, 3, 2)), mesh=4),
    lambda: H.hog(np.ones((1, 16, 16)), mesh=[0]),
    lambda: H.exact_search(np.ones((3, 2)), np.ones(2), 1, mesh="all"),
    lambda: H.build_index(__import__("jax").random.key(0), np.ones((3, 2)), 2, 1, mesh=1),
    lambda: crf_jax.fit_chain(np.zeros((1, 2, 1)), np.zeros((1, 2), int), n_labels=2, mesh=object()),
])
def test_a_mesh_that_is_not_a_mesh_is_a_value_error_naming_mesh(call):
    with pytest.raises(ValueError, match="^mesh: expected a jax.sharding.Mesh"):
        call()


def test_batch_mesh_rejects_a_device_count_out_of_range():
    with pytest.raises(ValueError, match="n_devices"):
        batch_mesh(0)
