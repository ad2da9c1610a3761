"""The study's side of one demonstration through the loop: the recordings through the video front end
(`track`: level sets and α-β tracks of both views, the triangulated hand relative to the face; LEVELSET
TR §3, LfD 2009 §III-C) and the PHMMs trained on simulated demonstrations (`train_phmms`). The steps a
user runs on their own recordings (the online PHMM recogniser, BMVC 2008 §5.4; the grasp moment, the
put-down and the place; the robot's task, MAP §III) are `lfd_jax.imitation`.

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

import jax
import numpy as np

import phmm_jax as P
from experiments.data import video
from experiments.imitation.config import Config
from experiments.imitation.demonstrations import (AREA_X, AREA_Y, DEMO_PACKAGES, KINDS, MIN_GAP_M, N_OBJECTS,
                                                  Demo, free, demo_track, table_z)
from hog_jax.video import held
from lfd_common import Cache
from lfd_jax.imitation import TableArea, Tracked, camera_rotation, phi_to_xy, reach_segment

AREA = TableArea(AREA_X, AREA_Y)  # the demonstrations' objects' area: the PHMMs' grid spans it
GRID = (3, 3)


# ------------------------------------------------------------------------------------------ tracking
# The rendering (the recording is a function of the settings and the demonstration), this module, the tracked
# stream's module of `lfd_jax.imitation` (`Tracked`, `camera_rotation`; not the recognition and the place, so
# that changing them keeps the tracks), and the video front end (`hog_jax.video.front_end`).
TRACK_PACKAGES: tuple[str, ...] = DEMO_PACKAGES + (
    "experiments.imitation.pipeline", "experiments.imitation.config", "lfd_jax.imitation._src.tracked", "hog_jax")
_TRACKS = Cache("imitation_tracks", packages=TRACK_PACKAGES)


def track(cfg: Config, settings, demo: Demo, rec: video.Recording, skin_model) -> Tracked:
    """The recording through the video front end (`hog_jax.video.front_end`; cached per
    settings, demonstration, skin model, front-end settings and the source of `TRACK_PACKAGES`; `rec`,
    a function of the settings and the demonstration, stays out of the key)."""
    from hog_jax.video import (BackgroundOptions, HandFaceOptions, TrackOptions, VideoOptions, front_end,
                               stereo_camera_from_matrices)

    def run() -> Tracked:
        start = video.segmentation_start(settings)
        camera = stereo_camera_from_matrices(rec.P_left, rec.P_right, *rec.left.shape[1:3])
        out = front_end(jax.random.key(cfg.seed + demo.seed % 100_000), skin_model, rec.left, rec.right, start, camera,
                        VideoOptions(background=BackgroundOptions.for_fps(settings.fps), coarse_scale=cfg.coarse_scale),
                        HandFaceOptions(min_area=min_blob_area(cfg, rec.left.shape[1:3]),
                                        # tracking starts on the face and one more blob: the other hand can stay
                                        # out of view, and the side rules keep it off the right hand's target
                                        # (validation demonstrations: 2 of 36 never tracked with 3, none worse)
                                        tracking=TrackOptions(min_init=2)), pad_multiple=cfg.pad_frames)
        positions, hand_l = out.positions, out.hand_left
        found = np.asarray(positions.found_3d, bool).copy()
        found[:start] = False
        rot = camera_rotation(rec.P_left)
        diff = np.where(found[:, None], np.asarray(positions.xyz, np.float64) @ rot, 0.0)  # R^T x per row
        return Tracked(diff.astype(np.float32), found, hand_l.astype(np.float32), int(start))

    fields = {k: getattr(cfg, k) for k in ("seed", "pad_frames", "coarse_scale", "min_blob_px_160")}
    return _TRACKS.get(run, settings=settings, demo=demo, skin_model=skin_model, cfg=fields)


def min_blob_area(cfg: Config, shape: tuple[int, int]) -> int:
    """`cfg.min_blob_px_160` scaled from a 160 x 120 frame to frames of `shape` (H, W)."""
    return max(1, round(cfg.min_blob_px_160 * shape[0] * shape[1] / (160 * 120)))


# ------------------------------------------------------------------------------------------ PHMMs
def kinematic_features(who, tr) -> tuple[np.ndarray, np.ndarray]:
    """(hand centre - face centre (T, 3) world, held where the hand is below the table top; visible (T,))
    of a `kinematics.Track` performed by `who`."""
    pose = tr.pose
    local = np.array([0.5 * who.look.hand.palm_length, 0.0, -0.01])
    hand = pose.r_wrist + pose.r_hand_rot @ local
    visible = hand[:, 2] > table_z()
    return held(hand - pose.trunk_pos, visible), visible


class Actors:
    """The demonstrations' actors (`experiments.data.video.actor`, one per person, made when first
    needed): called with a `Demo`, its person with the objects standing at the demonstration's places."""

    def __init__(self, settings):
        self.settings, self.cache = settings, {}

    def __call__(self, demo: Demo):
        if demo.person not in self.cache:
            self.cache[demo.person] = video.actor(self.settings, demo.person)
        who = self.cache[demo.person]
        rest = who.rest_pos.copy()
        rest[:, :2] = demo.objects_xy
        return who._replace(rest_pos=rest)


def demo_features(actors: Actors, demo: Demo, settings) -> np.ndarray:
    """The kinematic features (L, 3) of the demonstration's visible frames (the movement as tracked)."""
    x, visible = kinematic_features(actors(demo), demo_track(actors(demo), demo, settings))
    idx = np.flatnonzero(visible)
    return x[idx[0]: idx[-1] + 1]


def training_demos(cfg: Config, kind: str, seed: int) -> list[list[Demo]]:
    """Per grid corner (C order) `train_repetitions` demonstrations of `kind` with the target object
    at the corner's position, other objects, persons, grasps and places random."""
    rng = np.random.default_rng([seed, 21, 9, KINDS.index(kind)])
    groups = []
    for xy in phi_to_xy(P.grid_points(GRID), AREA):
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


def _hmm_config(cfg: Config, sequences: list, slack: float) -> P.HMMConfig:
    longest, shortest = max(len(x) for x in sequences), min(len(x) for x in sequences)
    n_states = min(cfg.n_states, shortest)
    return P.HMMConfig(n_states=n_states, min_duration=1, max_duration=int(math.ceil(slack * longest / n_states)))


def train_phmms(cfg: Config, settings, seed: int) -> list[P.PHMM]:
    """One PHMM per kind (`KINDS` order) over the 3 x 3 grid, on kinematic features (module docstring),
    then the reach PHMM (index `REACH`) on the transfers' reaches (`reach_segment`): the target of a
    transfer is read from its reach alone, since the carry and the return depend on the place, not on
    the target (on validation kinematics of the paper preset: median target error 4.8 cm against 11.9
    cm from the whole transfer). Longer paths are allowed for the reach (3x its longest training
    reach, as validated) since a detected movement may start early."""
    actors = Actors(settings)
    data = {kind: [[demo_features(actors, d, settings) for d in group] for group in training_demos(cfg, kind, seed)]
            for kind in KINDS}
    config = _hmm_config(cfg, [x for groups in data.values() for g in groups for x in g], 1.6)
    options = P.FitOptions(max_iter=cfg.phmm_iter)
    reaches = [[reach_segment(x) for x in g] for g in data["transfer"]]
    reach = P.fit_phmm(reaches, GRID, _hmm_config(cfg, [x for g in reaches for x in g], 3.0), options=options)
    return [P.fit_phmm(data[kind], GRID, config, options=options) for kind in KINDS] + [reach]
