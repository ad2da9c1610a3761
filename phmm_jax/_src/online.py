"""Online recognition of parametric movements: frames arrive one at a time and pointing / reaching
are recognised live with their parameter φ (BMVC 2008 §5.4 "Online Recognition and Synthesis",
Humanoids 2008 §V: the robot is told by pointing and reaching gestures, recognised from noisy 3-D
body tracking while they happen).

Shapes: D features, S streams, T frames, K classes (PHMMs), M φ candidates per class, d parameters
(d <= 3), W the detector's window, F the movement buffer (max_frames).

    online_recognizer(phmms, threshold, options=OnlineOptions()) -> OnlineRecognizer
    init_online(recognizer, n_streams=None) -> OnlineState
    online_step(recognizer, state, x_t) -> (OnlineState, OnlineFrame)     pure, jit-able, fixed cost
    online_step_batch(recognizer, states, X_t (S, D))                     S streams (vmap)
    online_scan(recognizer, stream (T, D), state=None) -> (OnlineState, OnlineFrame (T, ...))  lax.scan
    run_online / OnlineStream (`online_events`): the movements found, refined by `recognize`
Per frame, every class keeps a forward state (`stream`) for each of the M = lattice_points^d
candidates φ_m of the lattice `recognize` starts from (λ_k^{φ_m} interpolated and factored once), so
a frame costs K·M forward steps whatever has happened before. The detector looks W frames ahead of
the models: at frame t the models consume frame u = t - W.
* start: at rest, the hand has moved more than `threshold` over the window (|x_t - x_u| > threshold):
  the movement starts at u, and the rest position is x_u;
* end at u: the hand stays within `threshold` of x_u over the whole window (x_u..x_t still) and is
  back at the rest position (|x_u - rest| <= threshold) *or* the models' exit dominates (the
  filtering probability that the movement ends at u, max over classes and candidates, at least
  `exit_threshold`); and the movement has reached the shortest length a class allows. It also ends
  when it fills the buffer of `max_frames` frames or no candidate of any class explains it any more.
Input is checked at the boundary (`ValueError` naming the argument); inside jit only shapes are.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from lfd_common import NEG_INF, check_int, check_real, float_dtype
from phmm_jax._src.checks import check_type, model_bounds
from phmm_jax._src.inference import stacked_chain
from phmm_jax._src.options import OnlineOptions, check_online_options
from phmm_jax._src.parametric import PHMM, start_lattice, interpolate
from phmm_jax._src.stream import advance, check_frames, check_state, emitter, is_traced, summaries

__all__ = ["OnlineFrame", "OnlineRecognizer", "OnlineState", "init_online", "online_recognizer", "online_scan",
           "online_step", "online_step_batch"]

@partial(jax.tree_util.register_dataclass,
         data_fields=["phmms", "candidates", "chains", "emitters", "threshold", "log_exit_threshold"],
         meta_fields=["options", "min_frames"])
@dataclasses.dataclass(frozen=True)
class OnlineRecognizer:
    """An online recogniser of K classes (a pytree; build it with `online_recognizer`).

    BMVC 2008 §5.4, Humanoids 2008 §V. Its arrays are traced; `options` and `min_frames` are static
    metadata, so jitted steps specialise on them.

    Attributes:
        phmms: The K PHMMs (one per class), for the refinement by `recognize`.
        candidates: (M, d) the φ lattice every class keeps a forward state for.
        chains: Per class, the pseudo-state chains (N_k, P_k, M) of λ_k^{φ_m}.
        emitters: Per class, the factored emissions of λ_k^{φ_m}.
        threshold: () displacement threshold (data units).
        log_exit_threshold: () log of `options.exit_threshold`.
        options: The `OnlineOptions` it was built with, `max_frames` resolved (static).
        min_frames: The shortest movement any class explains (static).
    """

    phmms: tuple
    candidates: jnp.ndarray
    chains: tuple
    emitters: tuple
    threshold: jnp.ndarray
    log_exit_threshold: jnp.ndarray
    options: OnlineOptions
    min_frames: int

    @property
    def dim(self) -> int:
        """D, the feature dimension of every class."""
        return self.phmms[0].local.dim

    @property
    def n_classes(self) -> int:
        """K, the number of classes."""
        return len(self.phmms)


def online_recognizer(phmms: PHMM | Sequence[PHMM], threshold: float, *,
                      options: OnlineOptions = OnlineOptions()) -> OnlineRecognizer:
    """Build an online recogniser for the classes `phmms` (BMVC 2008 §5.4, Humanoids 2008 §V).

    Every class keeps a forward state for each candidate φ of the lattice `recognize` starts from
    (λ_k^{φ_m} interpolated and factored here, once), so a frame costs K·M forward steps.

    Args:
        phmms: A PHMM or a sequence of K PHMMs (same D, same d <= 3), one per class.
        threshold: Displacement (data units, > 0) over `options.window` frames that starts a
            movement; the hand is still / back at rest within it. Choose it above the tracker's
            noise over the window.
        options: `OnlineOptions`: window, exit_threshold, lattice_points, max_frames, and the
            `recognize` settings of the refinement (epsilon, n_steps, face_steps).

    Returns:
        The `OnlineRecognizer`, its `options.max_frames` resolved (default: the longest path of
        any class).

    Raises:
        ValueError: Naming the argument: `phmms` empty, not PHMMs, differing in D or d, or d > 3;
            `threshold` not > 0; `options` not an `OnlineOptions`; `max_frames` shorter than the
            shortest path of a class, or None while a class is a classical HMM (unbounded paths);
            a class whose parameters cannot be factored (`phmms[k]`).
    """
    if isinstance(phmms, PHMM):
        phmms = [phmms]
    if not isinstance(phmms, (list, tuple)) or not phmms:
        raise ValueError(f"phmms: expected a PHMM or a non-empty sequence of PHMMs, got {phmms!r:.80}")
    for k, phmm in enumerate(phmms):
        check_type(phmm, f"phmms[{k}]", PHMM)
        if phmm.local.dim != phmms[0].local.dim or phmm.n_params != phmms[0].n_params:
            raise ValueError(f"phmms[{k}]: differs in feature dimension or parameter count from phmms[0]")
    d = phmms[0].n_params
    if d > 3:
        raise ValueError(f"phmms: the online recogniser keeps lattice_points^d candidates per class; d <= 3, got {d}")
    threshold = check_real(threshold, "threshold", min_value=0.0, exclusive_min=True)
    options = check_online_options(options)
    min_frames = min(p.config.min_length for p in phmms)
    longest = [p.config.max_length for p in phmms]
    max_frames = options.max_frames
    if max_frames is None:
        if None in longest:
            raise ValueError("max_frames: required when a class is a classical HMM "
                             "(max_duration=None: paths of any length)")
        max_frames = max(longest)
    max_frames = check_int(max_frames, "max_frames", min_value=min_frames)
    for k, phmm in enumerate(phmms):  # what the kernels factor must be valid (raises naming the PHMM)
        model_bounds(phmm.local, f"phmms[{k}]")
    dtype = float_dtype()
    candidates = jnp.asarray(start_lattice(d, options.lattice_points), dtype)
    chains, emitters = zip(*[_candidate_models(phmm, candidates) for phmm in phmms])
    return OnlineRecognizer(tuple(phmms), candidates, tuple(chains), tuple(emitters), jnp.asarray(threshold, dtype),
                            jnp.asarray(np.log(options.exit_threshold), dtype), options.replace(max_frames=max_frames),
                            min_frames)


@jax.jit
def _candidate_models(phmm: PHMM, candidates):
    """The chains (N, P, M) and factored emissions of λ^{φ_m} for the M candidates (M, d)."""
    hmms = jax.vmap(interpolate, in_axes=(None, 0))(phmm, candidates)  # leading M axis
    return stacked_chain(hmms), emitter(hmms.means, hmms.covariances)


class OnlineState(NamedTuple):
    """The online recogniser's state of one stream (leading S axis for S streams).

    Attributes:
        t: () int32 frames seen.
        recent: (W + 1, D) the last W + 1 frames (ring buffer, frame t at t mod W+1).
        moving: () bool, the last frame the models consumed (u = t - 1 - W) belongs to a running
            movement.
        rest: (D,) the rest position the current (last) movement left.
        start: () int32 its first frame.
        length: () int32 its frames so far.
        frames: (F, D) its frames (the first `length` rows; kept after the end until the next start).
        forward: Per class, (N_k, P_k, M) forward messages of the candidates after the movement's
            frames so far.
    """

    t: Int[Array, ""]
    recent: Float[Array, "W1 D"]
    moving: Bool[Array, ""]
    rest: Float[Array, " D"]
    start: Int[Array, ""]
    length: Int[Array, ""]
    frames: Float[Array, "F D"]
    forward: tuple


class OnlineFrame(NamedTuple):
    """What the online recogniser says after frame t (leading axes for streams and frames).

    Attributes:
        frame: t.
        position: u = t - W, the frame the models have consumed (-1 for t < W).
        moving: Frame u belongs to a movement.
        started: A movement starts at u.
        ended: A movement ends at u.
        start: The current (last) movement's first frame.
        end: u where `ended`, else -1.
        label: () provisional class, the best running log-likelihood (-1 when none is finite or at
            rest).
        prefix: (K,) best running log p(x_{start:u}) (paths not yet ended) over the candidates per
            class.
        loglik: (K,) the same, finished (the movement ends at u).
        phi: (K, d) the best candidate (by prefix) per class.
        log_exit: () log of the largest probability over classes and candidates that the movement
            ends at u.
    """

    frame: Int[Array, ""]
    position: Int[Array, ""]
    moving: Bool[Array, ""]
    started: Bool[Array, ""]
    ended: Bool[Array, ""]
    start: Int[Array, ""]
    end: Int[Array, ""]
    label: Int[Array, ""]
    prefix: Float[Array, " K"]
    loglik: Float[Array, " K"]
    phi: Float[Array, "K d"]
    log_exit: Float[Array, ""]


def initial_online(rec: OnlineRecognizer) -> OnlineState:
    opts, dtype, dim = rec.options, float_dtype(), rec.dim
    forward = tuple(jnp.full(c.log_cont.shape, NEG_INF, dtype) for c in rec.chains)
    zero = jnp.zeros((), jnp.int32)
    return OnlineState(zero, jnp.zeros((opts.window + 1, dim), dtype), jnp.zeros((), bool), jnp.zeros(dim, dtype),
                       zero, zero, jnp.zeros((opts.max_frames, dim), dtype), forward)


def _distance(a, b):
    return jnp.sqrt(jnp.sum(jnp.square(a - b), axis=-1))


def _online_step(rec: OnlineRecognizer, state: OnlineState, x) -> tuple[OnlineState, OnlineFrame]:
    """One frame of the recogniser (see the module docstring); fixed cost, no branches."""
    opts = rec.options
    ring = opts.window + 1
    t = state.t
    recent = jnp.where(t == 0, jnp.broadcast_to(x, state.recent.shape), state.recent).at[t % ring].set(x)
    u = t - opts.window
    x_u = recent[(t + 1) % ring]  # frame u = t - W
    ready = u >= 0
    started = ready & ~state.moving & (_distance(x, x_u) > rec.threshold)
    moving = state.moving | started
    rest = jnp.where(started, x_u, state.rest)
    start = jnp.where(started, u, state.start)
    length = jnp.where(started, 0, state.length)

    forward, prefix, loglik = [], [], []
    for c, em, log_alpha in zip(rec.chains, rec.emitters, state.forward):
        updated = advance(c, em, log_alpha, length, x_u)
        log_alpha = jnp.where(moving, updated, log_alpha)
        p, f = summaries(c, log_alpha)  # (M,)
        forward.append(log_alpha)
        prefix.append(p)
        loglik.append(f)
    prefix, loglik = jnp.stack(prefix), jnp.stack(loglik)  # (K, M)
    slot = jnp.minimum(length, opts.max_frames - 1)
    frames = jnp.where(moving, jax.lax.dynamic_update_slice_in_dim(state.frames, x_u[None], slot, 0), state.frames)
    length = length + moving.astype(jnp.int32)

    running = jnp.isfinite(prefix)
    log_exit = jnp.max(jnp.where(running, loglik - jnp.where(running, prefix, 0.0), NEG_INF))
    still = jnp.max(_distance(recent, x_u)) <= rec.threshold
    home = _distance(x_u, rest) <= rec.threshold
    settled = still & (home | (log_exit >= rec.log_exit_threshold)) & (length >= rec.min_frames)
    ended = moving & (settled | (length >= opts.max_frames) | ~jnp.any(running))

    best = jnp.argmax(prefix, axis=1)  # (K,)
    rows = jnp.arange(prefix.shape[0])
    best_prefix = prefix[rows, best]
    label = jnp.where(moving & jnp.any(jnp.isfinite(best_prefix)), jnp.argmax(best_prefix), -1)
    frame = OnlineFrame(t, jnp.where(ready, u, -1), moving, started, ended, start, jnp.where(ended, u, -1),
                        label.astype(jnp.int32), best_prefix, loglik[rows, best], rec.candidates[best],
                        jnp.where(moving, log_exit, NEG_INF))
    new_state = OnlineState(t + 1, recent, moving & ~ended, rest, start, length, frames, tuple(forward))
    return new_state, frame


online_step_jit = jax.jit(_online_step)
"""`online_step` without the input checks, jitted: (recognizer, state, x_t (D,)) -> (OnlineState, OnlineFrame).

