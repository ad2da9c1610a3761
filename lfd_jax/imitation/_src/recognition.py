"""The demonstrated movement recognised from the tracked stream: the online PHMM recogniser's events
(PHMM, Herzog et al. 2008, BMVC §5.4: a streaming forward state per class, the movement's start and
end, class and parameter; Humanoids §III), the target on the table, the grasp moment and the put-down
from the hand's speed, and the object moved and its place where the video shows them (`place`)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

import phmm_jax as P
from lfd_jax.imitation._src.area import TableArea, phi_to_xy, xy_to_phi
from lfd_jax.imitation._src.tracked import Tracked, plausible, stream_of

KINDS: tuple[str, ...] = ("point", "transfer")  # the recognised actions, in the class PHMMs' order


def recognizer(phmms, sigma_m: float, threshold_m: float, window: int) -> P.OnlineRecognizer:
    """The online recogniser of the class PHMMs (PHMM, BMVC §5.4).

    Args:
        phmms: the PHMMs, the class ones first in `KINDS` order (later ones, e.g. a reach PHMM, are left
            out).
        sigma_m: observation noise (m) added to every PHMM's states.
        threshold_m: the hand's displacement over the window that starts a movement (m).
        window: the detector's look-ahead (frames).

    Returns:
        The `phmm_jax.OnlineRecognizer`.

    Raises:
        ValueError: fewer PHMMs than `KINDS`.
    """
    if len(phmms) < len(KINDS):
        raise ValueError(f"phmms: expected at least {len(KINDS)} PHMMs ({KINDS} order), got {len(phmms)}")
    return P.online_recognizer([P.with_observation_noise(p, sigma_m ** 2) for p in phmms[:len(KINDS)]], threshold_m,
                               options=P.OnlineOptions(window=window))


def grasp_and_putdown(stream: np.ndarray, measured: np.ndarray, start: int, end: int) -> tuple[int, int]:
    """The grasp moment and the put-down of a transfer (LFD §III-D: pick-up and put-down frames).

    The slowest measured frames of the hand (both it and the frame before tracked, not held) over the
    first half of the movement (the hand at the object) and over the rest before the return.

    Args:
        stream: (T, D) the hand's positions.
        measured: (T,) bool, the frames actually tracked.
        start: the movement's first frame.
        end: the movement's last frame.

    Returns:
        (grasp frame, put-down frame).

    Raises:
        ValueError: `measured` does not match `stream`, or `start` or `end` is not one of its frames.
    """
    if len(measured) != len(stream):
        raise ValueError(f"measured: expected {len(stream)} frames as stream, got {len(measured)}")
    for name, frame in (("start", start), ("end", end)):
        if not 0 <= frame < len(stream):
            raise ValueError(f"{name}: expected a frame of stream (0-{len(stream) - 1}), got {frame}")
    speed = np.r_[np.inf, np.linalg.norm(np.diff(stream, axis=0), axis=1)]
    speed = np.where(measured & np.r_[False, measured[:-1]], speed, np.inf)
    length = end - start + 1

    def slowest(a, b):
        a, b = int(start + a * length), max(int(start + b * length), int(start + a * length) + 1)
        return a + int(np.argmin(speed[a:b]))

    g = slowest(0.15, 0.55)
    p = slowest((g - start) / length + 0.15, 0.9)
    return g, p


def reach_segment(x: np.ndarray) -> np.ndarray:
    """The reach of a transfer: its features up to the grasp moment (`grasp_and_putdown`).

    The reach PHMM is trained on these (PHMM, Humanoids 2008: the robot reaches along the part of the
    movement before the grasp).

    Args:
        x: (T, D) a transfer's features.

    Returns:
        (L, D) its first L frames.
    """
    g, _ = grasp_and_putdown(x, np.ones(len(x), bool), 0, len(x) - 1)
    return x[: g + 1]


def _padded(segment: np.ndarray, length: int) -> np.ndarray:
    """(L, D) `segment` repeated at its last frame to (length, D): one compiled recognition for every
    segment length (the recognition's `lengths` mask the repeats out)."""
    return np.concatenate([segment, np.repeat(segment[-1:], length - len(segment), axis=0)])


def likeliest_object(phmm: P.PHMM, segment: np.ndarray, objects_xy: np.ndarray, longest: int,
                     area: TableArea = TableArea()) -> int:
    """The object at whose parameter the PHMM explains a movement best (PHMM eq. 3's likelihood at the known
    candidates: the MAP object under a uniform prior). Where the objects are known, this compares the
    likelihood at each of them instead of taking the object nearest the continuous maximum, whose φ a
    likelihood flat along one direction leaves far off.

    Args:
        phmm: the movement's class PHMM, its observation noise already in the model.
        segment: (L, 3) the movement, L >= 1.
        objects_xy: (K, 2) where the objects stand, world m.
        longest: the length the segment is padded to (one compilation for every length).
        area: the table rectangle the PHMM's grid spans.

    Returns:
        The index of the likeliest object.
    """
    k = len(objects_xy)
    x = np.repeat(_padded(segment, max(longest, len(segment)))[None], k, axis=0)
    loglik = np.asarray(P.phmm_log_likelihood(phmm, x, xy_to_phi(objects_xy, area), np.full(k, len(segment))))
    return int(np.argmax(np.where(np.isfinite(loglik), loglik, -np.inf)))


def reach_target(reach_phmm: P.PHMM, segment: np.ndarray, area: TableArea = TableArea()) -> np.ndarray | None:
    """The target of a reach by the reach PHMM (PHMM eq. 3, Humanoids §III).

    Args:
        reach_phmm: the reach PHMM, its observation noise already in the model.
        segment: (L, 3) the reach.
        area: the table rectangle the PHMM's grid spans.

    Returns:
        (2,) the target, world m; None where the segment is shorter or longer than the model's paths.
    """
    c = reach_phmm.config
    if not c.min_length <= len(segment) <= c.max_length:
        return None
    res = P.recognize([reach_phmm], _padded(segment, c.max_length)[None], [len(segment)])
    return phi_to_xy(np.asarray(res.phi)[0, 0].astype(float), area)


class Recognised(NamedTuple):
    """What the pipeline recognised in one demonstration (PHMM BMVC §5.4; LFD §III; MAP §III).

    Attributes:
        kind: "point" / "transfer"; None: no movement.
        target_xy: (2,) the PHMMs' target (NaN if none).
        target: the object recognised (-1 if none): for a pointing the object at whose parameter the
            pointing PHMM finds the movement likeliest (`likeliest_object`), for a transfer the nearest
            to the PHMMs' target.
        start: the movement's first frame (-1).
        end: its last frame (-1).
        grasp_frame: the grasp moment (-1 for pointing).
        putdown_frame: the put-down (-1 for pointing).
        place_xy: (2,) the place (the hand-over spot for pointing).
        grasp: a `sim.grasping.GRASP_CLASSES` class (-1: none).
        grasp_quat: (4,) the hand's orientation relative to the camera (NaN if none).
        place_from: "scene": the object's own displacement in the video (`scene_place`); "hand": the
            hand's; "" for pointing.
        target_phmm: the PHMMs' object, as `target` (`target` differs from it where the video shows
            another object moved).
        kind_phmm: the PHMMs' class (`kind` differs where the video shows an object moved, or none).
    """

    kind: str | None
    target_xy: np.ndarray
    target: int
    start: int
    end: int
    grasp_frame: int
    putdown_frame: int
    place_xy: np.ndarray
    grasp: int
    grasp_quat: np.ndarray
    place_from: str = ""
    target_phmm: int = -1
    kind_phmm: str | None = None


def _running_at_end(rec_online, stream: np.ndarray, measured: np.ndarray | None) -> tuple[int, int] | None:
    """(start, end) of the movement the detector still follows when the stream stops, ended at the last
    measured frame (a recording stops with the demonstration: the hand need not settle in view before it
    does); None where none runs or it is shorter than any class's paths. Never longer than `max_frames`."""
    state, _ = P.online_scan(rec_online, stream)
    if not bool(state.moving):
        return None
    start = int(state.start)
    last = len(stream) - 1 if measured is None or not measured.any() else int(np.flatnonzero(measured)[-1])
    end = min(last, start + rec_online.options.max_frames - 1)
    return (start, end) if end - start + 1 >= rec_online.min_frames else None


def movement(rec_online, stream: np.ndarray, merge_gap: int, area: TableArea = TableArea(),
             measured: np.ndarray | None = None):
    """The demonstrated movement in a stream (PHMM, BMVC §5.4 online detection; eq. 3 recognition).

    The online detector's events that a class explains, merged where fewer than `merge_gap` measured
    frames lie between them (a pointing hold or a put-down ends a detected movement early, and so does
    a hand lost behind the object it carries: the PHMMs model the whole movement, and only a measured
    frame shows the hand at rest), the merged frames recognised once more (class and φ). A movement still
    under way when the stream stops (the detector ends one only after the hand has been still for its
    window) counts as ended at the last measured frame.

    Args:
        rec_online: the `recognizer`.
        stream: (T, 3) the recogniser's input (`stream_of`).
        merge_gap: the largest gap (measured frames) between events merged into one movement.
        area: the table rectangle the PHMMs' grid spans.
        measured: (T,) bool, the frames actually tracked (`plausible`); None: every frame.

    Returns:
        (kind, target (2,) world m, start, end), or None if no movement is found.

    Raises:
        ValueError: `measured` does not match `stream`.
    """
    if measured is not None:
        measured = np.asarray(measured, bool)
        if measured.shape != (len(stream),):
            raise ValueError(f"measured: expected ({len(stream)},) flags as stream's frames, got {measured.shape}")
    events = P.run_online(rec_online, stream)
    ok = np.flatnonzero(events.found)
    starts, ends = events.start[ok], events.end[ok]
    running = _running_at_end(rec_online, stream, measured)
    if running is not None:
        starts, ends = np.r_[starts, running[0]], np.r_[ends, running[1]]
    if not starts.size:
        return None
    seen = np.cumsum(np.r_[0, np.ones(len(stream), int) if measured is None else measured])  # measured before f
    between = seen[starts[1:]] - seen[np.minimum(ends[:-1] + 1, len(stream))]  # measured frames between events
    group = np.cumsum(np.r_[0, between >= merge_gap])
    lengths = np.bincount(group, weights=ends - starts + 1)
    best = int(np.argmax(lengths))
    s, e = int(starts[group == best].min()), int(ends[group == best].max())
    segment = stream[s:e + 1]
    longest = rec_online.options.max_frames
    if len(segment) > longest:  # longer than any path: the detector's longest event stands
        n = len(ok)  # the detector's own events (a running movement alone is no longer than a path)
        i = ok[np.argmax(ends[:n] - starts[:n])]
        xy = phi_to_xy(np.asarray(events.phi[i], float), area)
        return KINDS[int(events.label[i])], xy, int(starts[:n].max()), int(e)
    res = P.recognize(list(rec_online.phmms), _padded(segment, longest)[None], [len(segment)])
    loglik = np.asarray(res.loglik)[0]
    k = int(np.argmax(np.where(np.isfinite(loglik), loglik, -np.inf)))
    return KINDS[k], phi_to_xy(np.asarray(res.phi)[0, k].astype(float), area), s, e


def recognise_demo(rec_online, tracked: Tracked, offset, median_frames: int, objects_xy: np.ndarray,
                   handover_xy, grasp=None, merge_gap: int = 10, reach_phmm: P.PHMM | None = None,
                   scene=None, area: TableArea = TableArea()) -> Recognised:
    """Action, target, grasp moment, put-down and place of one tracked demonstration (PHMM BMVC §5.4,
    Humanoids §III; LFD §III; the grasp by MAP §III).

    A movement the PHMMs call a pointing is a transfer where the video shows an object moved (a
    pointing moves nothing), and one they call a transfer is a pointing where it shows none moved
    (`ScenePlace.still`). The object the video shows moved replaces the PHMMs' target, and its
    displacement the hand's from the grasp moment to the put-down, each where the video decides.

    Args:
        rec_online: the online recogniser (`recognizer`).
        tracked: the tracked recording.
        offset: (3,) the tracker's offset from the PHMMs' training features (m).
        median_frames: the spike filter's window (odd frames).
        objects_xy: (K, 2) where the objects stand, world m.
        handover_xy: (2,) the hand-over spot (a pointing's place).
        grasp: frame index -> (class, quaternion (4,)) recognising the hand at the grasp moment; None:
            not recognised.
        merge_gap: `movement`'s merge gap (frames).
        reach_phmm: the reach PHMM with its observation noise, reading a transfer's target from its
            reach (`reach_target`); None: from the whole movement.
        scene: (start, end, objects_xy, target) -> `ScenePlace` (`place_reader`), which object moved and
            its place from the video; None: the PHMMs' target and the hand's displacement.
        area: the table rectangle the PHMMs' grid spans.

    Returns:
        The `Recognised`.

    Raises:
        ValueError: `objects_xy` is not a finite (K, 2) array.
    """
    objects_xy = np.asarray(objects_xy, float)
    if objects_xy.ndim != 2 or objects_xy.shape[1] != 2 or not np.isfinite(objects_xy).all():
        raise ValueError(f"objects_xy: expected finite (K, 2) table positions, got {objects_xy.shape}")
    nan2 = np.full(2, np.nan)
    measured = plausible(tracked, median_frames)
    if not measured.any():
        return Recognised(None, nan2, -1, -1, -1, -1, -1, nan2, -1, np.full(4, np.nan))
    stream = stream_of(tracked, offset, median_frames)
    found = movement(rec_online, stream, merge_gap, area, measured)
    if found is None:
        return Recognised(None, nan2, -1, -1, -1, -1, -1, nan2, -1, np.full(4, np.nan))
    kind, xy, s, e = found
    kind_phmm = kind
    target = int(np.argmin(np.linalg.norm(objects_xy - xy, axis=1)))
    seen = scene(s, e, objects_xy, target) if scene is not None else None
    if seen is not None and seen.still:
        kind = "point"                   # a transfer moves an object: the video shows none moved
    if kind == "point" and (seen is None or seen.moved < 0):
        target = likeliest_object(rec_online.phmms[KINDS.index("point")], stream[s:e + 1], objects_xy,
                                  rec_online.options.max_frames, area)
        return Recognised(kind, xy, target, s, e, -1, -1, np.asarray(handover_xy, float), -1, np.full(4, np.nan), "",
                          target, kind_phmm)
    kind = "transfer"
    g, p = grasp_and_putdown(stream, measured, s, e)
    from_reach = None if reach_phmm is None else reach_target(reach_phmm, stream[s:g + 1], area)
    if from_reach is not None:
        xy, guessed = from_reach, target
        target = int(np.argmin(np.linalg.norm(objects_xy - xy, axis=1)))
        if seen is not None and seen.moved < 0 and target != guessed:   # not decided: the new guess is looked for
            seen = scene(s, e, objects_xy, target)
    by_phmm = target
    if seen is not None and seen.moved >= 0:
        target = seen.moved
    place, place_from = objects_xy[target] + (stream[p, :2] - stream[g, :2]), "hand"
    if seen is not None and seen.found:
        place, place_from = seen.xy, "scene"
    cls, quat = grasp(g) if grasp is not None else (-1, np.full(4, np.nan))
    return Recognised(kind, xy, target, s, e, g, p, place, int(cls), np.asarray(quat, float), place_from, by_phmm,
                      kind_phmm)
