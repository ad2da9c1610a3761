"""The native / MJX-JAX equivalence check of the grasp rollouts, shared by one test file per hand.

One test file per hand so that `make test` (pytest-xdist, `--dist loadfile`) can give the two MJX
compiles to its two workers. Not a test module itself (no `test_` prefix).

Each test runs the check in a fresh process (`check_in_fresh_process`, `python -m
tests.grasp_equivalence HAND [CLASS ...]`): at the end of a long pytest worker that has compiled
hundreds of programs, jaxlib 0.10.2 crashed (SIGSEGV or SIGABRT, reproduced twice) while serialising
the MJX chunk's executable for the persistent compilation cache (`put_executable_and_time`); a
crash there killed the worker and hung pytest-xdist. The same check in a fresh process, or after
either half of that worker's test files, passes. (The pytest processes now use no persistent cache
at all, tests/conftest.py; this process keeps it, so the MJX compile is shared with later runs.)
"""
import sys

import numpy as np

from sim.grasping import GRASP_CLASSES
from sim.grasping import GraspOutcomes, rollout_grasps
from sim.grasping import PlanOptions, TrialParams, plan_trials
from tests.xla_level import run_module

# The trials: one per grasp class, the 1 s hold shortened to this on both backends (on the shared
# 2-core machine a 20-control-step MJX-JAX chunk of 6 worlds takes 3.5-7 s; the lift is unchanged).
EQUIVALENCE_HOLD_S = 0.2
END_TOLERANCE_M = 0.01


def equivalence_trials(hand: str) -> tuple[TrialParams, np.ndarray]:
    """One trial per grasp class of `hand`, no pose error, tactile correction on; (params, object starts)."""
    b = len(GRASP_CLASSES)
    return plan_trials(hand, np.asarray(GRASP_CLASSES), np.zeros((b, 2)), np.zeros(b), np.ones(b, bool),
                       np.arange(b), options=PlanOptions(hold_s=EQUIVALENCE_HOLD_S))


def native_run(hand: str) -> tuple[TrialParams, np.ndarray, GraspOutcomes]:
    """(params, object starts, native outcomes) of `equivalence_trials(hand)`."""
    params, start = equivalence_trials(hand)
    return params, start, rollout_grasps(hand, params, start, backend="native")


def check_native_and_mjx_jax_agree(hand: str, settle_anywhere: frozenset = frozenset()) -> None:
    """Run `equivalence_trials(hand)` on both backends and assert that they agree.

    Asserted for every trial: the same outcome (lifted or not, palm touched first or not), and the
    object touched or moved by the hand on MJX too. For objects held on both backends: the same set
    of touching links up to one link per trial, and final object positions within END_TOLERANCE_M,
    except for the grasp classes in `settle_anywhere`, whose object is held by the same links and
    lifted to the same height within END_TOLERANCE_M but may settle elsewhere in the hand (each
    caller says why).
    """
    params, start, native = native_run(hand)
    mjx_out = rollout_grasps(hand, params, start, backend="mjx-jax")
    np.testing.assert_array_equal(native.lifted, mjx_out.lifted)
    np.testing.assert_array_equal(native.palm_first, mjx_out.palm_first)
    touched = (mjx_out.contacts[..., 0] > 0).any(-1) | (mjx_out.first_link >= 0)
    moved = np.linalg.norm(mjx_out.object_end - start, axis=-1) > 0.01
    assert np.all(touched | moved), np.array(GRASP_CLASSES)[~(touched | moved)]
    held = native.lifted & mjx_out.lifted
    differ = (native.contacts[held, :, 0] > 0) != (mjx_out.contacts[held, :, 0] > 0)   # (held, links)
    assert differ.sum(-1).max(initial=0) <= 1, differ
    anywhere = np.isin(GRASP_CLASSES, sorted(settle_anywhere))
    np.testing.assert_allclose(native.object_end[held & ~anywhere], mjx_out.object_end[held & ~anywhere],
                               atol=END_TOLERANCE_M)
    np.testing.assert_allclose(native.lift_m[held], mjx_out.lift_m[held], atol=END_TOLERANCE_M)


def check_in_fresh_process(hand: str, settle_anywhere: frozenset = frozenset()) -> str:
    """`check_native_and_mjx_jax_agree(hand, settle_anywhere)` in a new Python process at XLA's default
    optimisation level (see the module docstring, `tests.xla_level.run_module`); its output, which ends
    with EQUIVALENT where the check passed."""
    return run_module("tests.grasp_equivalence", hand, *map(str, sorted(settle_anywhere)))


if __name__ == "__main__":
    from lfd_common import enable_compilation_cache

    enable_compilation_cache()
    check_native_and_mjx_jax_agree(sys.argv[1], frozenset(int(g) for g in sys.argv[2:]))
    print("EQUIVALENT")
