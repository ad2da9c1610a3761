"""2-D keypoint tracks (OpenPose) into one in-memory format: `KeypointTracks(xy (T, J, 2) float64
pixels, NaN where missed, confidence (T, J), names, rate_hz, time_s)`.

* **OpenPose JSON** (`--write_json`): one `*_keypoints.json` per frame,
  `{"version": ..., "people": [{"person_id": [-1], "pose_keypoints_2d": [x, y, c, ...], "hand_left_keypoints_2d":
  [...], "hand_right_keypoints_2d": [...], "face_keypoints_2d": [...]}, ...]}`; a keypoint not detected is
  x = y = c = 0; a part that was not run (hands, face) is an empty list. `load_openpose_folder` reads a
  folder of them (one video) and follows one person across the frames.
* **The reach-to-grasp release** (Dagioglou et al., HCII 2022): the upstream per-movement CSV
  (`<Joint>.x`, `<Joint>.y`, `<Joint>.prob` columns and `Time`, 0 = not detected; `load_reach_csv`) and
  its repacking `reach_grasp_openpose_p1-4.npz` (`load_reach_npz`: names, participant, size, size_cm,
  offsets, t, xy_dpx tenths of a pixel, prob, joints, rtg_onset, rtg_end).

Confidences are a field of their own beside the positions, not a third coordinate: `xy.reshape(T, -1)` is
the (T, 2 J) feature sequence the PHMM code takes (the layout of `MarkerRecording.markers`), and gap
filling (`fill_track_gaps`, through `markers.fill_gaps`) changes the positions only, so the confidence
of a filled frame stays 0 and says it was interpolated.
"""
from __future__ import annotations

import json
import os
import re
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from lfd_common import as_array, check_choice, check_int, check_real
from lfd_jax._src.marker_files import read_text
from lfd_jax._src.markers import chosen_indices, fill_gaps, make_recording

__all__ = ["BODY_25", "COCO_18", "HAND_21", "OPENPOSE_PARTS", "KeypointTracks", "ReachMovement", "crop_to_reach",
           "drop_untracked_keypoints", "fill_track_gaps", "is_openpose_folder", "load_openpose_folder",
           "load_reach_csv", "load_reach_npz", "make_tracks", "read_openpose_frame", "select_keypoints"]

BODY_25 = ("Nose", "Neck", "RShoulder", "RElbow", "RWrist", "LShoulder", "LElbow", "LWrist", "MidHip", "RHip",
           "RKnee", "RAnkle", "LHip", "LKnee", "LAnkle", "REye", "LEye", "REar", "LEar", "LBigToe", "LSmallToe",
           "LHeel", "RBigToe", "RSmallToe", "RHeel")
COCO_18 = ("Nose", "Neck", "RShoulder", "RElbow", "RWrist", "LShoulder", "LElbow", "LWrist", "RHip", "RKnee",
           "RAnkle", "LHip", "LKnee", "LAnkle", "REye", "LEye", "REar", "LEar")
HAND_21 = ("PalmBase", "Thumb1CMC", "Thumb2Knuckles", "Thumb3IP", "Thumb4FingerTip", "Index1Knuckles",
           "Index2PIP", "Index3DIP", "Index4FingerTip", "Middle1Knuckles", "Middle2PIP", "Middle3DIP",
           "Middle4FingerTip", "Ring1Knuckles", "Ring2PIP", "Ring3DIP", "Ring4FingerTip", "Pinky1Knuckles",
           "Pinky2PIP", "Pinky3DIP", "Pinky4FingerTip")
OPENPOSE_PARTS = ("pose", "hand_left", "hand_right", "face")
_PART_SIZES = {"hand_left": 21, "hand_right": 21, "face": 70}
_MAX_STEP = 0.5  # the followed person's keypoints move less than this fraction of its pose diagonal per frame
_MIN_GATE_PX = 10.0  # ... or less than this many pixels (a person seen by a few keypoints only)
_KEYPOINT_FILE = re.compile(r"^(.*?)(\d*)_keypoints\.json$")


