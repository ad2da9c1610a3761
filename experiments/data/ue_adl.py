"""The UE-ADL database of upper-limb daily-living actions (Huang, MiaH-kin/UE_ADLdatabase, MIT
licence; ../shared/data/ue_adl/README.md) and any folder laid out like it:

    ROOT/angles/<person>/<person><task><side><n>angles.csv[.xz]   processed joint angles, 100 Hz
    ROOT/markers/<person>/<person><task><side><n>.csv[.xz]        raw Vicon Nexus trajectories (mm)

task: F forward reach, A reach across, D drink from a cup, C comb hair (`ACTIONS`); side: L or R,
the arm used; n: the trial (1-based). `<person>_static.csv` calibration trials are not listed.
Angle files have one header row of column names, then one row of floats per frame.
"""
from __future__ import annotations

import io
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from lfd_jax import read_text
from lfd_common import check_choice, check_real

__all__ = ["ACTIONS", "ACTION_NAMES", "JointAngles", "KINDS", "SIDES", "Trial", "UE_ADL_DIR", "list_trials",
           "load_joint_angles"]

UE_ADL_DIR = "../shared/data/ue_adl"  # relative to the project root, as the experiments run
ACTIONS = ("F", "A", "D", "C")
ACTION_NAMES = ("forward reach", "reach across", "drink", "comb hair")
SIDES = ("L", "R")
KINDS = ("angles", "markers")
ANGLES_RATE_HZ = 100.0
_TRIAL = re.compile(r"(?P<task>[FADC])(?P<side>[LR])(?P<rep>\d+)(?P<angles>angles)?\.csv(?:\.xz)?")


class Trial(NamedTuple):
    """One dynamic trial: person (folder name), action index into ACTIONS, side "L"/"R", repetition
    (1-based) and the file."""

    person: str
    action: int
    side: str
    repetition: int
    path: Path


class JointAngles(NamedTuple):
    """angles (T, C) float64 (the first UE-ADL column is the finger velocity, the others degrees);
    names (C,) the column header; rate_hz."""

    angles: np.ndarray
    names: tuple[str, ...]
    rate_hz: float


def list_trials(root, kind: str = "angles") -> list[Trial]:
    """Every dynamic trial of `kind` ("angles" or "markers") under `root`, sorted by person, action,
    side and repetition. ValueError naming `root` when `root/kind` is not a folder or holds none."""
    kind = check_choice(kind, "kind", KINDS)
    base = Path(root) / kind
    if not base.is_dir():
        raise ValueError(f"root: no folder {base} (expected a UE-ADL layout: ROOT/{kind}/<person>/...)")
    trials = []
    for folder in sorted(p for p in base.iterdir() if p.is_dir()):
        for file in folder.iterdir():
            match = _TRIAL.fullmatch(file.name[len(folder.name):]) if file.name.startswith(folder.name) else None
            if match and bool(match["angles"]) == (kind == "angles"):
                trials.append(Trial(folder.name, ACTIONS.index(match["task"]), match["side"], int(match["rep"]), file))
    if not trials:
        raise ValueError(f"root: {base} holds no trial files <person><task><side><n>"
                         f"{'angles' if kind == 'angles' else ''}.csv[.xz]")
    return sorted(trials, key=lambda t: (t.person, t.action, t.side, t.repetition))


def load_joint_angles(path, rate_hz: float = ANGLES_RATE_HZ) -> JointAngles:
    """One UE-ADL joint-angle file (plain or .xz): the header row's names and the (T, C) values.
    The files do not state their rate; UE-ADL's is 100 Hz. ValueError naming `path` for a missing
    file, rows of another width than the header, or values that are not finite numbers."""
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"path: no such file {file}")
    rate = check_real(rate_hz, "rate_hz", min_value=0.0, exclusive_min=True)
    header, _, body = read_text(file).partition("\n")
    names = tuple(n.strip() for n in header.split(","))
    try:
        angles = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2)
    except ValueError as err:
        raise ValueError(f"path: cannot read {file} as a joint-angle CSV ({err})") from err
    if angles.shape[0] == 0 or angles.shape[1] != len(names):
        raise ValueError(f"path: {file} has {angles.shape[0]} rows of {angles.shape[1]} values under a header "
                         f"of {len(names)} columns")
    if not np.all(np.isfinite(angles)):
        raise ValueError(f"path: {file} contains NaN or infinite values")
    return JointAngles(angles, names, rate)
