"""Small motion-capture files written by the tests themselves, in the formats the loaders read: a
Vicon Nexus CSV export (the UE-ADL layout), a TRC file, a C3D file (through ezc3d), a UE-ADL
joint-angle file, and a whole folder laid out like UE-ADL with simulated trials."""
from __future__ import annotations

import lzma
from pathlib import Path

import numpy as np


def _cell(v: float) -> str:
    return "" if np.isnan(v) else f"{v:.6f}"


def write_nexus_csv(path: Path, markers_mm: np.ndarray, names, rate_hz: float = 100.0, subject: str = "S01") -> Path:
    """markers_mm (T, M, 3), NaN written as empty cells; `.xz` suffix compresses."""
    lines = ["\ufeffTrajectories", f"{rate_hz:g}",
             ",," + ",".join(f"{subject}:{n},," for n in names).rstrip(","),
             "Frame,Sub Frame," + ",".join("X,Y,Z" for _ in names),
             ",," + ",".join("mm,mm,mm" for _ in names)]
    lines += [f"{t + 1},0," + ",".join(_cell(v) for v in frame.ravel()) for t, frame in enumerate(markers_mm)]
    text = "\n".join(lines) + "\n\n"
    if path.suffix == ".xz":
        with lzma.open(path, "wt", encoding="utf-8") as f:
            f.write(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


def write_trc(path: Path, markers: np.ndarray, names, rate_hz: float = 60.0, units: str = "mm") -> Path:
    """markers (T, M, 3) in `units`; NaN written as empty cells."""
    n_frames, n_markers = markers.shape[:2]
    lines = [f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
             "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
             f"{rate_hz:g}\t{rate_hz:g}\t{n_frames}\t{n_markers}\t{units}\t{rate_hz:g}\t1\t{n_frames}",
             "Frame#\tTime\t" + "\t\t\t".join(names),
             "\t\t" + "\t".join(f"X{k}\tY{k}\tZ{k}" for k in range(1, n_markers + 1)), ""]
    lines += [f"{t + 1}\t{t / rate_hz:.5f}\t" + "\t".join(_cell(v) for v in frame.ravel())
              for t, frame in enumerate(markers)]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_c3d(path: Path, markers_mm: np.ndarray, names, rate_hz: float = 100.0, invalid=None) -> Path:
    """markers_mm (T, M, 3) through ezc3d; `invalid` (T, M) bool samples get residual -1."""
    import ezc3d

    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [rate_hz]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = tuple(names)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    points = np.ones((4, markers_mm.shape[1], markers_mm.shape[0]))
    points[:3] = np.transpose(markers_mm, (2, 1, 0))
    c3d["data"]["points"] = points
    if invalid is not None:
        residuals = np.zeros((1,) + points.shape[1:])
        residuals[0][np.asarray(invalid).T] = -1.0
        c3d["data"]["meta_points"]["residuals"] = residuals
    c3d.write(str(path))
    return path


ANGLE_NAMES = ("Finger Velocity", "Scap_X", "Scap_Y", "Scap_Z", "Shoulder horiz abd-adduction",
               "Shoulder flexion-extension", "Shoulder internal-external rotation", "elbow flexion-extension",
               "forearm pronation-supination", "wrist flexion-extension", "wrist radial-ulnar deviation")


def write_angles(path: Path, angles: np.ndarray, names=ANGLE_NAMES) -> Path:
    text = ",".join(names) + "\n" + "\n".join(",".join(f"{v:.6f}" for v in row) for row in angles) + "\n"
    if path.suffix == ".xz":
        with lzma.open(path, "wt") as f:
            f.write(text)
    else:
        path.write_text(text)
    return path


def simulated_trial(rng: np.random.Generator, action: int, side: int, n_frames: int, dim: int) -> np.ndarray:
    """A smooth movement whose shape depends on the action (a different curve per action) and the
    side (mirrored sign of the first half of the features), plus a little noise."""
    t = np.linspace(0.0, 1.0, n_frames)[:, None]
    phase = np.arange(dim)[None] / dim
    curve = np.sin(np.pi * (action + 1) * t + 2 * np.pi * phase) * (1 + 0.1 * action)
    curve[:, : dim // 2] *= 1 - 2 * side
    return curve + 0.05 * rng.standard_normal((n_frames, dim))


def write_ue_adl_folder(root: Path, persons, repetitions: int = 2, markers: bool = False, seed: int = 0) -> Path:
    """A folder laid out like UE-ADL: angles/<person>/<person><task><side><n>angles.csv.xz for the
    four actions and both sides (and, with `markers`, markers/<person>/...csv of the study's markers)."""
    from experiments.data.ue_adl import ACTIONS, SIDES
    from experiments.real_arm_actions.data import MARKERS_USED

    rng = np.random.default_rng(seed)
    for person in persons:
        for a, task in enumerate(ACTIONS):
            for s, side in enumerate(SIDES):
                for n in range(1, repetitions + 1):
                    frames = int(rng.integers(30, 50))
                    folder = root / "angles" / person
                    folder.mkdir(parents=True, exist_ok=True)
                    write_angles(folder / f"{person}{task}{side}{n}angles.csv.xz",
                                 20 * simulated_trial(rng, a, s, frames, len(ANGLE_NAMES)))
                    if markers:
                        folder = root / "markers" / person
                        folder.mkdir(parents=True, exist_ok=True)
                        xyz = 100 * simulated_trial(rng, a, s, frames, 3 * len(MARKERS_USED))
                        write_nexus_csv(folder / f"{person}{task}{side}{n}.csv",
                                        xyz.reshape(frames, len(MARKERS_USED), 3), MARKERS_USED, subject=person)
    return root