class KeypointTracks(NamedTuple):
    """2-D keypoints of one person over time, the format every keypoint reader returns.

    Attributes:
        xy: (T, J, 2) float64 image positions in pixels (x right, y down), NaN where not detected.
        confidence: (T, J) float64 detector confidence, 0 where not detected (also in frames that
            `fill_track_gaps` filled).
        names: (J,) keypoint names (`BODY_25`, then `L`/`R` + `HAND_21` for the hands).
        rate_hz: the frame rate.
        time_s: (T,) seconds from the first frame (`arange(T) / rate_hz` unless the source has stamps).
    """

    xy: np.ndarray
    confidence: np.ndarray
    names: tuple[str, ...]
    rate_hz: float
    time_s: np.ndarray


class ReachMovement(NamedTuple):
    """One movement of the reach-to-grasp release (Dagioglou et al., HCII 2022).

    Attributes:
        name: e.g. `P4_L_09` (participant, object size, repetition).
        participant: the participant's number.
        size: the cube's size class, 'S', 'M' or 'L'.
        size_cm: its edge in centimetres (2.5, 5.5, 7.5).
        onset_s: the annotated onset of the reach-to-grasp phase, seconds on `tracks.time_s`.
        end_s: its end (contact with the cube), seconds.
        tracks: the movement's `KeypointTracks` (26 joints: Neck, RShoulder, RElbow, RWrist, MidHip
            and the right hand's 21 in the npz).
    """

    name: str
    participant: int
    size: str
    size_cm: float
    onset_s: float
    end_s: float
    tracks: KeypointTracks


def make_tracks(xy, confidence, names: Sequence[str], rate_hz: float, time_s=None) -> KeypointTracks:
    """Checked `KeypointTracks`.

    Args:
        xy: (T, J, 2) real pixel positions, NaN where not detected (±inf not allowed).
        confidence: (T, J) confidences, finite and >= 0.
        names: one unique name per keypoint.
        rate_hz: the frame rate, positive and finite.
        time_s: (T,) finite frame times in seconds, or None for `arange(T) / rate_hz`.

    Returns:
        The `KeypointTracks` (arrays as float64).

    Raises:
        ValueError: naming the argument that breaks one of the above.
    """
    xy = as_array(xy, "xy", shape=(None, None, 2), finite=False)
    if np.isinf(xy).any():
        raise ValueError("xy: contains infinite values (misses must be NaN)")
    confidence = as_array(confidence, "confidence", shape=xy.shape[:2], min_value=0.0)
    rate_hz = check_real(rate_hz, "rate_hz", min_value=0.0, exclusive_min=True)
    names = tuple(str(n) for n in names)
    if len(names) != xy.shape[1]:
        raise ValueError(f"names: expected {xy.shape[1]} names (one per keypoint), got {len(names)}")
    if len(set(names)) != len(names):
        raise ValueError(f"names: keypoint names must be unique, got duplicates "
                         f"{sorted({n for n in names if names.count(n) > 1})}")
    if time_s is None:
        time_s = np.arange(len(xy)) / rate_hz
    time_s = as_array(time_s, "time_s", shape=(len(xy),))
    return KeypointTracks(xy, confidence, names, rate_hz, time_s)


def _check_tracks(tracks) -> KeypointTracks:
    if not isinstance(tracks, KeypointTracks):
        raise ValueError(f"tracks: expected a KeypointTracks, got {type(tracks).__name__}")
    return tracks


def _part_names(part: str, n: int) -> tuple[str, ...]:
    if part == "pose":
        return BODY_25 if n == 25 else COCO_18 if n == 18 else tuple(f"Pose{k:02d}" for k in range(n))
    if part == "face":
        return tuple(f"Face{k:02d}" for k in range(n))
    return tuple(("L" if part == "hand_left" else "R") + name for name in HAND_21)


