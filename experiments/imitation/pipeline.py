"""One demonstration through the loop (issue 21, "The loop"): video -> the video front end (level sets
and α-β tracks of both views, the triangulated hand relative to the face; LEVELSET TR §3, LfD 2009
§III-C) -> the online PHMM recogniser (BMVC 2008 §5.4: streaming forward state, movement start and end,
class and parameter = the target on the table; Humanoids 2008 §III) -> the grasp moment and the
put-down from the hand's speed along the recognised movement -> the grasp class and hand orientation
from the hand image at the grasp moment (GRASP §III, eqs. 3-4) -> the robot grasp (MAP §III).

The PHMMs are trained on the kinematics of demonstrations of their own seed (no rendering): the hand
centre minus the face centre in world axes, from the frame the hand rises above the table top (where
the cameras first see it) to the frame it drops below it again; one PHMM "point" (pointing at an
object) and one "transfer" (reaching to the object, carrying it, returning), each over a 3 x 3 grid of
object positions. The tracked stream differs from the kinematics by a constant (the face blob
includes the neck; the hand blob's centroid is not the hand's centre of volume): that offset, the
PHMMs' observation noise and the detector's threshold are chosen on validation demonstrations.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import cv2
import jax
import numpy as np

import phmm_jax as P
from experiments.data import video
from experiments.imitation.config import Config
from experiments.imitation.demonstrations import (AREA_X, AREA_Y, DEMO_PACKAGES, KINDS, MIN_GAP_M, N_OBJECTS,
                                                  Demo, free, demo_track, table_z)
from experiments.lfd_demonstration.features import held
from lfd_common import Cache

_LO, _HI = np.array([AREA_X[0], AREA_Y[0]]), np.array([AREA_X[1], AREA_Y[1]])
GRID = (3, 3)


def camera_rotation(P_left: np.ndarray) -> np.ndarray:
    """(3, 3) world -> left camera rotation (x right, y down, z forward) of a camera matrix (3, 4)."""
    P_left = np.asarray(P_left, np.float64)
    if P_left.shape != (3, 4) or not np.isfinite(P_left).all():
        raise ValueError(f"P_left: expected a finite (3, 4) camera matrix, got {P_left.shape}")
    return cv2.decomposeProjectionMatrix(P_left)[1]


def phi_to_xy(phi: np.ndarray) -> np.ndarray:
    """PHMM parameters φ (..., 2) -> table positions (..., 2), world m (the grid spans the objects' area)."""
    return _LO + np.asarray(phi) * (_HI - _LO)


def xy_to_phi(xy: np.ndarray) -> np.ndarray:
    """The inverse of `phi_to_xy`."""
    return (np.asarray(xy, float) - _LO) / (_HI - _LO)


# ------------------------------------------------------------------------------------------ tracking
class Tracked(NamedTuple):
    """The front end's output for one recording: diff (T, 3) hand - face in world axes (m; 0 where not
    found), found (T,) tracked in both views, hand_rc (T, 2) the tracked hand in the left view (row,
    column), start (the first segmented frame)."""

    diff: np.ndarray
    found: np.ndarray
    hand_rc: np.ndarray
    start: int


# The rendering (the recording is a function of the settings and the demonstration) and the video front end
# of `experiments.lfd_demonstration.front` with what it imports.
TRACK_PACKAGES: tuple[str, ...] = DEMO_PACKAGES + (
    "experiments.imitation.pipeline", "experiments.imitation.config", "experiments.lfd_demonstration.front",
    "experiments.lfd_demonstration.features", "experiments.lfd_demonstration.config",
    "experiments.lfd_demonstration.evaluate", "experiments.video_segmentation", "experiments.peers",
    "experiments.data.cdnet", "hog_jax")
_TRACKS = Cache("imitation_tracks", packages=TRACK_PACKAGES)


def track(cfg: Config, settings, demo: Demo, rec: video.Recording, rgb_skin) -> Tracked:
    """The recording through the video front end of `experiments.lfd_demonstration` (cached per
    settings, demonstration, skin model, front-end settings and the source of `TRACK_PACKAGES`; `rec`,
    a function of the settings and the demonstration, stays out of the key)."""
    from experiments.lfd_demonstration.front import front_end, hand_tracks

    def run() -> Tracked:
        _, positions, start = front_end(rec, rgb_skin, settings, jax.random.key(cfg.seed + demo.seed % 100_000),
                                        cfg.pad_frames, cfg.coarse_scale, min_blob_area(cfg, rec.left.shape[1:3]))
        hand_l, _, _ = hand_tracks(positions, start)
        found = np.asarray(positions.found_3d, bool).copy()
        found[:start] = False
        rot = camera_rotation(rec.P_left)
        diff = np.where(found[:, None], np.asarray(positions.xyz, np.float64) @ rot, 0.0)  # R^T x per row
        return Tracked(diff.astype(np.float32), found, hand_l.astype(np.float32), int(start))

    fields = {k: getattr(cfg, k) for k in ("seed", "pad_frames", "coarse_scale", "min_blob_px_160")}
    return _TRACKS.get(run, settings=settings, demo=demo, rgb_skin=rgb_skin, cfg=fields)


def min_blob_area(cfg: Config, shape: tuple[int, int]) -> int:
    """`cfg.min_blob_px_160` scaled from a 160 x 120 frame to frames of `shape` (H, W)."""
    return max(1, round(cfg.min_blob_px_160 * shape[0] * shape[1] / (160 * 120)))


def median_filter(x: np.ndarray, width: int) -> np.ndarray:
    """Running median over `width` (odd) frames of x (T, D), edges repeated (spikes of the tracker)."""
    if width == 1:
        return x
    h = width // 2
    padded = np.concatenate([np.repeat(x[:1], h, 0), x, np.repeat(x[-1:], h, 0)])
    return np.median(np.lib.stride_tricks.sliding_window_view(padded, width, axis=0), axis=-1)


def plausible(t: Tracked, median_frames: int, reach_m: float = 1.0, jump_m: float = 0.15) -> np.ndarray:
    """(T,) the tracked frames kept: within `reach_m` of the face and below it by less than an arm
    (a wrong stereo match triangulates metres away), and within `jump_m` of the running median of
    the kept frames around them (single-frame swaps of hand and face blobs)."""
    d = t.diff.astype(np.float64)
    keep = t.found & (np.linalg.norm(d, axis=1) < reach_m) & (d[:, 2] < 0.3)
    if not keep.any():
        return keep
    smooth = median_filter(held(d, keep), max(median_frames, 5) | 1)
    return keep & (np.linalg.norm(d - smooth, axis=1) < jump_m)


def stream_of(t: Tracked, offset: np.ndarray, median_frames: int) -> np.ndarray:
    """The recogniser's input (T, 3): the tracked hand - face of the plausible frames (`plausible`),
    held where lost or rejected, spike-filtered, minus the tracker's offset from the kinematic
    features."""
    return median_filter(held(t.diff.astype(np.float64), plausible(t, median_frames)), median_frames) - offset


# ------------------------------------------------------------------------------------------ PHMMs
def kinematic_features(who, tr) -> tuple[np.ndarray, np.ndarray]:
    """(hand centre - face centre (T, 3) world, held where the hand is below the table top; visible (T,))
    of a `kinematics.Track` performed by `who`."""
    pose = tr.pose
    local = np.array([0.5 * who.look.hand.palm_length, 0.0, -0.01])
    hand = pose.r_wrist + pose.r_hand_rot @ local
    visible = hand[:, 2] > table_z()
    return held(hand - pose.trunk_pos, visible), visible


class _Actors:
    def __init__(self, settings):
        self.settings, self.cache = settings, {}

    def __call__(self, demo: Demo):
        if demo.person not in self.cache:
            self.cache[demo.person] = video.actor(self.settings, demo.person)
        who = self.cache[demo.person]
        rest = who.rest_pos.copy()
        rest[:, :2] = demo.objects_xy
        return who._replace(rest_pos=rest)


def demo_features(actors: _Actors, demo: Demo, settings) -> np.ndarray:
    """The kinematic features (L, 3) of the demonstration's visible frames (the movement as tracked)."""
    x, visible = kinematic_features(actors(demo), demo_track(actors(demo), demo, settings))
    idx = np.flatnonzero(visible)
    return x[idx[0]: idx[-1] + 1]


def training_demos(cfg: Config, kind: str, seed: int) -> list[list[Demo]]:
    """Per grid corner (C order) `train_repetitions` demonstrations of `kind` with the target object
    at the corner's position, other objects, persons, grasps and places random."""
    rng = np.random.default_rng([seed, 21, 9, KINDS.index(kind)])
    groups = []
    for xy in phi_to_xy(P.grid_points(GRID)):
        group = []
        for _ in range(cfg.train_repetitions):
            target = int(rng.integers(N_OBJECTS))
            places = np.zeros((N_OBJECTS, 2))
            places[target] = xy
            taken = xy[None]
            for k in range(N_OBJECTS):
                if k != target:
                    places[k] = free(rng, taken, MIN_GAP_M)
                    taken = np.vstack([taken, places[k]])
            grasp = int(rng.choice((1, 2, 4, 9, 10, 12))) if kind == "transfer" else -1
            place = free(rng, taken, MIN_GAP_M) if kind == "transfer" else np.asarray(cfg.handover_xy, float)
            group.append(Demo(kind, int(rng.integers(cfg.demonstrators)), int(rng.integers(1 << 30)), places, target,
                              grasp, place))
        groups.append(group)
    return groups


REACH = len(KINDS)  # `train_phmms`' list: the class PHMMs in `KINDS` order, then the reach PHMM


def reach_segment(x: np.ndarray) -> np.ndarray:
    """The reach (L, D) of a transfer's features x (T, D): up to its grasp moment (`grasp_and_putdown`)."""
    g, _ = grasp_and_putdown(x, np.ones(len(x), bool), 0, len(x) - 1)
    return x[: g + 1]


def _hmm_config(cfg: Config, sequences: list, slack: float) -> P.HMMConfig:
    longest, shortest = max(len(x) for x in sequences), min(len(x) for x in sequences)
    n_states = min(cfg.n_states, shortest)
    return P.HMMConfig(n_states=n_states, min_duration=1, max_duration=int(math.ceil(slack * longest / n_states)))


def train_phmms(cfg: Config, settings, seed: int) -> list[P.PHMM]:
    """One PHMM per kind (`KINDS` order) over the 3 x 3 grid, on kinematic features (module docstring),
    then the reach PHMM (index `REACH`) on the transfers' reaches (`reach_segment`): the target of a
    transfer is read from its reach alone, since the carry and the return depend on the place, not on
    the target (on validation kinematics of the paper preset: median target error 4.8 cm against 11.9
    cm from the whole transfer; README, issue 21). Longer paths are allowed for the reach (3x its
    longest training reach, as validated) since a detected movement may start early."""
    actors = _Actors(settings)
    data = {kind: [[demo_features(actors, d, settings) for d in group] for group in training_demos(cfg, kind, seed)]
            for kind in KINDS}
    config = _hmm_config(cfg, [x for groups in data.values() for g in groups for x in g], 1.6)
    options = P.FitOptions(max_iter=cfg.phmm_iter)
    reaches = [[reach_segment(x) for x in g] for g in data["transfer"]]
    reach = P.fit_phmm(reaches, GRID, _hmm_config(cfg, [x for g in reaches for x in g], 3.0), options=options)
    return [P.fit_phmm(data[kind], GRID, config, options=options) for kind in KINDS] + [reach]


def recognizer(phmms, sigma_m: float, threshold_m: float, window: int) -> P.OnlineRecognizer:
    """The online recogniser (BMVC §5.4) of the class PHMMs (`KINDS` order) with observation noise sigma_m (m)."""
    return P.online_recognizer([P.with_observation_noise(p, sigma_m ** 2) for p in phmms[:len(KINDS)]], threshold_m,
                               options=P.OnlineOptions(window=window))


def reach_target(reach_phmm: P.PHMM, segment: np.ndarray) -> np.ndarray | None:
    """The target (2,) of a reach (L, 3) by the reach PHMM (PHMM eq. 3; observation noise already in
    the model); None where the segment is shorter or longer than the model's paths."""
    c = reach_phmm.config
    if not c.min_length <= len(segment) <= c.max_length:
        return None
    res = P.recognize([reach_phmm], segment[None], [len(segment)])
    return phi_to_xy(np.asarray(res.phi)[0, 0].astype(float))


# ------------------------------------------------------------------------------------------ per demo
class Recognised(NamedTuple):
    """What the loop recognised in one demonstration. kind ("point" / "transfer", None: no movement),
    target_xy (2,) the PHMM's target (NaN if none), target (the nearest object, -1 if none), start / end
    of the movement (frames, -1), grasp_frame and putdown_frame (-1 for pointing), place_xy (2,) (the
    hand-over spot for pointing), grasp (a `GRASP_CLASSES` class, -1: none), grasp_quat (4,) (the hand's
    orientation relative to the camera, NaN if none), place_from ("scene": the object's own displacement in
    the video, `experiments.imitation.place`; "hand": the hand's; "" for pointing), target_phmm (the object
    nearest the PHMMs' target; `target` differs from it where the video shows another object moved),
    kind_phmm (the PHMMs' class; `kind` differs where the video shows an object moved, or none)."""

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


def movement(rec_online, stream: np.ndarray, merge_gap: int):
    """The demonstrated movement: the online detector's events (BMVC §5.4) that a class explains,
    merged where fewer than `merge_gap` frames lie between them (a pointing hold or a put-down ends a
    detected movement early; the PHMMs model the whole one), the merged frames recognised once more
    (class and φ, PHMM eq. 3). (kind, target (2,), start, end) or None if no movement is found."""
    events = P.run_online(rec_online, stream)
    ok = np.flatnonzero(events.found)
    if not ok.size:
        return None
    starts, ends = events.start[ok], events.end[ok]
    group = np.cumsum(np.r_[0, starts[1:] - ends[:-1] > merge_gap])
    lengths = np.bincount(group, weights=ends - starts + 1)
    best = int(np.argmax(lengths))
    s, e = int(starts[group == best].min()), int(ends[group == best].max())
    segment = stream[s:e + 1]
    longest = rec_online.options.max_frames
    if len(segment) > longest:  # longer than any path: the detector's longest event stands
        i = ok[np.argmax(ends - starts)]
        return KINDS[int(events.label[i])], phi_to_xy(np.asarray(events.phi[i], float)), int(starts.max()), int(e)
    padded = np.concatenate([segment, np.repeat(segment[-1:], longest - len(segment), axis=0)])
    res = P.recognize(list(rec_online.phmms), padded[None], [len(segment)])
    loglik = np.asarray(res.loglik)[0]
    k = int(np.argmax(np.where(np.isfinite(loglik), loglik, -np.inf)))
    return KINDS[k], phi_to_xy(np.asarray(res.phi)[0, k].astype(float)), s, e


def grasp_and_putdown(stream: np.ndarray, measured: np.ndarray, start: int, end: int) -> tuple[int, int]:
    """The grasp moment and the put-down of a transfer: the slowest measured frames of the hand (both
    it and the frame before tracked, not held) over the first half of the movement (the hand at the
    object) and over the rest before the return."""
    speed = np.r_[np.inf, np.linalg.norm(np.diff(stream, axis=0), axis=1)]
    speed = np.where(measured & np.r_[False, measured[:-1]], speed, np.inf)
    length = end - start + 1

    def slowest(a, b):
        a, b = int(start + a * length), max(int(start + b * length), int(start + a * length) + 1)
        return a + int(np.argmin(speed[a:b]))

    g = slowest(0.15, 0.55)
    p = slowest((g - start) / length + 0.15, 0.9)
    return g, p


def synthesised_reach(reach_phmm: P.PHMM, object_xy: np.ndarray, length: int = 50) -> np.ndarray:
    """The reach of a person to an object at `object_xy` (2,) world m: the reach PHMM's mean movement
    for that target (Humanoids 2008 §III synthesis, `phmm_jax.synthesize`), hand - face in world axes
    (length, 3) m. The robot's approach follows its shape (`sim.task_motion.retarget_path`)."""
    return np.asarray(P.synthesize(reach_phmm, xy_to_phi(object_xy), length), np.float64)


def recognise_demo(rec_online, tracked: Tracked, offset, median_frames: int, objects_xy: np.ndarray,
                   handover_xy, grasp=None, merge_gap: int = 10, reach_phmm: P.PHMM | None = None,
                   scene=None) -> Recognised:
    """Action, target, grasp moment, put-down and place of one tracked demonstration; `grasp`
    (frame index -> (class, quat)) recognises the hand at the grasp moment (None: not recognised);
    `reach_phmm` (with its observation noise) reads a transfer's target from its reach (`reach_target`;
    None: from the whole movement); `scene` ((start, end, objects_xy, target) -> `place.ScenePlace`,
    `place.place_reader`) reads which object moved and its place from the video: the object it shows
    moved replaces the PHMMs' target, and its displacement the hand's from the grasp moment to the
    put-down, each where the video decides (None: the PHMMs' target and the hand's displacement). A
    movement the PHMMs call a pointing is a transfer where the video shows an object moved (a pointing
    moves nothing), and one they call a transfer is a pointing where it shows none moved (`still`)."""
    objects_xy = np.asarray(objects_xy, float)
    if objects_xy.ndim != 2 or objects_xy.shape[1] != 2 or not np.isfinite(objects_xy).all():
        raise ValueError(f"objects_xy: expected finite (K, 2) table positions, got {objects_xy.shape}")
    nan2 = np.full(2, np.nan)
    if not plausible(tracked, median_frames).any():
        return Recognised(None, nan2, -1, -1, -1, -1, -1, nan2, -1, np.full(4, np.nan))
    stream = stream_of(tracked, offset, median_frames)
    found = movement(rec_online, stream, merge_gap)
    if found is None:
        return Recognised(None, nan2, -1, -1, -1, -1, -1, nan2, -1, np.full(4, np.nan))
    kind, xy, s, e = found
    kind_phmm = kind
    target = int(np.argmin(np.linalg.norm(objects_xy - xy, axis=1)))
    seen = scene(s, e, objects_xy, target) if scene is not None else None
    if seen is not None and seen.still:
        kind = "point"                   # a transfer moves an object: the video shows none moved
    if kind == "point" and (seen is None or seen.moved < 0):
        return Recognised(kind, xy, target, s, e, -1, -1, np.asarray(handover_xy, float), -1, np.full(4, np.nan), "",
                          target, kind_phmm)
    kind = "transfer"
    g, p = grasp_and_putdown(stream, plausible(tracked, median_frames), s, e)
    from_reach = None if reach_phmm is None else reach_target(reach_phmm, stream[s:g + 1])
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
