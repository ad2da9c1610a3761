"""Markers, actions, the table and raster geometry, the recording container and simulated subjects."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from lfd_common import check_int


MARKERS = ("sternum", "shoulder", "elbow", "wrist", "index_knuckle", "index_tip", "thumb_tip")
ACTIONS = ("reaching", "pointing")
FRAME_RATE_HZ = 60.0
TABLE_HEIGHT_M = 0.73
RASTER_ORIGIN = np.array([-0.30, 0.25, TABLE_HEIGHT_M])  # near-left corner of the raster (x, y, z)
RASTER_SIZE_M = np.array([0.80, 0.30])  # width (x) x depth (y)
TABLE_EDGE_Y = 0.20  # the table's near edge (the chest surface is at about y = 0.12)
HIP = np.array([0.0, -0.05, 0.55])  # trunk pivot (between the hip joints, seated)
_SEAT_HEIGHT = 0.45


class Recordings(NamedTuple):
    """A batch of marker recordings. markers (B, T, M, 3) in metres, padded with the last frame;
    lengths (B,) frames; action (B,) index into ACTIONS; target (B, 3) metres; frame_rate in Hz;
    marker_names (M,)."""

    markers: np.ndarray
    lengths: np.ndarray
    action: np.ndarray
    target: np.ndarray
    frame_rate: float
    marker_names: tuple


class Subject(NamedTuple):
    """Anthropometry (metres) and movement style of one simulated person."""

    shoulder: np.ndarray  # (3,) shoulder joint centre, trunk upright
    sternum: np.ndarray  # (3,) sternum marker, trunk upright
    eye: np.ndarray  # (3,) cyclopean eye, trunk upright
    upper_arm: float
    forearm: float
    hand: float  # wrist to index knuckle
    finger: float  # index knuckle to tip
    pointing_extension: float  # habitual shoulder-knuckle distance when pointing, fraction of full reach
    pointing_standoff: float  # least knuckle-target distance when pointing (m)
    pointing_sight: float  # habitual sighting point, 0 = along the arm (shoulder), 1 = eye line
    swivel: float  # habitual elbow swivel (rad)
    speed: float  # duration factor (1 = average)


def raster_targets(rows: int, cols: int) -> np.ndarray:
    """Target points (rows, cols, 3) of a regular raster over the 80 x 30 cm table area; rows run in
    depth (y, away from the body), columns in width (x, left to right)."""
    rows = check_int(rows, "rows", min_value=1)
    cols = check_int(cols, "cols", min_value=1)
    v = np.linspace(0.0, 1.0, rows) if rows > 1 else np.zeros(1)
    u = np.linspace(0.0, 1.0, cols) if cols > 1 else np.zeros(1)
    vv, uu = np.meshgrid(v, u, indexing="ij")
    x = RASTER_ORIGIN[0] + uu * RASTER_SIZE_M[0]
    y = RASTER_ORIGIN[1] + vv * RASTER_SIZE_M[1]
    return np.stack([x, y, np.full_like(x, RASTER_ORIGIN[2])], axis=-1)


def sample_subject(rng: np.random.Generator) -> Subject:
    """A person drawn from realistic adult ranges (stature 1.55-1.95 m; segment lengths as fractions
    of stature, after Drillis & Contini, each scaled by its own +-3 % factor)."""
    stature = rng.uniform(1.55, 1.95)
    f = 1.0 + 0.03 * rng.standard_normal(6)
    shoulder_height = _SEAT_HEIGHT + 0.34 * stature * f[0]  # seated acromion height
    shoulder = np.array([0.098 * stature * f[1], 0.0, shoulder_height - 0.04])
    return Subject(
        shoulder=shoulder,
        sternum=np.array([0.0, 0.09, shoulder_height - 0.07]),
        eye=np.array([0.0, 0.07, shoulder_height + 0.19 * stature / 1.75]),
        upper_arm=0.172 * stature * f[2],
        forearm=0.157 * stature * f[3],
        hand=0.054 * stature * f[4],
        finger=0.05 * stature * f[5],
        pointing_extension=rng.uniform(0.72, 0.9),
        pointing_standoff=rng.uniform(0.15, 0.3),
        pointing_sight=rng.uniform(0.2, 0.8),
        swivel=np.deg2rad(10.0) * rng.standard_normal(),
        speed=rng.uniform(0.85, 1.15),
    )


# --------------------------------------------------------------------------------------------------
# Kinematics (vectorised over frames)
