"""`lfd-jax phmm fit` / `lfd-jax phmm recognize`: one explicit-duration HMM of `phmm_jax` per
movement class, fitted on one's own marker files or 2-D keypoint tracks and used to classify others.

An input is one of: a marker file (`lfd_jax.load_markers`, by suffix: Vicon Nexus .csv, .trc, .c3d;
.csv.xz / .trc.xz); a folder of OpenPose `*_keypoints.json` files (`lfd_jax.load_openpose_folder`, one
video, at `rate_hz`, one `person` followed); a CSV of the reach-to-grasp release (`lfd_jax.load_reach_csv`,
told from a Nexus CSV by its `Time` and `<joint>.prob` columns); the reach npz (`lfd_jax.load_reach_npz`:
every movement, or those `--movements` selects, is one input named by the movement, its class by
default the object size; `reach_phase` cuts it to the annotated reach-to-grasp phase).
It becomes a feature sequence in four steps, the same at fit and at recognition time: the chosen
markers / keypoints (default every one seen in all training inputs) -> short gaps filled by linear
interpolation (`fill_gaps` / `fill_track_gaps`, `max_gap_s`; a longer gap is an error naming the
marker) -> optionally minus one reference marker, frame by frame (`relative_to`) -> resampled to
`n_frames` frames (`resample_frames`; 0 keeps the recorded length) -> (T, 3 M) positions in metres, or
(T, 2 J) pixel positions for keypoints (one model takes one kind).

The model is a folder, because a `phmm_jax.save` file holds one model: `<class>.npz` per class and
`model.json` with the class order, the markers and the settings. Recognition scores every file
under every class's HMM (`phmm_jax.log_likelihood`) and takes the largest.
"""
from __future__ import annotations

import dataclasses
import json
import os
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

import phmm_jax
from lfd_common import markdown_table, progress
from lfd_jax._src.marker_files import load_markers
from lfd_jax._src.markers import MarkerRecording, drop_untracked_markers, fill_gaps, resample_frames, select_markers
from lfd_jax._src.openpose import (KeypointTracks, crop_to_reach, drop_untracked_keypoints, fill_track_gaps,
                                   is_openpose_folder, load_openpose_folder, load_reach_csv, load_reach_npz,
                                   select_keypoints)
from lfd_common import check_int, check_real, enable_compilation_cache

MANIFEST = "model.json"
MARKER_SUFFIXES = (".csv", ".trc", ".c3d", ".csv.xz", ".trc.xz")
CLASS_NAME = re.compile(r"[\w.+-]+")
INPUT_KEYS = ("kind", "rate_hz", "person", "min_confidence", "reach_phase")
MARKER_INPUTS = {"kind": "markers", "rate_hz": 30.0, "person": None, "min_confidence": 0.0, "reach_phase": False}