def read_openpose_frame(path, parts: Sequence[str] = ("pose", "hand_left", "hand_right")
                        ) -> dict[str, list[np.ndarray]]:
    """The people of one OpenPose `*_keypoints.json` file.

    Args:
        path: the JSON file.
        parts: which keypoint lists to read, among `OPENPOSE_PARTS`.

    Returns:
        {part: one (n, 3) float64 array (x, y, c) per person, in file order; (0, 3) where the part is an
        empty list}, plus "person_id": one int per person (-1 when OpenPose did not track).

    Raises:
        ValueError: naming `path` for a missing file, invalid JSON, no "people" list, or a keypoint list
            whose length is not a multiple of 3 (or not 21 triples for a hand, 70 for the face).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path: expected a file path, got {type(path).__name__}")
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"path: no such file {path}")
    for part in parts:
        check_choice(part, "parts", OPENPOSE_PARTS)
    try:
        people = json.loads(read_text(path))["people"]
        if not isinstance(people, list):
            raise TypeError("'people' is not a list")
        out: dict[str, list] = {part: [] for part in parts}
        out["person_id"] = []
        for person in people:
            pid = person.get("person_id", -1)
            if isinstance(pid, list):
                pid = pid[0] if pid else -1
            out["person_id"].append(int(pid))
            for part in parts:
                values = np.asarray(person.get(f"{part}_keypoints_2d", []), np.float64).reshape(-1)
                if values.size % 3 or (values.size and part in _PART_SIZES and values.size != 3 * _PART_SIZES[part]):
                    raise ValueError(f"{part}_keypoints_2d has {values.size} values, not "
                                     f"{'3 per keypoint' if part == 'pose' else f'{3 * _PART_SIZES[part]}'}")
                out[part].append(values.reshape(-1, 3))
    except (json.JSONDecodeError, KeyError, TypeError, ValueError, AttributeError) as err:
        raise ValueError(f"path: {path} is not an OpenPose keypoints file ({type(err).__name__}: {err})") from err
    return out


def is_openpose_folder(path) -> bool:
    """Whether `path` is a folder holding at least one `*_keypoints.json` file."""
    path = Path(path)
    return path.is_dir() and any(path.glob("*_keypoints.json"))


def _frame_files(folder: Path) -> tuple[list[Path], np.ndarray]:
    """The keypoint files of one video and their frame index (from the number before `_keypoints`)."""
    files = sorted(folder.glob("*_keypoints.json"))
    if not files:
        raise ValueError(f"path: {folder} holds no *_keypoints.json files")
    matches = [_KEYPOINT_FILE.match(f.name) for f in files]
    prefixes = sorted({m.group(1) for m in matches})
    if len(prefixes) > 1:
        raise ValueError(f"path: {folder} holds the keypoint files of several videos ({', '.join(prefixes[:4])}"
                         f"{' ...' if len(prefixes) > 4 else ''}); give one folder per video")
    if all(m.group(2) for m in matches):
        numbers = np.array([int(m.group(2)) for m in matches])
        order = np.argsort(numbers, kind="stable")
        files, numbers = [files[k] for k in order], numbers[order]
        if len(np.unique(numbers)) != len(numbers):
            raise ValueError(f"path: {folder} has two keypoint files with the same frame number")
        return files, numbers - numbers[0]
    return files, np.arange(len(files))


def _diagonal(pose: np.ndarray) -> float:
    """The diagonal of the bounding box of one person's detected pose keypoints, pixels."""
    xy = pose[pose[:, 2] > 0, :2]
    return float(np.linalg.norm(xy.max(0) - xy.min(0))) if len(xy) else 0.0


