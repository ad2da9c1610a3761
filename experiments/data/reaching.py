"""Fixed-length reaching/pointing movements for benchmarks and tests, from the table-top simulation.

A thin view of `experiments.data.tabletop` (the kinematic upper body, see there): one simulated
subject, movements resampled to `n_frames` samples of the 7 markers stacked as 21 features (metres).
"""
from __future__ import annotations

import numpy as np

from experiments.data.tabletop import ACTIONS, MARKERS, raster_targets, resample, sample_subject, simulate

__all__ = ["MARKERS", "movements_at", "raster_targets"]


def movements_at(rng: np.random.Generator, targets: np.ndarray, repetitions: int, kind: str = "reaching",
                 n_frames: int = 100, noise_m: float = 0.002) -> np.ndarray:
    """(len(targets), repetitions, n_frames, 21) movements of one subject (drawn from `rng`) to each
    target (K, 3); kind is one of `ACTIONS`."""
    if kind not in ACTIONS:
        raise ValueError(f"kind: expected one of {ACTIONS}, got {kind!r}")
    targets = np.asarray(targets, float).reshape(-1, 3)
    recordings = simulate(rng, [sample_subject(rng)], targets, repetitions, kind, marker_noise_m=noise_m)
    return resample(recordings, n_frames).reshape(len(targets), repetitions, n_frames, -1)