For a live loop whose frames are already checked (one compiled step, called per frame).
"""
online_step_batch_jit = jax.jit(jax.vmap(_online_step, in_axes=(None, 0, 0)))
"""`online_step_batch` without the input checks, jitted: (recognizer, states, X_t (S, D)) -> the S
streams' (OnlineState, OnlineFrame)."""


@jax.jit
def _online_scan(rec: OnlineRecognizer, state: OnlineState, stream):
    return jax.lax.scan(partial(_online_step, rec), state, stream)


def check_recognizer(rec) -> OnlineRecognizer:
    return check_type(rec, "recognizer", OnlineRecognizer, "a phmm_jax.OnlineRecognizer (from online_recognizer)")


def recognizer_bounds(rec: OnlineRecognizer):
    """(max |μ|, smallest eigenvalue) over every class's grid corners (the candidates interpolate them)."""
    bounds = [model_bounds(p.local, f"phmms[{k}]") for k, p in enumerate(rec.phmms)]
    return max(b[0] for b in bounds), min(b[1] for b in bounds)


def init_online(recognizer: OnlineRecognizer, n_streams: int | None = None) -> OnlineState:
    """The online recogniser's state before the first frame.

    Args:
        recognizer: From `online_recognizer`.
        n_streams: None for one stream, or S >= 1 for S streams.

    Returns:
        `OnlineState`, with a leading axis S when `n_streams` is given.

    Raises:
        ValueError: Naming `recognizer` (not an OnlineRecognizer) or `n_streams` (not an integer >= 1).
    """
    state = initial_online(check_recognizer(recognizer))
    if n_streams is None:
        return state
    n_streams = check_int(n_streams, "n_streams", min_value=1)
    return jax.tree_util.tree_map(lambda a: jnp.broadcast_to(a, (n_streams,) + a.shape), state)


