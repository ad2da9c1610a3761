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
