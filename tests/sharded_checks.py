"""Every `mesh=` entry point against its one-device result, on 4 forced CPU devices.

Run by `tests/test_sharding.py` in a subprocess (JAX reads the device count only before it starts):

    XLA_FLAGS=--xla_force_host_platform_device_count=4 python -m tests.sharded_checks [mjx]

`mjx` adds the MJX grasp rollouts (two MJX-JAX compilations, minutes on 2 cores: run by hand, not
by the test suite).

Batches of 7 (or 5) rows do not divide the 4 devices, so the padding and the masks are exercised.
Floats must agree to round-off, integers exactly. Prints one line per check and "ALL OK" at the end.
"""
from __future__ import annotations

import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from lfd_common import batch_mesh, enable_compilation_cache

RTOL, ATOL = 1e-4, 1e-4


def same(got, want, name: str, exact_ints: bool = True, atol: float = ATOL) -> None:
    """Every leaf equal: integer and bool leaves exactly, floats to round-off (`atol`; inf/NaN in place)."""
    got_leaves, want_leaves = jax.tree.leaves(got), jax.tree.leaves(want)
    assert len(got_leaves) == len(want_leaves), name
    for g, w in zip(got_leaves, want_leaves):
        g, w = np.asarray(g), np.asarray(w)
        assert g.shape == w.shape, f"{name}: shape {g.shape} != {w.shape}"
        if exact_ints and not np.issubdtype(w.dtype, np.floating):
            np.testing.assert_array_equal(g, w, err_msg=name)
        else:
            np.testing.assert_allclose(g, w, rtol=RTOL, atol=atol, err_msg=name)


def check_phmm(mesh) -> None:
    import phmm_jax as P

    rng = np.random.default_rng(0)
    cfg = P.HMMConfig(n_states=3, min_duration=3, max_duration=8)
    X = rng.normal(size=(7, 20, 2)).cumsum(1).astype(np.float32)
    lengths = np.array([20, 18, 15, 20, 19, 16, 20])
    options = P.FitOptions(max_iter=3)
    hmm = P.fit_hmm(X, lengths, cfg, options=options)
    same(P.fit_hmm(X, lengths, cfg, options=options, mesh=mesh), hmm, "fit_hmm (EM, psum)")
    same(P.log_likelihood(hmm, X, lengths, mesh=mesh), P.log_likelihood(hmm, X, lengths), "log_likelihood")
    same(P.posteriors(hmm, X, lengths, mesh=mesh), P.posteriors(hmm, X, lengths), "posteriors")
    same(P.viterbi(hmm, X, lengths, mesh=mesh), P.viterbi(hmm, X, lengths), "viterbi")
    other = P.fit_hmm(X[:, ::-1], None, cfg, options=options)
    phmm = P.PHMM(jax.tree.map(lambda *a: jnp.stack(a), hmm, other), (2,))
    args = dict(n_steps=1, lattice_points=3, face_steps=0)
    same(P.recognize(phmm, X[:5, :15], **args, mesh=mesh), P.recognize(phmm, X[:5, :15], **args), "recognize")


def check_hog(mesh) -> None:
    import hog_jax as H
    from hog_jax.video import run_background_batch
    from hog_jax.video import LevelSetOptions, LevelSetStructure, segment_video

    rng = np.random.default_rng(1)
    images = rng.random((7, 16, 16)).astype(np.float32)
    same(H.hog(images, mesh=mesh), H.hog(images), "hog")
    data = rng.normal(size=(203, 8)).astype(np.float32)
    queries = rng.normal(size=(5, 8)).astype(np.float32)
    same(H.exact_search(data, queries, 5, mesh=mesh), H.exact_search(data, queries, 5), "exact_search")
    key = jax.random.key(1)
    index, sharded_index = H.build_index(key, data, 6, 4), H.build_index(key, data, 6, 4, mesh=mesh)
    same(H.query(sharded_index, queries, 5, n_probes=1), H.query(index, queries, 5, n_probes=1),
         "LSH build_index + query (no bucket over C = 64)")
    videos = rng.integers(0, 256, (5, 3, 8, 8, 3)).astype(np.uint8)
    same(run_background_batch(videos, mesh=mesh), run_background_batch(videos), "run_background_batch")
    scores = np.log(rng.dirichlet(np.ones(2), (5, 2, 8, 8))).transpose(0, 1, 4, 2, 3).astype(np.float32)
    structure, opts = LevelSetStructure(2, (8, 8), None), LevelSetOptions(it_min=2, it_max=8)
    same(segment_video(structure, scores, options=opts, mesh=mesh), segment_video(structure, scores, options=opts),
         "segment_video")


def check_crf(mesh) -> None:
    import crf_jax

    rng = np.random.default_rng(2)
    X = rng.normal(size=(7, 6, 3)).astype(np.float32)
    y = (X[..., 0] > 0).astype(np.int32)
    lengths = np.array([6, 5, 6, 4, 6, 6, 3])
    opts = crf_jax.FitOptions(max_iter=5)
    one = crf_jax.fit_chain(X, y, lengths, n_labels=2, options=opts)
    sharded = crf_jax.fit_chain(X, y, lengths, n_labels=2, options=opts, mesh=mesh)
    same(sharded.model, one.model, "fit_chain (data-parallel gradients)")


def check_mjx(mesh) -> None:
    from sim.grasping import rollout_grasps
    from tests.grasp_equivalence import equivalence_trials

    params, start = equivalence_trials("barrett")
    params, start = type(params)(*(a[:3] for a in params)), start[:3]
    sharded = rollout_grasps("barrett", params, start, backend="mjx-jax", mesh=mesh)
    one = rollout_grasps("barrett", params, start, backend="mjx-jax")
    # 2,800 contact-rich float32 steps amplify the partitioned program's round-off: the discrete
    # outcomes must agree, lengths to 2 mm (metres) and 0.1 mm (slip, in mm)
    pick = lambda o: (o.lifted, o.palm_first, o.first_link, o.n_corrections, o.contacts[..., 0] > 0, o.phase)  # noqa: E731
    same(pick(sharded), pick(one), "MJX-JAX grasp rollouts: discrete outcomes")
    same((sharded.lift_m, sharded.object_end), (one.lift_m, one.object_end), "MJX-JAX: lift, object end", atol=2e-3)
    same(sharded.slip_mm, one.slip_mm, "MJX-JAX: slip", atol=0.1)


def main() -> None:
    enable_compilation_cache()
    assert jax.device_count() == 4, f"expected 4 forced CPU devices, got {jax.device_count()}"
    mesh = batch_mesh()
    checks = (check_phmm, check_hog, check_crf) + ((check_mjx,) if "mjx" in sys.argv[1:] else ())
    for check in checks:
        start = time.perf_counter()
        check(mesh)
        print(f"{check.__name__}: ok ({time.perf_counter() - start:.1f} s)", flush=True)
    print("ALL OK")


if __name__ == "__main__":
    main()
