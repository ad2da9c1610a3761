"""Synthetic hand movements with known class and target for the PHMM tests: minimum-jerk out to the
target, a hold and back, straight (a "pointing") or over an arc (a "reach" / "transfer")."""
import numpy as np


def min_jerk(n: int) -> np.ndarray:
    """(n,) the minimum-jerk profile from 0 to 1."""
    s = np.linspace(0.0, 1.0, n)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def out_and_back(rng: np.random.Generator, kind: int, rest: np.ndarray, target: np.ndarray,
                 noise: float) -> np.ndarray:
    """(T, 3) from `rest` to `target` (3,), a hold of 2-4 frames and back, with Gaussian noise of sd `noise`:
    kind 0 straight, kind 1 over an arc lifted 15 cm in z and drawn back 10 cm in x. Phase lengths are drawn
    from `rng` (out and back 6-8 frames)."""
    out = min_jerk(int(rng.integers(6, 9)))
    back = 1.0 - min_jerk(int(rng.integers(6, 9)))
    hold = np.ones(int(rng.integers(3, 6)))
    s = np.concatenate([out, hold[1:], back[1:]])
    path = rest + s[:, None] * (target - rest)
    if kind == 1:
        path[:, 2] += 0.15 * np.sin(np.pi * s)
        path[:, 0] -= 0.1 * np.sin(np.pi * s)
    return path + noise * rng.normal(size=path.shape)
