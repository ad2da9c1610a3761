"""Movements found by the online recogniser (`online`), refined by `recognize`: for a
recorded stream (`run_online`, by lax.scan) and for a live one (`OnlineStream`, frame by frame).
BMVC 2008 §5.4, Humanoids 2008 §V.

When a movement ends, its frames (and only those) are passed once to `recognize` (bounded: the
segment is padded to max_frames F, one compiled shape), which refines class and φ; the event is
reported at t = end + W: a latency of exactly W frames plus one `recognize` call.

Results are NamedTuples of batch-first arrays over E events; `OnlineEvents.found` is False for a
detected movement that no class can explain (its length fits no model): label -1, φ 0,
log-likelihoods -inf, never NaN. Shapes: D features, T frames, K classes, d parameters.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from jaxtyping import ArrayLike, Bool, Float, Int

from lfd_common import float_dtype
from phmm_jax._src.online import (OnlineFrame, OnlineRecognizer, check_recognizer, initial_online,
    online_step_jit, recognizer_bounds, online_scan)
from phmm_jax._src.parametric import recognize
from phmm_jax._src.stream import check_frames

__all__ = ["OnlineEvents", "OnlineStream", "run_online"]



class OnlineEvents(NamedTuple):
    """Movements detected by the online recogniser, batch-first over E events (BMVC §5.4).

    Attributes:
        found: (E,) bool, a class explains the movement (False: its length fits no class).
        start: (E,) int32 its first frame.
        end: (E,) int32 its last frame.
        report: (E,) int32 the frame at which it was reported (end + W).
        label: (E,) int32 class (-1 if not found).
        phi: (E, d) φ of that class by `recognize` on the movement's frames (0 if not found).
        loglik: (E, K) log-likelihood of every class at its refined φ (-inf for a class whose paths
            cannot have the movement's length); never NaN.
    """

    found: Bool[np.ndarray, " E"]
    start: Int[np.ndarray, " E"]
    end: Int[np.ndarray, " E"]
    report: Int[np.ndarray, " E"]
    label: Int[np.ndarray, " E"]
    phi: Float[np.ndarray, "E d"]
    loglik: Float[np.ndarray, "E K"]



def _no_events(rec: OnlineRecognizer) -> OnlineEvents:
    d, k = rec.candidates.shape[1], rec.n_classes
    empty = np.zeros(0, np.int32)
    return OnlineEvents(np.zeros(0, bool), empty, empty, empty, empty, np.zeros((0, d), float_dtype()),
                        np.zeros((0, k), float_dtype()))


def _refine(rec: OnlineRecognizer, segment: np.ndarray, start: int, end: int, report: int) -> OnlineEvents:
    """One event from the movement's frames (L, D): `recognize` by the classes whose paths can have
    length L, on the segment padded to max_frames (one compiled shape)."""
    opts = rec.options
    n_frames = len(segment)
    fits = [k for k, p in enumerate(rec.phmms)
            if p.config.min_length <= n_frames and (p.config.max_length is None or n_frames <= p.config.max_length)]
    loglik = np.full(rec.n_classes, -np.inf, float_dtype())
    phi = np.zeros(rec.candidates.shape[1], float_dtype())
    label = -1
    if fits:
        padded = np.concatenate([segment, np.repeat(segment[-1:], opts.max_frames - n_frames, axis=0)])
        result = recognize([rec.phmms[k] for k in fits], padded[None], [n_frames], epsilon=opts.epsilon,
                           n_steps=opts.n_steps, lattice_points=opts.lattice_points, face_steps=opts.face_steps)
        values = np.asarray(result.loglik)[0]
        loglik[fits] = np.where(np.isfinite(values), values, -np.inf)
        if np.any(np.isfinite(values)):
            best = int(np.argmax(values))
            label, phi = fits[best], np.asarray(result.phi)[0, best].astype(float_dtype())
    found = label >= 0
    return OnlineEvents(np.array([found]), np.array([start], np.int32), np.array([end], np.int32),
                        np.array([report], np.int32), np.array([label], np.int32), phi[None], loglik[None])


def _concat(events: list[OnlineEvents], rec: OnlineRecognizer) -> OnlineEvents:
    if not events:
        return _no_events(rec)
    return OnlineEvents(*(np.concatenate(parts) for parts in zip(*events)))


def run_online(recognizer: OnlineRecognizer, stream: Float[ArrayLike, "T D"]) -> OnlineEvents:
    """Recognise the movements of a recorded stream, with class and parameter (BMVC §5.4, Humanoids §V).

    `online_scan` (lax.scan over the frames), then one `recognize` per detected movement on its
    frames (padded to max_frames: one compiled shape). A movement still running when the stream
    stops (or within W frames of its end) is not reported.

    Args:
        recognizer: From `online_recognizer`.
        stream: (T, D) the frames.

    Returns:
        `OnlineEvents` over the E movements found (E = 0: correctly shaped empty arrays).

    Raises:
        ValueError: Naming `recognizer` (not an OnlineRecognizer) or `stream` (empty, wrong D,
            NaN/inf, so far from the models' means that a log-density overflows).
    """
    rec = check_recognizer(recognizer)
    _, trace = online_scan(rec, stream)
    stream = np.asarray(stream, float_dtype())
    ended = np.flatnonzero(np.asarray(trace.ended))
    starts, ends = np.asarray(trace.start)[ended], np.asarray(trace.end)[ended]
    return _concat([_refine(rec, stream[s:e + 1], int(s), int(e), int(r)) for s, e, r in zip(starts, ends, ended)], rec)


class OnlineStream:
    """A live stream for the online recogniser (BMVC §5.4, Humanoids §V), fed one frame at a time.

    `push(x_t)` feeds one frame through the jitted `online_step` and returns the events reported at
    this frame; a movement is reported W frames after its end, so the latency is exactly W frames
    plus one `recognize` call. It reports the same events at the same frames as `run_online`.

    Args:
        recognizer: From `online_recognizer`.

    Attributes:
        recognizer: The `OnlineRecognizer`.
        state: The `OnlineState` after the frames pushed so far (public for live displays).
        last: The latest `OnlineFrame` (provisional class and φ while a movement runs), or None
            before the first frame.

    Raises:
        ValueError: Naming `recognizer`, when it is not an OnlineRecognizer.
    """

    def __init__(self, recognizer: OnlineRecognizer):
        self.recognizer = check_recognizer(recognizer)
        self.state = initial_online(self.recognizer)
        self.last: OnlineFrame | None = None
        self._bounds = recognizer_bounds(self.recognizer)

    def push(self, x_t: Float[ArrayLike, " D"]) -> OnlineEvents:
        """Feed one frame; return the movements reported at it.

        Args:
            x_t: (D,) the new frame.

        Returns:
            `OnlineEvents` with E = 0, or E = 1 when a movement ended W frames ago (its refinement
            by `recognize` runs inside this call).

        Raises:
            ValueError: Naming `x_t` (wrong shape, NaN/inf, too far from the models' means).
        """
        rec = self.recognizer
        x_t = check_frames(x_t, (rec.dim,), "x_t", None, self._bounds)
        self.state, self.last = online_step_jit(rec, self.state, x_t)
        if not bool(self.last.ended):
            return _no_events(rec)
        segment = np.asarray(self.state.frames)[: int(self.state.length)]
        return _refine(rec, segment, int(self.last.start), int(self.last.end), int(self.last.frame))
