"""Config, presets and the paper's numbers of the grasp recognition study."""
from __future__ import annotations

import dataclasses

PAPER = {"accuracy_X": 0.61, "accuracy_Xp": 0.71, "accuracy_Xpp": 0.75, "human_X": 0.74,
         "orientation_error_deg": (0.0, 16.8, 10.5)}
EULER_NAMES = ("azimuth", "elevation", "roll")


@dataclasses.dataclass(frozen=True)
class Config:
    """Grasp recognition from one image: rendered database, HOG, LSH kNN, GRASP's evaluation."""

    seed: int = 0
    n_azimuth: int = 60
    n_elevation: int = 15
    render_size: int = 128
    crop_size: int = 64
    n_bins: int = 4
    n_levels: int = 3
    k: int = 10
    lsh_target_recall: float = 0.9
    n_held_out: int = 120
    n_large: int = 600
    frame_size: int = 160
    n_skin_images: int = 12
    k_values: tuple[int, ...] = (1, 3, 5, 10, 20, 50)
    db_grids: tuple[str, ...] = ("30x10", "60x15", "120x30")
    bins_sweep: tuple[int, ...] = (3, 4, 5, 6, 8)
    levels_sweep: tuple[int, ...] = (2, 3, 4, 5)
    timing_repeats: int = 5

    def __post_init__(self):
        if min(self.n_azimuth, self.n_elevation, self.k, self.n_large, self.n_held_out, self.timing_repeats) < 1:
            raise ValueError("n_azimuth, n_elevation, k, n_large, n_held_out and timing_repeats must be >= 1")
        if not 0.0 < self.lsh_target_recall <= 1.0:
            raise ValueError("lsh_target_recall: must be in (0, 1]")
        if self.crop_size < 2 ** (max(self.levels_sweep + (self.n_levels,)) - 1):
            raise ValueError("crop_size: too small for the finest HOG level")
        for g in self.db_grids:
            parse_grid(g)


PRESETS = {
    "quick": {"n_azimuth": 30, "n_elevation": 8, "n_large": 60, "n_held_out": 60, "k_values": (1, 5, 10, 20),
              "db_grids": ("20x5", "30x8"), "bins_sweep": (3, 8), "levels_sweep": (2, 3), "timing_repeats": 3},
    "paper": {},
}


def parse_grid(text: str) -> tuple[int, int]:
    """'60x15' -> (60, 15)."""
    try:
        a, e = (int(v) for v in text.lower().split("x"))
    except ValueError as err:
        raise ValueError(f"db_grids: expected entries like '60x15', got {text!r}") from err
    if a < 1 or e < 1:
        raise ValueError(f"db_grids: expected positive grid sizes, got {text!r}")
    return a, e
