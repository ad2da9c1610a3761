"""Config, presets and the trial table (grasp x condition x tactile x seed) of the grasp mapping study."""
from __future__ import annotations

import dataclasses

import numpy as np

from sim.grasping import GRASP_CLASSES, VOLAR_GRASPS
from sim.hands import HAND_NAMES


@dataclasses.dataclass(frozen=True)
class Config:
    """Grasp mapping study (MAP §IV-A) on a batched physics backend."""

    seed: int = 0
    hands: tuple[str, ...] = HAND_NAMES
    grasps: tuple[int, ...] = GRASP_CLASSES
    n_seeds: int = 8
    offset_m: float = 0.05
    n_directions: int = 6
    tilts_deg: tuple[float, ...] = (15.0, 30.0)
    mapping: str = "map2009"
    backend: str = "auto"
    nthread: int = 0
    image_width: int = 320
    image_height: int = 240

    def __post_init__(self):
        if not self.hands or any(h not in HAND_NAMES for h in self.hands):
            raise ValueError(f"hands: expected a non-empty subset of {HAND_NAMES}, got {self.hands}")
        if not self.grasps or any(g not in GRASP_CLASSES for g in self.grasps):
            raise ValueError(f"grasps: expected a non-empty subset of {GRASP_CLASSES}, got {self.grasps}")
        if self.n_seeds < 1 or not 1 <= self.n_directions <= 12:
            raise ValueError("n_seeds must be >= 1 and n_directions in [1, 12]")
        if not 0.0 < self.offset_m <= 0.2:
            raise ValueError(f"offset_m: expected (0, 0.2] m, got {self.offset_m}")
        if any(not 0.0 < abs(t) <= 90.0 for t in self.tilts_deg):
            raise ValueError(f"tilts_deg: expected values in (0, 90] degrees, got {self.tilts_deg}")


PRESETS = {
    "quick": {"n_seeds": 1},
    "paper": {},
}


@dataclasses.dataclass(frozen=True)
class Condition:
    name: str
    offset: tuple[float, float]
    tilt_deg: float
    kind: str  # none | pos | rot


def conditions(cfg: Config) -> list[Condition]:
    """No error, `n_directions` position errors (multiples of 2 pi / n), one per tilt."""
    out = [Condition("none", (0.0, 0.0), 0.0, "none")]
    for k in range(cfg.n_directions):
        ang = 2 * np.pi * k / cfg.n_directions
        out.append(Condition(f"pos_{np.degrees(ang):03.0f}deg", (cfg.offset_m * np.cos(ang), cfg.offset_m * np.sin(ang)),
                             0.0, "pos"))
    out += [Condition(f"rot_{t:g}deg", (0.0, 0.0), t, "rot") for t in cfg.tilts_deg]
    return out


def trial_table(cfg: Config) -> dict[str, np.ndarray]:
    """Every (grasp, condition, tactile, seed) combination as columns (T,); tactile off only for volar."""
    conds = conditions(cfg)
    g, c, tac, s = np.meshgrid(np.asarray(cfg.grasps), np.arange(len(conds)), [True, False],
                               np.arange(cfg.n_seeds), indexing="ij")
    g, c, tac, s = g.ravel(), c.ravel(), tac.ravel(), s.ravel()
    keep = tac | np.isin(g, list(VOLAR_GRASPS))
    g, c, tac, s = g[keep], c[keep], tac[keep], s[keep]
    offsets = np.array([conds[k].offset for k in c])
    tilts = np.array([conds[k].tilt_deg for k in c])
    return {"grasp": g, "cond": c, "tactile": tac, "seed": s + 1000 * cfg.seed, "offset": offsets, "tilt": tilts}
