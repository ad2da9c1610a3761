import os

os.environ.setdefault("LFD_NO_PROGRESS", "1")

import jax  # noqa: E402

# No persistent compilation cache in the test processes. jaxlib 0.10.2 crashed (SIGSEGV/SIGABRT)
# serialising an MJX executable for the cache at the end of a long pytest worker (reproduced twice,
# never in a fresh process), which killed the worker and failed or hung the run. JAX decides once per
# process, at its first compile, whether the cache is used, so switching it off here also holds for
# the experiments the tests run in-process (their `enable_compilation_cache()` then only sets the
# directory). Subprocesses started by tests (CLIs, sharded and multi-host checks, the MJX
# equivalence checks) are short and keep their own cache.
jax.config.update("jax_enable_compilation_cache", False)


# Files that take longest, heaviest first: `make test` distributes whole files over two workers
# (`--dist loadfile`) in collection order, so with the alphabetical order a heavy file near the end ran
# alone on one worker while the other idled. Seconds from `pytest --durations=60` in a fresh clone with
# cold caches (2026-12-04); files not listed keep their order after these. Only the order changes.
_HEAVY_FILES_S = {
    "test_oac.py": 113, "test_grasp_equivalence_karlsruhe.py": 105, "test_phmm_tabletop.py": 98,
    "test_grasp_recognition.py": 96, "test_imitation.py": 81, "test_grasp_equivalence_barrett.py": 79,
    "test_cli.py": 70, "test_lfd_demonstration.py": 66, "test_readme.py": 65, "test_phmm_training.py": 59,
    "test_real_arm_actions.py": 55, "test_sharding.py": 51, "test_crf_models.py": 49,
    "test_video_segmentation.py": 43, "test_demo.py": 36, "test_phmm_inference.py": 32, "test_mjx_step.py": 29,
    "test_lfd_features.py": 26, "test_hog_lsh.py": 23, "test_grasp_rollout.py": 22, "test_phmm_edge_cases.py": 22,
}


def pytest_collection_modifyitems(items):
    items.sort(key=lambda item: -_HEAVY_FILES_S.get(item.path.name, 0))  # stable: in-file order kept