def online_step(recognizer: OnlineRecognizer, state: OnlineState, x_t: Float[ArrayLike, " D"]
                ) -> tuple[OnlineState, OnlineFrame]:
    """Advance the online recogniser by one frame of one stream (BMVC §5.4).

    Pure, jit-able, fixed cost (K·M forward steps of the candidates, no branches). A movement's end
    is signalled by `ended`; its frames are then `state.frames[:state.length]` (`OnlineStream`
    refines them by `recognize`).

    Args:
        recognizer: From `online_recognizer`.
        state: The `OnlineState` after the previous frames.
        x_t: (D,) the new frame.

    Returns:
        (new `OnlineState`, `OnlineFrame`).

    Raises:
        ValueError: Naming `recognizer`, `state` (of another recogniser or of several streams) or
            `x_t` (wrong shape, NaN/inf, too far from the models' means).
    """
    rec = check_recognizer(recognizer)
    check_state(state, "state", initial_online(rec), OnlineState, None)
    x_t = check_frames(x_t, (rec.dim,), "x_t", None, None if is_traced(x_t) else recognizer_bounds(rec))
    return online_step_jit(rec, state, x_t)


def online_step_batch(recognizer: OnlineRecognizer, states: OnlineState, X_t: Float[ArrayLike, "S D"]
                      ) -> tuple[OnlineState, OnlineFrame]:
    """Advance S streams by one frame each (a vmap of `online_step`).

    Args:
        recognizer: From `online_recognizer`.
        states: The S streams' `OnlineState`, each field with a leading axis S.
        X_t: (S, D) one new frame per stream.

    Returns:
        (new `OnlineState`, `OnlineFrame`), each field with a leading axis S.

    Raises:
        ValueError: Naming `recognizer`, `states` or `X_t`, as `online_step` does.
    """
    rec = check_recognizer(recognizer)
    X_t = check_frames(X_t, (None, rec.dim), "X_t", None, None if is_traced(X_t) else recognizer_bounds(rec))
    check_state(states, "states", initial_online(rec), OnlineState, X_t.shape[0])
    return online_step_batch_jit(rec, states, X_t)


def online_scan(recognizer: OnlineRecognizer, stream: Float[ArrayLike, "T D"], state: OnlineState | None = None
                ) -> tuple[OnlineState, OnlineFrame]:
    """Feed a recorded stream through `online_step` by lax.scan.

    Args:
        recognizer: From `online_recognizer`.
        stream: (T, D) the frames.
        state: The `OnlineState` to continue from; None: the start.

    Returns:
        (final `OnlineState`, `OnlineFrame` of every frame with a leading axis T).

    Raises:
        ValueError: Naming `recognizer`, `stream` (empty, wrong D, NaN/inf, too far from the
            models' means) or `state`.
    """
    rec = check_recognizer(recognizer)
    stream = check_frames(stream, (None, rec.dim), "stream", None, recognizer_bounds(rec), sequence=True)
    state = initial_online(rec) if state is None else check_state(state, "state", initial_online(rec),
                                                                      OnlineState, None)
    return _online_scan(rec, state, stream)
