"""Config and presets of the PHMM table-top study."""
from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Config:
    """PHMM table-top study: training on a 3x3 raster, tests on a 5x7 raster, robot retargeting."""

    seed: int = 0
    train_repetitions: int = 10
    test_repetitions: int = 4
    test_rows: int = 5
    test_cols: int = 7
    n_subjects: int = 1
    n_states: int = 20
    min_duration: int = 4
    max_duration: int = 6
    n_samples: int = 100
    n_iter: int = 30
    average_states: int = 80
    noise_cm: tuple[float, ...] = (0.0, 1.0, 2.0, 5.0, 10.0, 15.0, 20.0)
    endpoint_sd_cm: float = 1.2
    marker_noise_mm: float = 2.0
    drop_rate: float = 0.3
    recognition_steps: int = 40

    def __post_init__(self):
        for name in ("train_repetitions", "test_repetitions", "n_subjects", "n_states", "min_duration",
                     "max_duration", "n_samples", "average_states", "n_iter"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name}: must be >= 1, got {getattr(self, name)}")
        if self.test_rows < 3 or self.test_cols < 3:
            raise ValueError("test_rows, test_cols: need at least 3 (the inner region is the raster minus its border)")
        if not self.noise_cm or any(s < 0 for s in self.noise_cm) or 0.0 not in self.noise_cm:
            raise ValueError(f"noise_cm: non-negative values including 0, got {self.noise_cm}")


PRESETS = {
    "quick": {"train_repetitions": 4, "test_repetitions": 1, "n_iter": 10, "average_states": 40,
              "noise_cm": (0.0, 10.0), "recognition_steps": 6},
    "paper": {},
}
PAPER = {"synthesis_error_cm_inner": 1.8, "param_error_cm": 2.0, "rate_2x2": 0.94, "rate_3x3": 0.93, "rate_hmm": 0.85}
