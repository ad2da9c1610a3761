import os

os.environ.setdefault("LFD_NO_PROGRESS", "1")
from tests.xla_level import use_fast_compile  # noqa: E402

use_fast_compile()  # see tests/xla_level.py

import jax  # noqa: E402

# No persistent compilation cache in the test processes. jaxlib 0.10.2 crashed (SIGSEGV/SIGABRT)
# serialising an MJX executable for the cache at the end of a long pytest worker (reproduced twice,
# never in a fresh process), which killed the worker and failed or hung the run. JAX decides once per
# process, at its first compile, whether the cache is used, so switching it off here also holds for
# the experiments the tests run in-process (their `enable_compilation_cache()` then only sets the
# directory). Subprocesses started by tests (CLIs, sharded and multi-host checks, the MJX
# equivalence checks) are short and keep their own cache.
jax.config.update("jax_enable_compilation_cache", False)

# The heaviest test files, heaviest first (a file's tests together, on a cold `make test` on the 2-core
# machine): `make test` runs whole files on two workers in collection order
# (`--no-loadscope-reorder`), so these start first and the run ends on short files, not on a
# one-test file that costs a minute while the other worker idles (pytest-xdist's default order, by
# number of tests per file, put the one-test MJX checks last). Files not listed keep their order after
# these. Only the order changes; every test still runs.
HEAVY_FILES_FIRST = (
    "test_imitation.py",
    "test_grasp_recognition.py",
    "test_oac.py",
    "test_grasp_equivalence_barrett.py",
    "test_grasp_equivalence_karlsruhe.py",
    "test_phmm_tabletop.py",
    "test_cli.py",
    "test_phmm_inference.py",
    "test_docs_examples.py",
    "test_video_segmentation.py",
    "test_lfd_demonstration.py",
    "test_real_arm_actions.py",
    "test_phmm_training.py",
    "test_sharding.py",
    "test_crf_chain.py",
    "test_crf_models.py",
    "test_mjx_step.py",
    "test_lfd_features.py",
    "test_demo.py",
)


def pytest_collection_modifyitems(config, items):
    """Put the tests of `HEAVY_FILES_FIRST` first, in that order (a stable sort: a file's tests stay together
    and in their own order)."""
    rank = {name: i for i, name in enumerate(HEAVY_FILES_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))