@dataclasses.dataclass(frozen=True)
class FitSettings:
    """What `phmm fit` does: the HMMs' structure (`phmm_jax.HMMConfig`; max_duration None is the
    classical HMM with self-loops), the EM options (`phmm_jax.FitOptions`) and the preprocessing
    (module docstring; markers () = every marker seen in all training files) and how keypoint inputs
    are read: OpenPose folders at `rate_hz`, following `person` (None: the nearest person frame to
    frame), keypoints at or below `min_confidence` as misses; reach npz movements cut to their
    reach-to-grasp phase when `reach_phase`."""

    n_states: int = 20
    min_duration: int = 4
    max_duration: int | None = 6
    covariance_type: str = "diag"
    max_iter: int = 50
    reg_covar: float = 1e-4
    n_frames: int = 100
    max_gap_s: float = 0.2
    markers: tuple[str, ...] = ()
    relative_to: str | None = None
    rate_hz: float = 30.0
    person: int | None = None
    min_confidence: float = 0.0
    reach_phase: bool = False

    def __post_init__(self):
        check_real(self.rate_hz, "rate_hz", min_value=0.0, exclusive_min=True)
        if self.person is not None:
            check_int(self.person, "person", min_value=0)
        check_real(self.min_confidence, "min_confidence", min_value=0.0)
        if not isinstance(self.reach_phase, bool):
            raise ValueError(f"reach_phase: expected true or false, got {self.reach_phase!r}")
        self.hmm_config()
        self.fit_options()
        if check_int(self.n_frames, "n_frames", min_value=0) == 1:
            raise ValueError("n_frames: expected 0 (keep the recorded length) or at least 2")
        check_real(self.max_gap_s, "max_gap_s", min_value=0.0)
        if not isinstance(self.markers, tuple) or not all(isinstance(m, str) for m in self.markers):
            raise ValueError(f"markers: expected a list of marker names, got {self.markers!r}")
        if self.relative_to is not None and not isinstance(self.relative_to, str):
            raise ValueError(f"relative_to: expected a marker name, got {self.relative_to!r}")
        if self.relative_to in self.markers:
            raise ValueError(f"markers: the reference marker {self.relative_to!r} cannot also be a feature")
        if self.n_frames and self.max_duration is not None:
            shortest, longest = self.n_states * self.min_duration, self.n_states * self.max_duration
            if not shortest <= self.n_frames <= longest:
                raise ValueError(f"n_frames: {self.n_frames} frames fit no path of {self.n_states} states of "
                                 f"{self.min_duration}-{self.max_duration} frames ({shortest}-{longest})")

    def hmm_config(self) -> phmm_jax.HMMConfig:
        """The HMMs' structure; ValueError naming the field that is invalid."""
        return phmm_jax.HMMConfig(self.n_states, self.min_duration, self.max_duration, self.covariance_type)

    def fit_options(self) -> phmm_jax.FitOptions:
        """How EM fits them; ValueError naming the field that is invalid."""
        return phmm_jax.FitOptions(max_iter=self.max_iter, reg_covar=self.reg_covar)


