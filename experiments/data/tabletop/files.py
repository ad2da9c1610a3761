"""Loading and saving one real recording in the in-memory format."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from lfd_common import as_array, check_choice, check_real
from experiments.data.tabletop.subjects import ACTIONS, FRAME_RATE_HZ, MARKERS, Recordings
from experiments.data.tabletop.movement import fill_gaps
from experiments.data.tabletop.recordings import stack_recordings


def load_recording(path) -> Recordings:
    """Read one recorded movement into a `Recordings` of batch 1 (markers reordered to `MARKERS`).

    `.npz`: arrays `markers` (T, M, 3) in metres, `marker_names` (M,), `frame_rate` (Hz), `action`
    ("reaching" | "pointing"), `target` (3,). `.csv`: header lines `# frame_rate: 60`,
    `# action: pointing`, `# target: x, y, z`, then a column header `sternum_x, sternum_y, ...` and one
    row per frame. Missing (NaN or empty) samples are occlusions and are filled by `fill_gaps`.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(path)
    if path.suffix == ".npz":
        with np.load(path, allow_pickle=False) as f:
            missing = {"markers", "marker_names", "frame_rate", "action", "target"} - set(f.files)
            if missing:
                raise ValueError(f"path: {path} lacks the array(s) {sorted(missing)}")
            markers = as_array(f["markers"], "markers", ndim=3, finite=False)
            names = [str(s) for s in f["marker_names"]]
            frame_rate, action, target = float(f["frame_rate"]), str(f["action"]), f["target"]
    elif path.suffix == ".csv":
        meta, header, rows = {}, None, []
        for line in path.read_text().splitlines():
            if line.startswith("#"):
                key, _, value = line[1:].partition(":")
                meta[key.strip()] = value.strip()
            elif line.strip() and header is None:
                header = [h.strip() for h in line.split(",")]
            elif line.strip():
                rows.append([float(v) if v.strip() else np.nan for v in line.split(",")])
        for key in ("frame_rate", "action", "target"):
            if key not in meta:
                raise ValueError(f"path: {path} lacks the header line '# {key}: ...'")
        if header is None or not rows or any(len(r) != len(header) for r in rows):
            raise ValueError(f"path: {path} needs a column header and rows of {len(header or [])} values")
        if len(header) % 3 or any(not h.endswith(("_x", "_y", "_z")) for h in header):
            raise ValueError(f"path: {path} columns must be <marker>_x, <marker>_y, <marker>_z")
        names = [h[:-2] for h in header[::3]]
        markers = np.asarray(rows).reshape(len(rows), len(names), 3)
        frame_rate, action = float(meta["frame_rate"]), meta["action"]
        target = [float(v) for v in meta["target"].split(",")]
    else:
        raise ValueError(f"path: expected a .npz or .csv file, got {path.name}")
    check_real(frame_rate, "frame_rate", min_value=1e-6)
    action = check_choice(action, "action", ACTIONS)
    target = as_array(target, "target", shape=(3,))
    if markers.shape[1:] != (len(names), 3):
        raise ValueError(f"markers: expected shape (T, {len(names)}, 3), got {markers.shape}")
    missing = [m for m in MARKERS if m not in names]
    if missing:
        raise ValueError(f"marker_names: missing {missing} (need {list(MARKERS)})")
    markers = fill_gaps(markers[:, [names.index(m) for m in MARKERS]])
    return stack_recordings([markers], [ACTIONS.index(action)], target[None], frame_rate)


def save_recording(path, markers, action: str, target, frame_rate: float = FRAME_RATE_HZ) -> Path:
    """Write one movement (T, 7, 3) in `MARKERS` order as `.npz` or `.csv` (the loader's formats)."""
    path = Path(path)
    markers = as_array(markers, "markers", shape=(None, len(MARKERS), 3), finite=False)
    action = check_choice(action, "action", ACTIONS)
    target = as_array(target, "target", shape=(3,))
    if path.suffix == ".npz":
        np.savez(path, markers=markers, marker_names=np.array(MARKERS), frame_rate=frame_rate,
                 action=action, target=target)
    elif path.suffix == ".csv":
        header = ",".join(f"{m}_{k}" for m in MARKERS for k in "xyz")
        lines = [f"# frame_rate: {frame_rate}", f"# action: {action}", f"# target: {', '.join(map(str, target))}",
                 header] + [",".join("" if np.isnan(v) else repr(float(v)) for v in row)
                            for row in markers.reshape(len(markers), -1)]
        path.write_text("\n".join(lines) + "\n")
    else:
        raise ValueError(f"path: expected a .npz or .csv file, got {path.name}")
    return path
