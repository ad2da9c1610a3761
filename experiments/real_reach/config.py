"""Config and presets of the real-reach study (object size and reach timing from OpenPose tracks)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

METHODS = ("phmm", "phmm_cv", "phmm_person", "aperture", "aperture_person", "regression", "hmmlearn", "dtw")
METHOD_NAMES = {"phmm": "PHMM, d = 1 (size in cm)",
                "phmm_cv": "PHMM φ, class means of cross-validated φ",
                "phmm_person": "PHMM φ z-scored per person, class means of cross-validated φ",
                "aperture": "nearest class mean, max grip aperture",
                "aperture_person": "nearest class mean, max grip aperture z-scored per person",
                "regression": "linear regression, last frame", "hmmlearn": "hmmlearn GaussianHMM per size",
                "dtw": "1-NN DTW"}
EVENT_METHODS = ("speed", "hmm")


@dataclasses.dataclass(frozen=True)
class Config:
    """Leave-one-person-out recognition of the cube's size (S / M / L) from real reach-to-grasp
    tracks, online along the reach, and online reach onset / contact detection."""

    seed: int = 0
    data: Path = Path("../shared/data/reach_grasp")   # a folder with reach_grasp_openpose_p1-4.npz, or the file
    n_persons: int | None = None      # only the first persons
    per_class: int | None = None      # only the first movements of each person and size
    max_gap_s: float = 0.2            # keypoint gaps filled up to this length
    normalisations: tuple[str, ...] = ("pixels", "person", "calibrated")
    fractions: tuple[float, ...] = (0.2, 0.4, 0.6, 0.8, 1.0)   # prefixes of the reach for the online estimate
    # settings chosen on inner leave-one-person-out folds of the training persons
    grid_states: tuple[int, ...] = (4, 8)
    floors: tuple[float, ...] = (0.1, 1.0)              # covariance floors, standardised units squared
    phmm_grids: tuple[str, ...] = ("SL", "SML")              # PHMM corners: S and L, or S, M and L
    phmm_covariances: tuple[str, ...] = ("corner", "tied")   # per corner, or each state's tied across corners
    n_validation_folds: int = 3
    n_iter: int = 20
    epsilon: float = 0.1              # how far the PHMM's search may leave [0, 1]
    recognition_steps: int = 6
    n_phi: int = 25                   # φ lattice over [-ε, 1 + ε] of the PHMM's online estimate
    search: bool = True               # whole reaches by phmm_jax.recognize's search (False: the φ lattice)
    # events
    reach_states: int = 4
    after_states: int = 3
    after_frames: int = 60            # frames after contact that train the event HMM's last states
    event_lags: tuple[int, ...] = (0, 3, 6)   # fixed-lag smoothing of the event HMM (frames of latency)
    speed_windows: tuple[int, ...] = (3, 6, 10, 15)   # wrist speed over this many frames (causal)
    speed_onsets: tuple[float, ...] = (0.01, 0.02, 0.03, 0.04, 0.05, 0.07)   # shoulder widths per frame
    speed_stops: tuple[float, ...] = (0.1, 0.2, 0.3, 0.5)    # contact: speed below this share of the peak

    def __post_init__(self):
        for name in ("n_iter", "recognition_steps", "reach_states", "after_states", "after_frames",
                     "n_validation_folds"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name}: must be >= 1, got {getattr(self, name)}")
        if self.n_phi < 3:
            raise ValueError(f"n_phi: must be >= 3, got {self.n_phi}")
        if self.n_persons is not None and self.n_persons < 3:
            raise ValueError(f"n_persons: leave-one-person-out with inner folds needs >= 3, got {self.n_persons}")
        if self.per_class is not None and self.per_class < 2:
            raise ValueError(f"per_class: must be >= 2, got {self.per_class}")
        if not self.normalisations or set(self.normalisations) - {"pixels", "person", "calibrated"}:
            raise ValueError(f"normalisations: non-empty, entries 'pixels', 'person' or 'calibrated', "
                             f"got {self.normalisations}")
        if not self.fractions or min(self.fractions) <= 0 or max(self.fractions) > 1 or 1.0 not in self.fractions:
            raise ValueError(f"fractions: in (0, 1], 1.0 included, got {self.fractions}")
        if not self.grid_states or min(self.grid_states) < 1:
            raise ValueError(f"grid_states: non-empty, every entry >= 1, got {self.grid_states}")
        if not self.floors or min(self.floors) <= 0:
            raise ValueError(f"floors: non-empty, every entry > 0, got {self.floors}")
        if not self.phmm_grids or set(self.phmm_grids) - {"SL", "SML"}:
            raise ValueError(f"phmm_grids: non-empty, entries 'SL' or 'SML', got {self.phmm_grids}")
        if not self.phmm_covariances or set(self.phmm_covariances) - {"corner", "tied"}:
            raise ValueError(f"phmm_covariances: non-empty, entries 'corner' or 'tied', got {self.phmm_covariances}")
        if not self.event_lags or min(self.event_lags) < 0:
            raise ValueError(f"event_lags: non-empty, every entry >= 0, got {self.event_lags}")
        if self.epsilon < 0 or self.max_gap_s < 0:
            raise ValueError("epsilon, max_gap_s: must be >= 0")
        if not self.speed_onsets or not self.speed_stops or not self.speed_windows or min(self.speed_windows) < 1:
            raise ValueError("speed_windows, speed_onsets, speed_stops: non-empty (windows >= 1)")


PRESETS = {
    "quick": {"per_class": 10, "grid_states": (4,), "floors": (0.1,), "phmm_grids": ("SML",),
              "phmm_covariances": ("tied",), "n_iter": 8,
              "recognition_steps": 3, "n_phi": 13, "event_lags": (0, 3)},
    "paper": {},
}
