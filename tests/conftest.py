import gc
import os
from pathlib import Path

import pytest

os.environ.setdefault("LFD_NO_PROGRESS", "1")
from tests.xla_level import use_fast_compile  # noqa: E402

use_fast_compile()  # see tests/xla_level.py

import jax  # noqa: E402
from hypothesis import settings  # noqa: E402

# The property tests draw the same examples on every run (derandomized, no example database), so that
# a CI run is reproducible: a random draw once failed CI on a float32 tolerance no earlier run had met.
# HYPOTHESIS_PROFILE=explore draws new examples each run, to look for more such cases.
settings.register_profile("reproducible", derandomize=True, database=None)
settings.register_profile("explore")
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "reproducible"))

# No persistent compilation cache in the test processes. jaxlib 0.10.2 crashed (SIGSEGV/SIGABRT)
# serialising an MJX executable for the cache at the end of a long pytest worker (reproduced twice,
# never in a fresh process), which killed the worker and failed or hung the run. JAX decides once per
# process, at its first compile, whether the cache is used, so switching it off here also holds for
# the experiments the tests run in-process (their `enable_compilation_cache()` then only sets the
# directory). Subprocesses started by tests (CLIs, sharded and multi-host checks, the MJX
# equivalence checks) are short and keep their own cache.
jax.config.update("jax_enable_compilation_cache", False)

# XLA:CPU maps the code and constants of every compiled kernel into memory as separate mappings (about
# three per kernel) and keeps them while the executable is cached. A pytest worker that runs half the
# suite compiles thousands of programs: it passed 40,000 mappings half-way through a local run, and at
# Linux's vm.max_map_count (65,530 by default) the JIT's next mmap fails and the worker dies in a compile
# with SIGSEGV or SIGABRT, in whichever test file comes last. After a test file, when the worker holds
# more than this share of the limit, JAX's caches are cleared, which unmaps that code (files that share
# compiled functions then compile them again, so it is not done after every file).
MAP_SHARE_BEFORE_CLEARING = 0.5
MAPS = Path("/proc/self/maps")
MAX_MAP_COUNT = Path("/proc/sys/vm/max_map_count")


def memory_map_share() -> float:
    """The share of vm.max_map_count this process uses (0 where /proc does not say)."""
    try:
        with MAPS.open() as maps:
            return sum(1 for _ in maps) / int(MAX_MAP_COUNT.read_text())
    except (OSError, ValueError):
        return 0.0


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_code_near_the_map_limit():
    yield
    if memory_map_share() > MAP_SHARE_BEFORE_CLEARING:
        jax.clear_caches()
        gc.collect()

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
    "test_video_streaming.py",
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
