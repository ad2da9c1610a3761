"""Marker files into one `MarkerRecording` (metres, NaN in gaps): Vicon Nexus CSV exports, TRC text
files, C3D through `ezc3d` (the optional extra `mocap`). Text files may be xz-compressed (`.xz`).

* **Vicon Nexus CSV** (the "Trajectories" section of a Nexus export, as in UE-ADL): a line
  `Trajectories`, the frame rate, the marker names (`Subject:Marker`, each followed by two empty
  cells), `Frame,Sub Frame,X,Y,Z,...`, the units (`mm`), then one row per frame; an empty cell is a gap.
  Other sections of a full export (Devices, Model Outputs, ...) are skipped.
* **TRC** (Motion Analysis / OpenSim): tab-separated; line 1 `PathFileType ...`, line 2 the keys
  `DataRate CameraRate NumFrames NumMarkers Units ...`, line 3 their values, line 4
  `Frame# Time NAME1 <tab> <tab> NAME2 ...`, line 5 `X1 Y1 Z1 X2 ...`, then one row per frame (an empty
  or NaN cell is a gap). The rows must be as many as NumFrames says and as wide as NumMarkers says.
* **C3D** through `ezc3d.c3d(path)`: POINT:LABELS, POINT:RATE, POINT:UNITS; a sample whose residual
  is negative (the C3D convention for "invalid"), or NaN, is a gap. The file must hold the frames its
  header states (checked on the bytes before ezc3d reads them: ezc3d 1.7 makes up the frames a cut
  file lacks, and hangs or crashes on some cuts).
"""
from __future__ import annotations

import io
import lzma
import os
import re
from pathlib import Path

import numpy as np

from lfd_jax._src.markers import MarkerRecording, make_recording

__all__ = ["UNIT_TO_METRES", "load_c3d", "load_markers", "load_nexus_csv", "load_trc", "read_text"]

UNIT_TO_METRES = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
_EMPTY_CELL = re.compile(r"(?<=[,\t])(?=[,\t]|$)|^(?=[,\t])", flags=re.M)


def _existing(path) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path: expected a file path, got {type(path).__name__}")
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"path: no such file {path}")
    return path


def read_text(path: Path) -> str:
    """The text of a file, plain or xz-compressed (`.xz`), a UTF-8 BOM dropped.

    Args:
        path: the file.

    Returns:
        Its text.

    Raises:
        ValueError: naming `path` when it cannot be read as UTF-8 text (a truncated `.xz` included).
    """
    try:
        if path.suffix == ".xz":
            with lzma.open(path, "rt", encoding="utf-8-sig") as f:
                return f.read()
        return path.read_text(encoding="utf-8-sig")
    except (OSError, EOFError, UnicodeDecodeError, lzma.LZMAError) as err:  # EOFError: a cut .xz
        raise ValueError(f"path: cannot read {path} as text ({err})") from err


def _table(lines: list[str], delimiter: str, n_markers: int, path: Path) -> np.ndarray:
    """Rows of numbers with empty cells (gaps) -> float array (rows, 2 + 3 n_markers), NaN in the gaps.

    A row must hold the frame and time (or sub-frame) columns and X, Y, Z of every marker the header
    names; cells past them must be empty (a trailing delimiter), not values of markers it does not name.
    """
    n_columns = 2 + 3 * n_markers
    text = _EMPTY_CELL.sub("nan", "\n".join(lines))
    try:
        table = np.loadtxt(io.StringIO(text), delimiter=delimiter, ndmin=2)
    except ValueError as err:
        raise ValueError(f"path: {path} has a row that is not numbers ({err})") from err
    if table.shape[1] < n_columns or not np.isnan(table[:, n_columns:]).all():
        raise ValueError(f"path: {path} rows have {table.shape[1]} values, expected {n_columns} "
                         f"(2 + 3 x {n_markers} markers of its header)")
    return table[:, :n_columns]


def _scale(unit: str, path: Path) -> float:
    unit = unit.strip().lower()
    if unit not in UNIT_TO_METRES:
        raise ValueError(f"path: {path} gives the unit {unit!r}; expected one of {sorted(UNIT_TO_METRES)}")
    return UNIT_TO_METRES[unit]


