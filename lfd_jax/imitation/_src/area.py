"""The PHMMs' parameter space and the table: a PHMM's parameter φ in [0, 1]^2 spans a rectangle of the
table top where objects stand (PHMM, Herzog et al. 2008 Humanoids §III: the movements are trained over
a grid of target positions and interpolated between them)."""
from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class TableArea:
    """The rectangle of the table top that the PHMMs' 3 x 3 grid spans (world m).

    The defaults are the area of the simulated demonstrations: where objects stand (the grasped part's
    x, y), in the right hand's half of the table, clear of the left forearm.

    Attributes:
        x: (low, high) world x (m).
        y: (low, high) world y (m).

    Raises:
        ValueError: `x` or `y` is not an increasing pair of finite numbers.
    """

    x: tuple[float, float] = (-0.45, 0.12)
    y: tuple[float, float] = (-0.50, -0.24)

    def __post_init__(self):
        for name in ("x", "y"):
            v = getattr(self, name)
            if (not isinstance(v, tuple) or len(v) != 2 or not np.isfinite(np.asarray(v, float)).all()
                    or not v[0] < v[1]):
                raise ValueError(f"{name}: expected an increasing pair (low, high) of finite numbers, got {v!r}")

    @property
    def low(self) -> np.ndarray:
        """(2,) the rectangle's lower corner (x, y)."""
        return np.array([self.x[0], self.y[0]])

    @property
    def high(self) -> np.ndarray:
        """(2,) the rectangle's upper corner (x, y)."""
        return np.array([self.x[1], self.y[1]])


def phi_to_xy(phi: np.ndarray, area: TableArea = TableArea()) -> np.ndarray:
    """Table positions of PHMM parameters (PHMM, Humanoids 2008 §III, eq. 3's φ).

    Args:
        phi: (..., 2) parameters in [0, 1]^2.
        area: the rectangle the grid spans.

    Returns:
        (..., 2) table positions, world m.
    """
    lo, hi = area.low, area.high
    return lo + np.asarray(phi) * (hi - lo)


def xy_to_phi(xy: np.ndarray, area: TableArea = TableArea()) -> np.ndarray:
    """PHMM parameters of table positions: the inverse of `phi_to_xy`.

    Args:
        xy: (..., 2) table positions, world m.
        area: the rectangle the grid spans.

    Returns:
        (..., 2) parameters (in [0, 1]^2 inside the area).
    """
    lo, hi = area.low, area.high
    return (np.asarray(xy, float) - lo) / (hi - lo)
