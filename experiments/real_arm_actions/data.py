"""The study's two data sets from a UE-ADL-like folder: joint angles and raw-marker features, each
trial resampled to a fixed number of frames.

* angles: the 11 columns of the processed files (finger velocity and 10 joint angles) as they are.
* markers: 10 points of the Nexus trajectories relative to the sternum marker STRN, in metres: per
  arm (R, L) the centroids of the shoulder, upper-arm, forearm and hand clusters (4 markers each)
  and the fingertip. The 10 calibration landmarks (GTH, LEP, MEP, SPR, SPU) are empty in dynamic
  trials and not used; short gaps of the used markers are filled (`lfd_jax.fill_gaps`).
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from experiments.config import progress
import lfd_jax as loaders
from experiments.data import ue_adl

CLUSTERS = ("SHO", "UAR", "LAR", "HAN")
MARKER_POINTS = tuple(f"{side}{c}" for side in "RL" for c in CLUSTERS + ("FTP",))
MARKERS_USED = ("STRN",) + tuple(f"{s}{c}{k}" for s in "RL" for c in CLUSTERS for k in range(1, 5)) + ("RFTP", "LFTP")


class Dataset(NamedTuple):
    """features (B, S, D) float64; action (B,) index into ue_adl.ACTIONS; side (B,) 0 left, 1 right;
    person (B,) str; kind "angles" | "markers"; names (D,) the features."""

    features: np.ndarray
    action: np.ndarray
    side: np.ndarray
    person: np.ndarray
    kind: str
    names: tuple[str, ...]

    def subset(self, index) -> "Dataset":
        return self._replace(features=self.features[index], action=self.action[index], side=self.side[index],
                             person=self.person[index])

    @property
    def persons(self) -> list[str]:
        return sorted(set(self.person.tolist()))


def marker_features(recording: loaders.MarkerRecording, max_gap_s: float) -> np.ndarray:
    """(T, 30): the `MARKER_POINTS` relative to STRN (module docstring), gaps filled first."""
    rec = loaders.fill_gaps(loaders.select_markers(recording, MARKERS_USED), max_gap_s)
    at = {n: rec.markers[:, i] for i, n in enumerate(rec.names)}
    points = [np.mean([at[f"{p}{k}"] for k in range(1, 5)], axis=0) if p[1:] in CLUSTERS else at[p]
              for p in MARKER_POINTS]
    return (np.stack(points, axis=1) - at["STRN"][:, None]).reshape(len(rec.markers), -1)


def _load_one(trial: ue_adl.Trial, kind: str, n_frames: int, max_gap_s: float) -> np.ndarray:
    if kind == "angles":
        sequence = ue_adl.load_joint_angles(trial.path).angles
    else:
        try:
            sequence = marker_features(loaders.load_markers(trial.path), max_gap_s)
        except ValueError as err:
            raise ValueError(f"{trial.path}: {err}") from err
    return loaders.resample_frames(sequence, n_frames)


def feature_names(kind: str, first_trial: ue_adl.Trial) -> tuple[str, ...]:
    if kind == "angles":
        return ue_adl.load_joint_angles(first_trial.path).names
    return tuple(f"{p}_{axis}" for p in MARKER_POINTS for axis in "xyz")


def has_kind(root: Path, kind: str) -> bool:
    return (Path(root) / kind).is_dir()


def load_dataset(root: Path, kind: str, n_frames: int, n_persons: int | None = None,
                 max_gap_s: float = 0.2) -> Dataset:
    """Every dynamic trial of `kind` under `root` (the first `n_persons` persons when given)."""
    trials = ue_adl.list_trials(root, kind)
    persons = sorted({t.person for t in trials})[:n_persons]
    trials = [t for t in trials if t.person in persons]
    features = np.stack([_load_one(t, kind, n_frames, max_gap_s)
                         for t in progress(trials, desc=f"loading {kind} ({Path(root).name})")])
    return Dataset(features, np.array([t.action for t in trials]), np.array([ue_adl.SIDES.index(t.side) for t in trials]),
                   np.array([t.person for t in trials]), kind, feature_names(kind, trials[0]))