def settings_from(args) -> FitSettings:
    """Defaults < the --config JSON object < the flags given; ValueError naming what is wrong."""
    fields = {f.name for f in dataclasses.fields(FitSettings)}
    values: dict = {}
    if args.config is not None:
        try:
            values = json.loads(Path(args.config).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:  # a binary file, a folder, ...
            raise ValueError(f"--config: cannot read {args.config} as a JSON text file ({err})") from err
        if not isinstance(values, dict) or set(values) - fields:
            unknown = sorted(set(values) - fields) if isinstance(values, dict) else values
            raise ValueError(f"--config: {args.config} must hold a JSON object with keys among {sorted(fields)}, "
                             f"got {unknown!r}")
    flags = {name: getattr(args, name) for name in fields if getattr(args, name, None) is not None}
    if isinstance(flags.get("markers"), str):
        flags["markers"] = [m.strip() for m in flags["markers"].split(",") if m.strip()]
    values.update(flags)
    if values.get("max_duration") == 0:
        values["max_duration"] = None
    if "markers" in values and isinstance(values["markers"], list):
        values["markers"] = tuple(values["markers"])
    return FitSettings(**values)


def is_marker_file(path: Path) -> bool:
    """A file with one of the suffixes `load_markers` reads."""
    return path.is_file() and path.name.lower().endswith(MARKER_SUFFIXES)


def is_input(path: Path) -> bool:
    """A marker file (a reach CSV included) or a folder of OpenPose keypoint files."""
    return is_marker_file(path) or is_openpose_folder(path)


def is_reach_csv(path: Path) -> bool:
    """A `.csv` whose header has the reach release's `Time` and `<joint>.prob` columns."""
    if path.suffix.lower() != ".csv":
        return False
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        header = [c.strip() for c in f.readline().split(",")]
    return "Time" in header and any(c.endswith(".prob") for c in header)


class Item(NamedTuple):
    """One input: its name (searched by --label), where it came from, what was read, and the class a
    reach movement has without --label (its object size; None for other inputs)."""

    name: str
    source: Path
    recording: MarkerRecording | KeypointTracks
    default_class: str | None


def input_options(settings: FitSettings) -> dict:
    """The manifest's "inputs": how inputs were read (the kind is set once they are)."""
    return {"kind": None, **{k: getattr(settings, k) for k in INPUT_KEYS[1:]}}


def read_inputs(path: Path, inputs: dict, movements: str | None) -> list[Item]:
    """The inputs in one path (module docstring); ValueError naming the path for a bad one."""
    path = Path(path)
    if is_openpose_folder(path):
        tracks = load_openpose_folder(path, inputs["rate_hz"], person=inputs["person"],
                                      min_confidence=inputs["min_confidence"])
        return [Item(path.name, path, tracks, None)]
    if path.is_dir():
        raise ValueError(f"path: {path} is a folder without *_keypoints.json files (not an OpenPose folder)")
    if path.suffix.lower() == ".npz":
        return [Item(m.name, path, crop_to_reach(m) if inputs["reach_phase"] else m.tracks, m.size)
                for m in load_reach_npz(path, movements)]
    if is_reach_csv(path):
        return [Item(path.name, path, load_reach_csv(path), None)]
    return [Item(path.name, path, load_markers(path), None)]


def kind_of(items: list[Item]) -> str:
    """"markers" or "keypoints"; ValueError when the inputs mix them."""
    kinds = {"keypoints" if isinstance(i.recording, KeypointTracks) else "markers" for i in items}
    if len(kinds) > 1:
        raise ValueError("dir: the inputs mix marker files and keypoint tracks; one model takes one kind")
    return kinds.pop()


def label_of(path: Path, pattern: re.Pattern) -> str | None:
    """The first group of `pattern` searched in the file's name (None when it does not match)."""
    return label_of_name(path.name, pattern)


def compile_label(label: str) -> re.Pattern:
    """The --label expression compiled; ValueError naming `label` when it is invalid or has no group."""
    try:
        pattern = re.compile(label)
    except re.error as err:
        raise ValueError(f"label: {label!r} is not a regular expression ({err})") from err
    if pattern.groups < 1:
        raise ValueError(f"label: {label!r} has no group; put the class in parentheses, e.g. '([FADC])[LR]\\d'")
    return pattern


def training_files(root: Path, label: str | None) -> list[tuple[Path, str]]:
    """(input, class) of every training input: DIR/<class>/<marker files or OpenPose folders>, or every
    marker file or OpenPose folder under DIR whose name `label` matches (its first group the class)."""
    if not root.is_dir():
        raise FileNotFoundError(f"dir: no such folder {root}")
    if label is None:
        pairs = [(f, d.name) for d in sorted(p for p in root.iterdir() if p.is_dir() and not is_openpose_folder(p))
                 for f in sorted(d.iterdir()) if is_input(f)]
        where = (f"class folders {root}/<class>/ with marker files ({', '.join(MARKER_SUFFIXES)}) or OpenPose "
                 f"folders")
    else:
        pattern = compile_label(label)
        walked = list(os.walk(root, followlinks=True))
        paths = sorted([Path(folder) / name for folder, _, names in walked for name in names]
                       + [Path(folder) for folder, _, _ in walked])
        pairs = [(f, c) for f in paths if is_input(f) and (c := label_of(f, pattern))]
        where = f"marker files or OpenPose folders under {root} whose names match '{label}'"
    if not pairs:
        raise ValueError(f"dir: found no {where}")
    check_classes(c for _, c in pairs)
    return pairs


def check_classes(classes) -> None:
    """ValueError naming `label` for a class that is not a plain name."""
    for name in classes:
        if not CLASS_NAME.fullmatch(name):
            raise ValueError(f"label: class {name!r} is not a plain name (letters, digits, . + - _)")


def training_items(root: Path, label: str | None, inputs: dict, movements: str | None) -> list[tuple[Item, str]]:
    """(input, class) of every training input: `training_files` of a folder, or the movements of a reach
    npz (class: the --label group of the movement's name, else its object size)."""
    if root.is_file():
        if root.suffix.lower() != ".npz":
            raise ValueError(f"dir: expected a folder or a reach .npz file, got {root}")
        pattern = compile_label(label) if label else None
        pairs = [(i, label_of_name(i.name, pattern) if pattern else i.default_class)
                 for i in read_inputs(root, inputs, movements)]
        pairs = [(i, c) for i, c in pairs if c]
        if not pairs:
            raise ValueError(f"label: {label!r} matches none of the movements of {root}")
        check_classes(c for _, c in pairs)
        return pairs
    if movements is not None:
        raise ValueError("movements: --movements selects movements of a reach .npz file; DIR is a folder")
    pairs = training_files(root, label)
    return [(item, c) for path, c in progress(pairs, desc="reading inputs")
            for item in read_inputs(path, inputs, None)]


def label_of_name(name: str, pattern: re.Pattern) -> str | None:
    """The first group of `pattern` searched in `name` (None when it does not match)."""
    match = pattern.search(name)
    return None if match is None else match.group(1)


def seen_names(recording) -> set[str]:
    """The markers / keypoints of a recording seen at least once."""
    if isinstance(recording, KeypointTracks):
        return set(drop_untracked_keypoints(recording).names)
    return set(drop_untracked_markers(recording).names)


def common_markers(recordings, relative_to: str | None) -> tuple[str, ...]:
    """The markers seen in every recording, in the first recording's order (without `relative_to`)."""
    seen = [seen_names(r) for r in recordings]
    names = tuple(n for n in recordings[0].names if all(n in s for s in seen) and n != relative_to)
    if not names:
        raise ValueError("markers: no marker is seen in every training file; choose them with --markers")
    return names


def features(path: Path, recording, markers: tuple[str, ...], relative_to: str | None, max_gap_s: float,
             n_frames: int) -> np.ndarray:
    """(T, 3 M) positions in metres of `markers` of the recording read from `path`, or (T, 2 J) pixels
    for keypoint tracks (module docstring); ValueError naming the file."""
    names = markers + ((relative_to,) if relative_to else ())
    try:
        if isinstance(recording, KeypointTracks):
            positions = fill_track_gaps(select_keypoints(recording, names), max_gap_s).xy
        else:
            positions = fill_gaps(select_markers(recording, names), max_gap_s).markers
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from err
    if relative_to:
        positions = positions[:, :-1] - positions[:, -1:]
    if n_frames:
        positions = resample_frames(positions, n_frames)
    return positions.reshape(len(positions), -1)


def scores(hmms: list, sequences: list[np.ndarray]) -> np.ndarray:
    """(B, K) log-likelihood of every sequence under every HMM."""
    return np.stack([np.asarray(phmm_jax.log_likelihood(hmm, sequences)) for hmm in hmms], axis=1)


def fit(args) -> int:
    """Fit and write the model folder; print the classes and the training-set accuracy."""
    settings = settings_from(args)
    inputs = input_options(settings)
    pairs = training_items(args.dir, args.label, inputs, getattr(args, "movements", None))
    recordings = [item.recording for item, _ in pairs]
    inputs["kind"] = kind_of([item for item, _ in pairs])
    markers = settings.markers or common_markers(recordings, settings.relative_to)
    manifest = {"classes": sorted({c for _, c in pairs}), "markers": list(markers),
                "preprocessing": {"relative_to": settings.relative_to, "max_gap_s": settings.max_gap_s,
                                  "n_frames": settings.n_frames},
                "inputs": inputs, "settings": dataclasses.asdict(settings)}
    sequences = [features(item.source / item.name if item.source.suffix == ".npz" else item.source,
                          item.recording, markers, **manifest["preprocessing"]) for item, _ in pairs]
    classes = manifest["classes"]
    truth = np.array([classes.index(c) for _, c in pairs])
    enable_compilation_cache()
    hmms = []
    for k in progress(range(len(classes)), desc="fitting HMMs"):
        own = [s for s, t in zip(sequences, truth) if t == k]
        hmms.append(phmm_jax.fit_hmm(own, config=settings.hmm_config(), options=settings.fit_options()))
    args.out.mkdir(parents=True, exist_ok=True)
    for name, hmm in zip(classes, hmms):
        phmm_jax.save(args.out / f"{name}.npz", hmm)
    (args.out / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
    predicted = scores(hmms, sequences).argmax(axis=1)
    rows = [(name, int(np.sum(truth == k)), f"{np.mean(predicted[truth == k] == k):.0%}")
            for k, name in enumerate(classes)]
    what = "keypoints (pixels)" if inputs["kind"] == "keypoints" else "markers"
    print(f"{len(pairs)} inputs, {len(markers)} {what} -> D = {sequences[0].shape[1]} features; "
          f"HMM {settings.n_states} states, durations {settings.min_duration}-{settings.max_duration or 'inf'}")
    print(markdown_table(("class", "training files", "recognised on its own training files"), rows))
    print(f"wrote {args.out}/ ({MANIFEST} and {len(classes)} phmm_jax models)")
    return 0


def load_model_folder(folder: Path) -> tuple[dict, list]:
    """(manifest, one HMM per class) of a folder written by `fit`; ValueError naming the manifest when
    it is not one (no classes, a class that is not a plain name, missing keys)."""
    manifest_path = Path(folder) / MANIFEST
    if not manifest_path.is_file():
        raise FileNotFoundError(f"model: no {MANIFEST} in {folder} (write a model folder with 'lfd-jax phmm fit')")
    try:
        manifest = json.loads(manifest_path.read_text())
        valid = (isinstance(manifest["classes"], list) and isinstance(manifest["markers"], list)
                 and set(manifest["preprocessing"]) == {"relative_to", "max_gap_s", "n_frames"})
        inputs = {**MARKER_INPUTS, **manifest.get("inputs", {})}  # folders written before keypoint inputs
        valid = valid and set(inputs) == set(INPUT_KEYS) and inputs["kind"] in ("markers", "keypoints")
    except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError, AttributeError) as err:
        raise ValueError(f"model: {manifest_path} is not a model manifest ({err})") from err
    if not valid:
        raise ValueError(f"model: {manifest_path} is not a model manifest (classes, markers, preprocessing)")
    classes = manifest["classes"]
    if not classes or not all(isinstance(c, str) and CLASS_NAME.fullmatch(c) for c in classes):
        raise ValueError(f"model: {manifest_path} lists classes {classes!r}; expected one or more class names "
                         f"(write the folder with 'lfd-jax phmm fit')")
    manifest["inputs"] = inputs
    return manifest, [phmm_jax.load(Path(folder) / f"{name}.npz") for name in manifest["classes"]]


def recognize(args) -> int:
    """Print each file's class and its log-likelihood under every class (and the accuracy with --label)."""
    manifest, hmms = load_model_folder(args.model)
    classes = manifest["classes"]
    pattern = compile_label(args.label) if args.label else None
    movements = getattr(args, "movements", None)
    if movements is not None and not any(Path(f).suffix.lower() == ".npz" for f in args.files):
        raise ValueError("movements: --movements selects movements of a reach .npz file; no FILE is one")
    items = [item for path in progress(args.files, desc="reading inputs")
             for item in read_inputs(path, manifest["inputs"], movements)]
    kind = kind_of(items)
    if kind != manifest["inputs"]["kind"]:
        raise ValueError(f"files: the model was fitted on {manifest['inputs']['kind']}, the files are {kind}")
    sequences = [features(item.source / item.name if item.source.suffix == ".npz" else item.source,
                          item.recording, tuple(manifest["markers"]), **manifest["preprocessing"]) for item in items]
    enable_compilation_cache()
    loglik = scores(hmms, sequences)
    best = loglik.argmax(axis=1)
    truth = [label_of_name(item.name, pattern) if pattern else item.default_class for item in items]
    shown = pattern is not None or any(t is not None for t in truth)
    rows = [(item.name, classes[b], *([t or "?"] if shown else []), *(f"{v:.1f}" for v in ll))
            for item, b, t, ll in zip(items, best, truth, loglik)]
    header = ("input", "recognised", *(["true"] if shown else []), *(f"log p(x | {c})" for c in classes))
    print(markdown_table(header, rows))
    if shown:
        known = [(classes[b], t) for b, t in zip(best, truth) if t is not None]
        if known:
            right = sum(b == t for b, t in known)
            print(f"accuracy {right}/{len(known)} = {right / len(known):.1%} (inputs whose name or reach "
                  f"movement gives a class)")
    return 0


def run(args) -> int:
    return fit(args) if args.run == "fit" else recognize(args)
