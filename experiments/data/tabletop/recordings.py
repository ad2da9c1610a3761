"""Batches of recordings: occlusion and gap filling, stacking, resampling, the study protocol."""
from __future__ import annotations

import numpy as np

from lfd_common import as_array, cached, check_int
from experiments.data.tabletop.subjects import (ACTIONS, FRAME_RATE_HZ, MARKERS, Recordings, TABLE_EDGE_Y,
                                                TABLE_HEIGHT_M, raster_targets, sample_subject)
from experiments.data.tabletop.movement import simulate_movement


def table_penetration(recordings: Recordings) -> np.ndarray:
    """Deepest point (B,) in metres of any arm or hand marker (elbow to thumb) inside the table
    (beyond its near edge, below its top); 0 when the movement stays clear."""
    arm = recordings.markers[:, :, 2:]
    valid = (np.arange(arm.shape[1]) < recordings.lengths[:, None])[:, :, None]
    depth = np.where(valid & (arm[..., 1] > TABLE_EDGE_Y), TABLE_HEIGHT_M - arm[..., 2], 0.0)
    return np.maximum(depth.reshape(len(depth), -1).max(1), 0.0)


def stack_recordings(movements, action, target, frame_rate=FRAME_RATE_HZ, marker_names=MARKERS) -> Recordings:
    """A `Recordings` batch from a list of (T_b, M, 3) movements, action indices (B,), targets (B, 3)."""
    if len(movements) == 0:
        raise ValueError("movements: need at least one movement")
    lengths = np.array([len(m) for m in movements])
    padded = np.stack([np.concatenate([m, np.repeat(m[-1:], lengths.max() - len(m), 0)]) for m in movements])
    return Recordings(padded, lengths, np.asarray(action, int), np.asarray(target, float).reshape(-1, 3),
                      float(frame_rate), tuple(marker_names))


def simulate(rng: np.random.Generator, subjects, targets, repetitions: int, action: str,
             **settings) -> Recordings:
    """`repetitions` movements to every target (K, 3) by each of the subjects, in order target-major:
    index = (k * repetitions + r); repetition r is by subject r % len(subjects). `settings` go to
    `simulate_movement`."""
    targets = as_array(targets, "targets").reshape(-1, 3)
    repetitions = check_int(repetitions, "repetitions", min_value=1)
    moves = [simulate_movement(rng, subjects[r % len(subjects)], t, action, **settings)
             for t in targets for r in range(repetitions)]
    return stack_recordings(moves, np.full(len(moves), ACTIONS.index(action)),
                            np.repeat(targets, repetitions, axis=0))


def concatenate(recordings) -> Recordings:
    """One `Recordings` from several (same frame rate and markers)."""
    recordings = list(recordings)
    moves = [r.markers[b, :r.lengths[b]] for r in recordings for b in range(len(r.lengths))]
    return stack_recordings(moves, np.concatenate([r.action for r in recordings]),
                            np.concatenate([r.target for r in recordings]), recordings[0].frame_rate,
                            recordings[0].marker_names)


def resample(recordings: Recordings, n_samples: int = 100) -> np.ndarray:
    """Every movement linearly resampled in time to `n_samples` frames: (B, n_samples, 3 M) features
    (the markers stacked, PHMM papers: "sequences normalised to 100 samples")."""
    n_samples = check_int(n_samples, "n_samples", min_value=2)
    markers, lengths = recordings.markers, recordings.lengths
    pos = np.linspace(0.0, 1.0, n_samples)[None, :] * (lengths[:, None] - 1)  # (B, S)
    lo = np.floor(pos).astype(int)
    hi = np.minimum(lo + 1, lengths[:, None] - 1)
    frac = (pos - lo)[..., None, None]
    rows = np.arange(len(lengths))[:, None]
    out = (1 - frac) * markers[rows, lo] + frac * markers[rows, hi]
    return out.reshape(len(lengths), n_samples, -1)


# --------------------------------------------------------------------------------------------------
# Data sets for the protocol, cached

@cached("phmm_tabletop", packages=("experiments.data.tabletop", "lfd_common"), switch="use_cache")
def protocol_data(seed: int, train_raster=(3, 3), train_repetitions: int = 10, test_raster=(5, 7),
                  test_repetitions: int = 4, n_subjects: int = 1, endpoint_sd_m: float = 0.012,
                  marker_noise_m: float = 0.002, drop_rate: float = 0.3, use_cache: bool = True):
    """Training and test recordings of both actions (train, test), each a `Recordings` with the
    actions concatenated (reaching first), target-major within an action. Cached under
    `cache_dir("phmm_tabletop")` keyed by every argument and the source of the simulator (this package)
    and of `lfd_common`; `use_cache=False` computes without reading or writing."""
    rng = np.random.default_rng(seed)
    subjects = [sample_subject(rng) for _ in range(check_int(n_subjects, "n_subjects", min_value=1))]
    kw = dict(endpoint_sd_m=endpoint_sd_m, marker_noise_m=marker_noise_m, drop_rate=drop_rate)
    out = []
    for raster, reps in ((train_raster, train_repetitions), (test_raster, test_repetitions)):
        targets = raster_targets(*raster)
        out.append(concatenate([simulate(rng, subjects, targets, reps, a, **kw) for a in ACTIONS]))
    return tuple(out)


# --------------------------------------------------------------------------------------------------
# Real recordings
