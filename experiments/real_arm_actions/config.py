"""Config and presets of the real-arm action study (UE-ADL)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

from experiments.data.ue_adl import UE_ADL_DIR

METHODS = ("edhmm", "hmm", "hmmlearn", "dtw")
METHOD_NAMES = {"edhmm": "explicit-duration HMM (phmm_jax)", "hmm": "classical left-right HMM (phmm_jax)",
                "hmmlearn": "hmmlearn GaussianHMM (left-right)", "dtw": "1-NN DTW (tslearn)"}


@dataclasses.dataclass(frozen=True)
class Config:
    """Leave-one-person-out classification of the four UE-ADL actions (forward reach, reach across,
    drink, comb hair) from joint angles and raw markers; PHMMs over the reach side."""

    seed: int = 0
    data: Path = Path(UE_ADL_DIR)
    train: Path | None = None      # with `test`: train on the persons of one folder, test on another's
    test: Path | None = None
    n_persons: int | None = None   # only the first persons (sorted by name) of each kind
    use_markers: bool = True       # also the raw-marker part (persons with a markers/ folder)
    n_frames: int = 100            # every trial resampled to this many frames
    grid_states: tuple[int, ...] = (5, 10)
    grid_covariance: tuple[str, ...] = ("diag", "full")
    reg_covar: float = 0.01        # covariance floor, in standardised feature units squared
    duration_spread: float = 0.5   # explicit durations within (1 -/+ spread) n_frames / n_states
    n_iter: int = 30
    n_validation_folds: int = 2    # inner leave-one-person-out folds that choose the HMM settings
    max_gap_s: float = 0.2         # marker gaps filled up to this length
    recognition_steps: int = 20    # quasi-Newton steps of the side PHMM's recognition
    # covariance floors (standardised units squared) the side PHMMs choose from on validation persons
    side_floors: tuple[float, ...] = (0.01, 0.1, 1.0, 10.0, 100.0)

    def __post_init__(self):
        for name in ("n_frames", "n_iter", "n_validation_folds", "recognition_steps"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name}: must be >= 1, got {getattr(self, name)}")
        if self.n_persons is not None and self.n_persons < 2:
            raise ValueError(f"n_persons: leave-one-person-out needs >= 2, got {self.n_persons}")
        if (self.train is None) != (self.test is None):
            raise ValueError("train, test: give both folders or neither")
        if not self.grid_states or min(self.grid_states) < 1:
            raise ValueError(f"grid_states: non-empty, every entry >= 1, got {self.grid_states}")
        if not self.grid_covariance or set(self.grid_covariance) - {"diag", "full"}:
            raise ValueError(f"grid_covariance: non-empty, entries 'diag' or 'full', got {self.grid_covariance}")
        if max(self.grid_states) > self.n_frames:
            raise ValueError(f"grid_states: at most n_frames ({self.n_frames}) states, got {max(self.grid_states)}")
        if not 0.0 <= self.duration_spread < 1.0:
            raise ValueError(f"duration_spread: expected [0, 1), got {self.duration_spread}")
        if not self.side_floors or min(self.side_floors) <= 0:
            raise ValueError(f"side_floors: non-empty, every entry > 0, got {self.side_floors}")
        if self.reg_covar <= 0 or self.max_gap_s < 0:
            raise ValueError("reg_covar, max_gap_s: reg_covar > 0 and max_gap_s >= 0")


PRESETS = {
    "quick": {"n_persons": 3, "grid_states": (5,), "grid_covariance": ("diag",), "n_iter": 10,
              "n_validation_folds": 1, "n_frames": 50, "recognition_steps": 5, "side_floors": (0.01, 10.0)},
    "paper": {},
}
