"""Simulated table-top reaching and pointing movements (PHMM papers' protocol, simplified).

Seven 3-D markers (shoulder, sternum, elbow, wrist, thumb, index finger tip, index knuckle) of a
right arm move from a rest pose beside the hip to a target on the table and back. Reaching ends with
the hand at the target; pointing stops short, higher, with the index finger extended towards it.
Each repetition varies its timing (a smooth random time warp), amplitude and marker noise.
Units: metres. Output: (T, 21) per movement, resampled to `n_frames`.
"""
from __future__ import annotations

import numpy as np

MARKERS = ("shoulder", "sternum", "elbow", "wrist", "thumb", "index_tip", "index_knuckle")
_SHOULDER = np.array([0.0, -0.2, 1.4])
_STERNUM = np.array([0.0, -0.05, 1.3])
_REST_HAND = np.array([0.05, -0.25, 0.85])
TABLE_ORIGIN = np.array([-0.4, 0.25, 0.75])  # the raster's corner (x to the right, y away from the body)
TABLE_SIZE = np.array([0.8, 0.3])  # 80 x 30 cm


def raster_targets(rows: int, cols: int) -> np.ndarray:
    """Target points (rows, cols, 3) of a regular raster over the 80 x 30 cm table area."""
    u = np.linspace(0.0, 1.0, cols)
    v = np.linspace(0.0, 1.0, rows)
    grid = np.stack(np.meshgrid(v, u, indexing="ij"), axis=-1)  # (rows, cols, 2) as (v, u)
    xy = TABLE_ORIGIN[:2] + grid[..., ::-1] * TABLE_SIZE
    return np.concatenate([xy, np.full(grid.shape[:2] + (1,), TABLE_ORIGIN[2])], axis=-1)


def _min_jerk(s):
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def movement(rng: np.random.Generator, target: np.ndarray, kind: str = "reaching", n_frames: int = 100,
             noise_m: float = 0.005, warp: float = 0.15) -> np.ndarray:
    """One movement (n_frames, 21) to `target` (3,) and back; kind "reaching" or "pointing"."""
    scale = 1.0 + 0.05 * rng.normal()
    u = np.linspace(0.0, 1.0, n_frames)
    # A monotone random time warp: the phase runs faster or slower in parts of the movement.
    knots = np.cumsum(np.exp(warp * rng.normal(size=6)))
    knots = np.concatenate([[0.0], knots / knots[-1]])
    phase = np.interp(u, np.linspace(0, 1, 7), knots)
    out_and_back = np.where(phase < 0.5, _min_jerk(np.clip(phase * 2.2, 0, 1)),
                            _min_jerk(np.clip((1 - phase) * 2.2, 0, 1)))[:, None]
    goal = target.copy()
    if kind == "pointing":
        goal = _SHOULDER + 0.6 * (target - _SHOULDER) + np.array([0.0, 0.0, 0.12])
    elif kind != "reaching":
        raise ValueError(f"kind: expected 'reaching' or 'pointing', got {kind!r}")
    hand = _REST_HAND + out_and_back * (goal - _REST_HAND) * scale
    direction = (target - hand) / np.linalg.norm(target - hand, axis=1, keepdims=True)
    arm = hand - _SHOULDER
    elbow = _SHOULDER + 0.5 * arm + np.array([0.12, 0.0, -0.08]) * (1 - 0.5 * out_and_back)
    wrist = hand - 0.06 * direction
    extend = 0.09 if kind == "pointing" else 0.05
    index_tip = hand + extend * direction
    thumb = hand + np.array([-0.03, 0.0, 0.03]) + 0.02 * direction * out_and_back
    knuckle = hand + 0.02 * direction
    shoulder = np.broadcast_to(_SHOULDER + 0.02 * out_and_back * (goal - _REST_HAND) / 1.0, hand.shape)
    sternum = np.broadcast_to(_STERNUM, hand.shape) + 0.01 * out_and_back
    markers = np.stack([shoulder, sternum, elbow, wrist, thumb, index_tip, knuckle], axis=1)
    markers = markers + noise_m * rng.normal(size=markers.shape)
    return markers.reshape(n_frames, -1)


def movements_at(rng: np.random.Generator, targets: np.ndarray, repetitions: int, kind: str = "reaching",
                 n_frames: int = 100, noise_m: float = 0.005) -> np.ndarray:
    """(len(targets), repetitions, n_frames, 21) movements to each target."""
    return np.stack([np.stack([movement(rng, t, kind, n_frames, noise_m) for _ in range(repetitions)])
                     for t in np.asarray(targets).reshape(-1, 3)])
