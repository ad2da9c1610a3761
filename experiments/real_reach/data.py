"""The study's data: every movement of a reach-to-grasp npz as per-frame hand features over the whole
recording, with the annotated reach (onset, contact) as frame indices.

Features per frame (`FEATURES`): the wrist position, the thumb, index and middle finger tips
relative to the wrist, and two grip apertures (thumb tip – index tip and thumb tip – middle tip
distances), from the OpenPose keypoints after short gaps are filled (`lfd_jax.fill_track_gaps`). The
middle finger matters: one of the four persons opens thumb and index alike for every size and scales
the grip with the middle finger. Versions (`NORMALISATIONS`):

* `pixels`: image pixels as the camera gives them (the wrist at its absolute position);
* `person`: per movement, the wrist relative to its position at the reach's onset (the resting pose)
  in shoulder widths (median Neck–RShoulder distance over the frames up to the onset), the fingers in
  hand lengths (median RPalmBase–RMiddle1Knuckles distance over the same frames) — person-specific
  offsets and scales removed with what is known when the reach starts;
* `calibrated`: the `person` features z-scored per person with the mean and deviation of all that
  person's reach frames (`calibrate`): an explicit offset and scale per feature and person, read off
  the person's unlabelled reaches — a calibration set, which a new person must give first, and which
  here holds the three sizes in equal shares.

The event streams use their own causal features (`event_features`): the wrist's displacement from
the recording's first frame and its speed, in shoulder widths.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

import lfd_jax as loaders

NPZ_NAME = "reach_grasp_openpose_p1-4.npz"
SIZES = ("S", "M", "L")
SIZE_CM = np.array([2.5, 5.5, 7.5])
KEYPOINTS = ("Neck", "RShoulder", "RWrist", "RThumb4FingerTip", "RIndex4FingerTip", "RMiddle4FingerTip",
             "RPalmBase", "RMiddle1Knuckles")
FEATURES = ("wrist_x", "wrist_y", "thumb_x", "thumb_y", "index_x", "index_y", "middle_x", "middle_y",
            "aperture", "aperture_middle")
APERTURES = (FEATURES.index("aperture"), FEATURES.index("aperture_middle"))
NORMALISATIONS = ("pixels", "person", "calibrated")


class Movement(NamedTuple):
    """One recorded movement: keypoints (T, 8, 2) of `KEYPOINTS` in pixels, gaps filled; onset and
    contact frame indices (the first and last frames of the first run of frames between the annotated
    onset and end); the size class (index into `SIZES`); the person; the name."""

    keypoints: np.ndarray
    onset: int
    contact: int
    size: int
    person: int
    name: str


def npz_path(data: Path) -> Path:
    """The npz inside a reach-grasp folder (or the file itself)."""
    data = Path(data)
    return data if data.suffix == ".npz" else data / NPZ_NAME


def _movement(m: loaders.ReachMovement, max_gap_s: float) -> Movement:
    tracks = loaders.select_keypoints(m.tracks, KEYPOINTS)
    try:
        tracks = loaders.fill_track_gaps(tracks, max_gap_s)
    except ValueError:  # a longer gap (a few movements): filled all the same, a straight line across
        tracks = loaders.fill_track_gaps(tracks, max_gap_frames=len(tracks.xy))
    t = tracks.time_s
    inside = (t >= m.onset_s) & (t <= m.end_s)
    onset = int(np.argmax(inside))
    # the first run of frames inside the phase: one recording's last frame has a broken time stamp
    # (far negative) that would otherwise count as inside
    run = np.argmin(inside[onset:]) if not inside[onset:].all() else len(t) - onset
    contact = onset + int(run) - 1
    return Movement(tracks.xy, onset, max(contact, onset + 1), SIZES.index(m.size), m.participant, m.name)


def load_movements(data: Path, n_persons: int | None = None, max_gap_s: float = 0.2,
                   per_class: int | None = None) -> list[Movement]:
    """The movements of the npz under `data` (the first `n_persons` persons, the first `per_class`
    movements of each person and size when given)."""
    movements = [_movement(m, max_gap_s) for m in loaders.load_reach_npz(npz_path(data))]
    persons = sorted({m.person for m in movements})[:n_persons]
    out, seen = [], {}
    for m in movements:
        key = (m.person, m.size)
        if m.person in persons and (per_class is None or seen.get(key, 0) < per_class):
            seen[key] = seen.get(key, 0) + 1
            out.append(m)
    return out


def _resting_length(m: Movement, a: int, b: int) -> float:
    k = m.keypoints[:m.onset + 1]
    return float(np.median(np.linalg.norm(k[:, b] - k[:, a], axis=-1)))


def shoulder_width(m: Movement) -> float:
    """Median Neck–RShoulder distance (pixels) over the frames up to the onset."""
    return _resting_length(m, 0, 1)


def hand_length(m: Movement) -> float:
    """Median RPalmBase–RMiddle1Knuckles distance (pixels) over the frames up to the onset."""
    return _resting_length(m, 6, 7)


def reach_features(m: Movement, normalisation: str) -> np.ndarray:
    """(L, 10) `FEATURES` over the reach (onset..contact inclusive), in pixels or person units (the
    `calibrated` version is `calibrate` of the person units over a person's reaches)."""
    if normalisation not in NORMALISATIONS:
        raise ValueError(f"normalisation: one of {NORMALISATIONS}, got {normalisation!r}")
    k = m.keypoints[m.onset:m.contact + 1]
    wrist = k[:, 2]
    tips = [k[:, j] - wrist for j in (3, 4, 5)]
    apertures = [np.linalg.norm(k[:, 3] - k[:, j], axis=-1)[:, None] for j in (4, 5)]
    if normalisation == "pixels":
        return np.concatenate([wrist, *tips, *apertures], axis=1)
    hand = np.concatenate([*tips, *apertures], axis=1) / hand_length(m)
    return np.concatenate([(wrist - wrist[:1]) / shoulder_width(m), hand], axis=1)


def calibrate(seqs: list[np.ndarray], persons: np.ndarray) -> list[np.ndarray]:
    """Every sequence z-scored per feature with the frames of all sequences of its person."""
    out = list(seqs)
    for p in set(persons.tolist()):
        own = [k for k, q in enumerate(persons) if q == p]
        frames = np.concatenate([seqs[k] for k in own])
        mean, sd = frames.mean(0), frames.std(0)
        sd = np.where(sd > 1e-12, sd, 1.0)
        for k in own:
            out[k] = (seqs[k] - mean) / sd
    return out


def event_features(m: Movement) -> np.ndarray:
    """(T, 4) causal features of the whole recording for the event streams: the wrist's displacement
    from the first frame (x, y), its speed (per frame) and the grip aperture, in shoulder widths — at
    frame t the mean Neck–RShoulder distance of frames 0..t, so that no frame needs the annotated
    onset or a later frame."""
    wrist = m.keypoints[:, 2]
    widths = np.linalg.norm(m.keypoints[:, 1] - m.keypoints[:, 0], axis=-1)
    scale = np.cumsum(widths) / np.arange(1, len(widths) + 1)
    speed = np.concatenate([[0.0], np.linalg.norm(np.diff(wrist, axis=0), axis=-1)])
    aperture = np.linalg.norm(m.keypoints[:, 3] - m.keypoints[:, 4], axis=-1)
    return np.column_stack([wrist - wrist[:1], speed, aperture]) / scale[:, None]