def load_nexus_csv(path) -> MarkerRecording:
    """The "Trajectories" section of a Vicon Nexus CSV export, in metres.

    Args:
        path: the `.csv` (or `.csv.xz`) file: a "Trajectories" line, the rate, the marker names
            ("subject:name"), the X/Y/Z line, the units, then one row per frame (empty cells are gaps).

    Returns:
        A `MarkerRecording`.

    Raises:
        ValueError: naming `path` for a missing file, no Trajectories section, a bad header or rows.
    """
    path = _existing(path)
    lines = read_text(path).splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip().strip(",") == "Trajectories"]
    if not starts:
        raise ValueError(f"path: {path} has no 'Trajectories' section (not a Vicon Nexus CSV export)")
    head = starts[0]
    if len(lines) < head + 5:
        raise ValueError(f"path: {path} ends inside the Trajectories header")
    try:
        rate = float(lines[head + 1].split(",")[0])
    except ValueError as err:
        raise ValueError(f"path: {path} line {head + 2} should be the frame rate, got {lines[head + 1]!r}") from err
    names = [cell.split(":")[-1].strip() for cell in lines[head + 2].split(",") if cell.strip()]
    units = [u for u in lines[head + 4].split(",")[2:] if u.strip()]
    if not names or len(units) < 3 * len(names):
        raise ValueError(f"path: {path} header gives {len(names)} markers and {len(units)} unit cells")
    if len(set(units)) != 1:
        raise ValueError(f"path: {path} mixes units {sorted(set(units))}")
    body = []
    for line in lines[head + 5:]:
        if not line.strip(", "):
            break  # the blank line that ends the section
        body.append(line)
    if not body:
        raise ValueError(f"path: {path} has no frames in its Trajectories section")
    table = _table(body, ",", len(names), path)
    markers = table[:, 2:].reshape(len(table), len(names), 3) * _scale(units[0], path)
    return make_recording(markers, names, rate)


def load_trc(path) -> MarkerRecording:
    """A TRC marker file, in metres.

    Args:
        path: the `.trc` (or `.trc.xz`) file, tab-separated, its header stating DataRate, NumMarkers
            and Units (and usually NumFrames).

    Returns:
        A `MarkerRecording`.

    Raises:
        ValueError: naming `path` for a missing file, a header without DataRate, NumMarkers and Units,
            or rows that disagree with it: fewer or more frames than NumFrames (a file cut at a row
            boundary), rows wider or narrower than NumMarkers markers.
    """
    path = _existing(path)
    lines = read_text(path).splitlines()
    if len(lines) < 6 or not lines[0].startswith("PathFileType"):
        raise ValueError(f"path: {path} is not a TRC file (expected a first line 'PathFileType ...')")
    header = dict(zip((k.strip() for k in lines[1].split("\t")), (v.strip() for v in lines[2].split("\t"))))
    try:
        rate, n_markers, unit = float(header["DataRate"]), int(header["NumMarkers"]), header["Units"]
        n_frames = int(header["NumFrames"]) if header.get("NumFrames") else None
    except (KeyError, ValueError) as err:
        raise ValueError(f"path: {path} header lacks a valid DataRate, NumMarkers, NumFrames or Units ({err})") from err
    names = [c.strip() for c in lines[3].split("\t")[2:] if c.strip()]
    if len(names) != n_markers:
        raise ValueError(f"path: {path} names {len(names)} markers, its header says NumMarkers {n_markers}")
    body = [line for line in lines[5:] if line.strip()]
    if not body:
        raise ValueError(f"path: {path} has no frames")
    if n_frames is not None and len(body) != n_frames:
        raise ValueError(f"path: {path} header says {n_frames} frames, file holds {len(body)}")
    table = _table(body, "\t", n_markers, path)
    markers = table[:, 2:].reshape(len(table), n_markers, 3) * _scale(unit, path)
    return make_recording(markers, names, rate)


def _import_ezc3d():
    try:
        import ezc3d
    except ImportError as err:
        raise ImportError("reading C3D files needs ezc3d: pip install 'lfd-jax[mocap]' (or pip install ezc3d)") from err
    return ezc3d


