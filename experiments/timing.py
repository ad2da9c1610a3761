"""The one timing helper of the benchmarks: warm-up, `jax.block_until_ready`, median of repeats,
compile time apart.

    t = time_call(lambda: batch_log_likelihood(hmm, X, lengths), repeats=7)
    t.median_s, t.first_s, t.compile_s, t.result

`warmup` is the first, separately timed call: `fn` itself (the default: its time minus the median is
the compile time), another callable (a warm-up on a smaller input, say) or None (no warm-up).
`setup` (optional) builds a fresh input before every call, outside the timed region; `fn` then takes
it as its argument. `time_interleaved` times several callables round-robin (one call of each per
repeat), so that a load that drifts during the run reaches every side alike: use it for the sides of
a ratio. `block=False` skips `jax.block_until_ready` for results that are not JAX arrays
(walking a large Python result would be timed as part of the anchor's work).
"""
from __future__ import annotations

import dataclasses
import statistics
import time
from collections.abc import Callable, Mapping
from typing import Any

_DEFAULT = object()


@dataclasses.dataclass(frozen=True)
class Timing:
    """Seconds of the timed calls (`times_s`), their median, the warm-up call (`first_s`, NaN when
    there was none) and the last call's result."""

    times_s: tuple[float, ...]
    first_s: float
    result: Any = None

    @property
    def median_s(self) -> float:
        return float(statistics.median(self.times_s))

    @property
    def compile_s(self) -> float:
        """Warm-up time beyond a warm call (compilation, first transfers); 0 when it was not slower."""
        return max(self.first_s - self.median_s, 0.0) if self.first_s == self.first_s else 0.0


def _ready(value, block: bool):
    if block:
        import jax

        return jax.block_until_ready(value)
    return value


def time_call(fn: Callable, repeats: int, warmup: Callable | None | object = _DEFAULT,
              setup: Callable[[], Any] | None = None, block: bool = True) -> Timing:
    """Time `fn()` (or `fn(setup())`) `repeats` times after a warm-up; see the module docstring."""
    if repeats < 1:
        raise ValueError(f"repeats: expected >= 1, got {repeats}")

    def call(f):
        arg = () if setup is None else (setup(),)
        start = time.perf_counter()
        out = _ready(f(*arg), block)
        return time.perf_counter() - start, out

    first = float("nan")
    if warmup is not None:
        first, _ = call(fn if warmup is _DEFAULT else warmup)
    times, out = [], None
    for _ in range(repeats):
        seconds, out = call(fn)
        times.append(seconds)
    return Timing(tuple(times), first, out)


def time_interleaved(fns: Mapping[str, Callable], repeats: int, block: bool = True) -> dict[str, Timing]:
    """`time_call` of each `fn()` in `fns`, one call of each in turn per repeat (after one warm-up
    call of each, in the same order); see the module docstring."""
    if repeats < 1:
        raise ValueError(f"repeats: expected >= 1, got {repeats}")

    def call(f):
        start = time.perf_counter()
        out = _ready(f(), block)
        return time.perf_counter() - start, out

    first = {name: call(f)[0] for name, f in fns.items()}
    times = {name: [] for name in fns}
    last = {}
    for _ in range(repeats):
        for name, f in fns.items():
            seconds, last[name] = call(f)
            times[name].append(seconds)
    return {name: Timing(tuple(times[name]), first[name], last[name]) for name in fns}