def _step(poses: np.ndarray, last: np.ndarray) -> np.ndarray:
    """(P,) mean distance, pixels, of each person's pose keypoints from the followed person's last pose,
    over the keypoints detected in both (inf: none in common)."""
    common = (poses[..., 2] > 0) & (last[:, 2] > 0)
    distance = np.linalg.norm(poses[..., :2] - last[:, :2], axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(common, distance, 0.0).sum(1) / common.sum(1)
    return np.where(common.any(1), mean, np.inf)


def _choose_people(poses: list[np.ndarray]) -> np.ndarray:
    """The person followed in each frame: (F,) index into that frame's people, -1 for none.

    The first frame with a detected person starts with its most confident one (largest summed pose
    confidence); every later frame takes the person nearest to the followed person's last pose (`_step`),
    if that is within `_MAX_STEP` of the last pose's diagonal (at least `_MIN_GATE_PX`); otherwise the
    followed person is missed in that frame (another person is not taken).
    """
    chosen = np.full(len(poses), -1)
    last, gate = None, np.inf
    for f, pose in enumerate(poses):
        seen = (pose[..., 2] > 0).any(-1) if len(pose) else np.zeros(0, bool)
        if not seen.any():
            continue
        if last is None:
            k = int(np.argmax(np.where(seen, pose[..., 2].sum(1), -np.inf)))
        else:
            step = _step(pose, last)
            k = int(np.argmin(step))
            if step[k] > gate:
                continue
        chosen[f], last = k, pose[k]
        gate = max(_MAX_STEP * _diagonal(pose[k]), _MIN_GATE_PX)
    return chosen


def load_openpose_folder(path, rate_hz: float, *, person: int | None = None,
                         parts: Sequence[str] = ("pose", "hand_left", "hand_right"),
                         min_confidence: float = 0.0) -> KeypointTracks:
    """One person's keypoints over a folder of OpenPose `*_keypoints.json` files (one video).

    Frames are ordered by the number before `_keypoints.json` (OpenPose's `<video>_000000000012_
    keypoints.json`); a number absent from the run is a frame with every keypoint missing. The person:
    `person=k` takes the k-th entry of "people" in every frame; by default the person is followed
    frame to frame: the most confident person (summed pose confidence) of the first frame with anyone,
    then in each frame the person nearest to the followed person's last pose (the mean distance of the
    pose keypoints detected in both, the neck among them), unless that is further than half the
    diagonal of the last pose's bounding box (at least 10 px): then the followed person is missed in
    that frame rather than swapped for another. OpenPose's `person_id` is -1 unless it ran with
    `--tracking`, so it is not used.

    Args:
        path: the folder.
        rate_hz: the video's frame rate (OpenPose's JSON does not hold it).
        person: None to follow the nearest person, or an index into each frame's "people".
        parts: the keypoint lists read, among `OPENPOSE_PARTS`, in this order: `pose` (BODY_25 or
            COCO_18 names), `hand_left` / `hand_right` (`L` / `R` + `HAND_21`), `face` (`Face00`...).
        min_confidence: keypoints with a confidence at or below it are misses (0: only c = 0 is).

    Returns:
        `KeypointTracks`; a part that a frame lacks (an empty list, or a person without it) is NaN there.

    Raises:
        ValueError: naming `path` for a missing folder, no keypoint files, files of several videos, a
            malformed file (naming that file) or a part whose keypoint count changes between files;
            naming `rate_hz`, `person`, `parts` or `min_confidence` when invalid.
    """
    if not isinstance(path, (str, os.PathLike)) or not Path(path).is_dir():
        raise ValueError(f"path: no such folder {path}")
    rate_hz = check_real(rate_hz, "rate_hz", min_value=0.0, exclusive_min=True)
    if person is not None:
        person = check_int(person, "person", min_value=0)
    parts = tuple(check_choice(p, "parts", OPENPOSE_PARTS) for p in parts)
    if not parts or len(set(parts)) != len(parts):
        raise ValueError(f"parts: expected distinct parts among {OPENPOSE_PARTS}, got {parts!r}")
    min_confidence = check_real(min_confidence, "min_confidence", min_value=0.0)
    read = ("pose",) + tuple(p for p in parts if p != "pose")  # the pose is what people are followed by
    files, index = _frame_files(Path(path))
    frames = [read_openpose_frame(f, read) for f in files]
    sizes = {}
    for f, frame in zip(files, frames):
        for part in read:
            for arr in frame[part]:
                if len(arr) and sizes.setdefault(part, len(arr)) != len(arr):
                    raise ValueError(f"path: {f} has {len(arr)} {part} keypoints, earlier files {sizes[part]}")
    sizes = {part: sizes.get(part, _PART_SIZES.get(part, 25)) for part in read}
    names = tuple(n for part in parts for n in _part_names(part, sizes[part]))
    poses = [np.stack([a if len(a) else np.zeros((sizes["pose"], 3)) for a in frame["pose"]])
             if frame["pose"] else np.zeros((0, sizes["pose"], 3)) for frame in frames]
    if person is None:
        chosen = _choose_people(poses)
    else:
        chosen = np.array([person if person < len(frame["pose"]) else -1 for frame in frames])
    table = np.zeros((index[-1] + 1, len(names), 3))
    for f, frame in enumerate(frames):
        if chosen[f] >= 0:
            table[index[f]] = np.concatenate([frame[part][chosen[f]] if len(frame[part][chosen[f]])
                                              else np.zeros((sizes[part], 3)) for part in parts])
    return _tracks_from_table(table[..., :2], table[..., 2], names, rate_hz, None, min_confidence)


def _tracks_from_table(xy, confidence, names, rate_hz, time_s, min_confidence=0.0) -> KeypointTracks:
    """Tracks from raw detector output: c <= min_confidence (c = 0 included) or x = y = 0 is a miss."""
    missed = (confidence <= min_confidence) | (confidence == 0) | (xy == 0).all(-1)
    xy = np.where(missed[..., None], np.nan, xy)
    return make_tracks(xy, np.nan_to_num(confidence), names, rate_hz, time_s)


def _rate_of(time_s: np.ndarray, where: str) -> float:
    steps = np.diff(time_s)
    steps = steps[steps > 0]
    if not len(steps):
        raise ValueError(f"path: {where} has no increasing time stamps to give a frame rate")
    return float(1.0 / np.median(steps))


def load_reach_csv(path) -> KeypointTracks:
    """One movement of the reach-to-grasp release in its upstream CSV layout.

    The layout (the release's README): a header row, then one row per frame: `<Joint>.x`, `<Joint>.y`,
    `<Joint>.prob` for each joint (0, 0, 0 when OpenPose missed it) and `Time` (seconds from the first
    frame). Joints are kept in the header's order; the rate is 1 / the median positive time step
    (the stamps are irregular, a few repeat).

    Args:
        path: the `.csv` file (e.g. `P4/P4_L_09.csv`).

    Returns:
        `KeypointTracks` with `time_s` the file's `Time` column.

    Raises:
        ValueError: naming `path` for a missing file, a header without `Time` or without the three
            columns of a joint, or rows that are not numbers.
    """
    if not isinstance(path, (str, os.PathLike)) or not Path(path).is_file():
        raise ValueError(f"path: no such file {path}")
    path = Path(path)
    lines = [line for line in read_text(path).splitlines() if line.strip()]
    if len(lines) < 2:
        raise ValueError(f"path: {path} has no frames")
    header = [c.strip() for c in lines[0].split(",")]
    joints = list(dict.fromkeys(c.rsplit(".", 1)[0] for c in header if c.endswith((".x", ".y", ".prob"))))
    columns = {c: k for k, c in enumerate(header)}
    lacking = [f"{j}{s}" for j in joints for s in (".x", ".y", ".prob") if f"{j}{s}" not in columns]
    if "Time" not in columns or not joints or lacking:
        raise ValueError(f"path: {path} is not a reach CSV (expected 'Time' and '<joint>.x/.y/.prob' columns; "
                         f"lacking {lacking[:3] or (['Time'] if 'Time' not in columns else ['joint columns'])})")
    try:
        table = np.array([[float(v) if v.strip() else np.nan for v in line.split(",")] for line in lines[1:]])
    except ValueError as err:
        raise ValueError(f"path: {path} has a row that is not numbers ({err})") from err
    if table.ndim != 2 or table.shape[1] != len(header):
        raise ValueError(f"path: {path} has rows of another length than its header ({len(header)} columns)")
    xy = np.stack([table[:, [columns[f"{j}.x"], columns[f"{j}.y"]]] for j in joints], axis=1)
    prob = table[:, [columns[f"{j}.prob"] for j in joints]]
    time_s = table[:, columns["Time"]]
    return _tracks_from_table(xy, prob, joints, _rate_of(time_s, str(path)), time_s)


_REACH_KEYS = ("names", "participant", "size", "size_cm", "offsets", "t", "xy_dpx", "prob", "joints", "rtg_onset",
               "rtg_end")


def load_reach_npz(path, movements: str | Sequence[str] | None = None) -> list[ReachMovement]:
    """The movements of the reach-to-grasp npz (`reach_grasp_openpose_p1-4.npz`).

    Positions are `xy_dpx / 10` pixels (0 = not detected -> NaN), confidences `prob`, times `t`; each
    movement's rate is 1 / its median positive time step (about 60 Hz).

    Args:
        path: the `.npz` file.
        movements: None for all; a regular expression searched in each movement's name (e.g.
            `"^P[12]_"`, `"_L_"`); or a sequence of names (each must be present).

    Returns:
        The chosen `ReachMovement`s, in the file's order.

    Raises:
        ValueError: naming `path` for a missing or unreadable file or one that lacks a key of the layout or
            has inconsistent shapes; naming `movements` for an invalid expression, names the file lacks,
            or a selection that is empty.
    """
    if not isinstance(path, (str, os.PathLike)) or not Path(path).is_file():
        raise ValueError(f"path: no such file {path}")
    if not zipfile.is_zipfile(path):  # truncated, or a .npy / other file np.load would read or try to unpickle
        raise ValueError(f"path: cannot read {path} as npz (not a complete zip archive)")
    try:
        with np.load(path, allow_pickle=False) as data:
            absent = [k for k in _REACH_KEYS if k not in data.files]
            if absent:
                raise ValueError(f"path: {path} lacks {absent} of the reach layout")
            d = {k: data[k] for k in _REACH_KEYS}
    except (OSError, EOFError, zipfile.BadZipFile) as err:  # BadZipFile: a truncated npz
        raise ValueError(f"path: cannot read {path} as npz ({err})") from err
    names = [str(n) for n in d["names"]]
    offsets, n_frames, n_joints = d["offsets"].astype(int), len(d["t"]), len(d["joints"])
    if (len(offsets) != len(names) + 1 or offsets[0] != 0 or offsets[-1] != n_frames or np.any(np.diff(offsets) < 1)
            or d["xy_dpx"].shape != (n_frames, n_joints, 2) or d["prob"].shape != (n_frames, n_joints)
            or any(len(d[k]) != len(names) for k in ("participant", "size", "size_cm", "rtg_onset", "rtg_end"))):
        raise ValueError(f"path: {path} has inconsistent shapes (offsets {offsets.shape} for {len(names)} movements, "
                         f"xy_dpx {d['xy_dpx'].shape}, prob {d['prob'].shape}, t {d['t'].shape})")
    if movements is None:
        keep = list(range(len(names)))
    elif isinstance(movements, str):
        try:
            pattern = re.compile(movements)
        except re.error as err:
            raise ValueError(f"movements: {movements!r} is not a regular expression ({err})") from err
        keep = [k for k, n in enumerate(names) if pattern.search(n)]
    else:
        absent = [m for m in movements if m not in names]
        if absent:
            raise ValueError(f"movements: {path} has no movement(s) {absent[:5]}")
        keep = [names.index(m) for m in movements]
    if not keep:
        raise ValueError(f"movements: {movements!r} selects none of the {len(names)} movements in {path}")
    joints = [str(j) for j in d["joints"]]
    out = []
    for k in keep:
        rows = slice(offsets[k], offsets[k + 1])
        time_s = d["t"][rows].astype(np.float64)
        tracks = _tracks_from_table(d["xy_dpx"][rows].astype(np.float64) / 10.0, d["prob"][rows].astype(np.float64),
                                    joints, _rate_of(time_s, f"{path} movement {names[k]}"), time_s)
        out.append(ReachMovement(names[k], int(d["participant"][k]), str(d["size"][k]), float(d["size_cm"][k]),
                                 float(d["rtg_onset"][k]), float(d["rtg_end"][k]), tracks))
    return out


def crop_to_reach(movement: ReachMovement) -> KeypointTracks:
    """The frames of a movement's reach-to-grasp phase: onset <= time <= end (the release's rule).

    Args:
        movement: a `ReachMovement`.

    Returns:
        Its `KeypointTracks` cut to those frames (`time_s` still from the movement's first frame).

    Raises:
        ValueError: when `movement` is not a `ReachMovement` or no frame lies in the phase.
    """
    if not isinstance(movement, ReachMovement):
        raise ValueError(f"movement: expected a ReachMovement, got {type(movement).__name__}")
    tracks = movement.tracks
    inside = (tracks.time_s >= movement.onset_s) & (tracks.time_s <= movement.end_s)
    if not inside.any():
        raise ValueError(f"movement: {movement.name} has no frame between {movement.onset_s} and {movement.end_s} s")
    return tracks._replace(xy=tracks.xy[inside], confidence=tracks.confidence[inside], time_s=tracks.time_s[inside])


def select_keypoints(tracks: KeypointTracks, names: Sequence[str]) -> KeypointTracks:
    """Some of the keypoints, in a given order.

    Args:
        tracks: the `KeypointTracks`.
        names: the keypoints to keep, in the order wanted.

    Returns:
        The tracks with those keypoints only.

    Raises:
        ValueError: naming the keypoints the tracks lack, a keypoint named twice, or for an empty
            `names`.
    """
    tracks = _check_tracks(tracks)
    index = chosen_indices(names, tracks.names, "keypoint", "tracks")
    return tracks._replace(xy=tracks.xy[:, index], confidence=tracks.confidence[:, index], names=tuple(names))


def drop_untracked_keypoints(tracks: KeypointTracks) -> KeypointTracks:
    """The tracks without the keypoints never detected (a hand that was not run, say).

    Args:
        tracks: the `KeypointTracks`.

    Returns:
        The tracks with the keypoints detected at least once.

    Raises:
        ValueError: when no keypoint is left.
    """
    tracks = _check_tracks(tracks)
    seen = ~np.isnan(tracks.xy).any(-1).all(0)
    if not seen.any():
        raise ValueError("tracks: no keypoint is detected in any frame")
    return select_keypoints(tracks, [n for n, s in zip(tracks.names, seen) if s])


def fill_track_gaps(tracks: KeypointTracks, max_gap_s: float = 0.2, *, max_gap_frames: int | None = None
                    ) -> KeypointTracks:
    """Short misses filled by linear interpolation in time, per keypoint (`fill_gaps` of the markers).

    Args:
        tracks: the `KeypointTracks`.
        max_gap_s: the longest gap filled, in seconds at `tracks.rate_hz` (rounded down to frames).
        max_gap_frames: the longest gap filled, in frames (overrides `max_gap_s`).

    Returns:
        The tracks with their gaps filled; `confidence` unchanged (0 in the filled frames).

    Raises:
        ValueError: naming the keypoint and its frames for a longer gap (a keypoint never detected is
            such a gap: drop it first with `drop_untracked_keypoints`), or naming an invalid argument.
    """
    tracks = _check_tracks(tracks)
    as_markers = np.concatenate([tracks.xy, np.zeros(tracks.xy.shape[:2] + (1,))], axis=-1)
    try:
        filled = fill_gaps(make_recording(as_markers, tracks.names, tracks.rate_hz), max_gap_s,
                           max_gap_frames=max_gap_frames)
    except ValueError as err:
        raise ValueError(str(err).replace("recording: marker", "tracks: keypoint", 1)) from err
    return tracks._replace(xy=filled.markers[..., :2])