# The C3D header's byte order and the byte holding the sign of its float scale factor, by the processor
# type stored in byte 4 of the parameter section: Intel (IEEE, little-endian), DEC (VAX floats: the
# sign in the high byte of the first 16-bit word), MIPS (IEEE, big-endian).
_C3D_PROCESSORS = {84: ("little", 15), 85: ("little", 13), 86: ("big", 12)}


def _check_c3d_length(path: Path) -> None:
    """ValueError naming `path` when the file holds fewer frames than its header states.

    From the 512-byte header (C3D user guide: 16-bit words 2 points, 3 analog samples per frame, 4
    and 5 the first and last frame, 7-8 the scale factor, negative for float data, 9 the first block
    of the data) and the file's size.
    """
    processor = b""
    with open(path, "rb") as f:
        head = f.read(512)
        if len(head) == 512 and head[1] == 0x50 and head[0] >= 2:  # 0x50: the C3D key; byte 1: the parameters' block
            f.seek(512 * (head[0] - 1) + 3)
            processor = f.read(1)
    if not processor or processor[0] not in _C3D_PROCESSORS:
        raise ValueError(f"path: cannot read {path} as C3D (no C3D header and parameter section)")
    order, sign_byte = _C3D_PROCESSORS[processor[0]]
    points, analog, first, last = (int.from_bytes(head[k:k + 2], order) for k in (2, 4, 6, 8))
    data_start = 512 * (int.from_bytes(head[16:18], order) - 1)
    frame_bytes = (4 * points + analog) * (4 if head[sign_byte] & 0x80 else 2)
    stated = last - first + 1
    if frame_bytes and stated > 0:
        held = max(0, path.stat().st_size - data_start) // frame_bytes
        if held < stated:
            raise ValueError(f"path: {path} header says {stated} frames, file holds {held} (a truncated file)")


def load_c3d(path) -> MarkerRecording:
    """The 3-D points of a C3D file (read by ezc3d), in metres; negative residuals and NaN are gaps.

    Args:
        path: the `.c3d` file.

    Returns:
        A `MarkerRecording`.

    Raises:
        ImportError: saying how to install ezc3d (the extra `mocap`) when it is absent.
        ValueError: naming `path` for a missing or unreadable file, or one that holds fewer frames than
            its header states.
    """
    path = _existing(path)
    ezc3d = _import_ezc3d()
    _check_c3d_length(path)
    try:
        c3d = ezc3d.c3d(str(path))
    except Exception as err:  # ezc3d raises RuntimeError/IOError for anything it cannot parse
        raise ValueError(f"path: cannot read {path} as C3D ({err})") from err
    point = c3d["parameters"]["POINT"]
    points = np.asarray(c3d["data"]["points"], float)  # (4, M, T)
    labels = [str(n).strip() for n in point["LABELS"]["value"]][:points.shape[1]]
    unit = str(point["UNITS"]["value"][0]) if "UNITS" in point and len(point["UNITS"]["value"]) else "mm"
    markers = np.moveaxis(points[:3], (0, 1, 2), (2, 1, 0)).copy()  # (T, M, 3)
    residuals = np.asarray(c3d["data"]["meta_points"]["residuals"], float)  # (1, M, T)
    markers[(residuals[0].T < 0)] = np.nan
    return make_recording(markers * _scale(unit, path), labels, float(point["RATE"]["value"][0]))


def load_markers(path) -> MarkerRecording:
    """Any supported marker file, by its suffix.

    Args:
        path: a `.csv` (Vicon Nexus), `.trc` or `.c3d` file; `.csv.xz` and `.trc.xz` are read through lzma.

    Returns:
        A `MarkerRecording`.

    Raises:
        ValueError: naming `path` for another suffix, a missing file or contents that break the format.
    """
    path = _existing(path)
    suffixes = [s.lower() for s in path.suffixes]
    kind = suffixes[-2] if suffixes[-1:] == [".xz"] and len(suffixes) > 1 else (suffixes[-1] if suffixes else "")
    loaders = {".csv": load_nexus_csv, ".trc": load_trc, ".c3d": load_c3d}
    if kind not in loaders or (kind == ".c3d" and suffixes[-1] == ".xz"):
        raise ValueError(f"path: expected a .csv (Vicon Nexus), .trc or .c3d marker file, got {path.name}")
    return loaders[kind](path)
