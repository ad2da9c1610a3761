"""`lfd-jax phmm fit` / `lfd-jax phmm recognize`: one explicit-duration HMM of `phmm_jax` per
movement class, fitted on one's own marker files and used to classify others.

A file becomes a feature sequence in four steps, the same at fit and at recognition time:
`lfd_jax.load_markers` (by suffix: Vicon Nexus .csv, .trc, .c3d; .csv.xz / .trc.xz)
-> the chosen markers (`select_markers`; default every marker seen in all training files) ->
short gaps filled by linear interpolation (`fill_gaps`, `max_gap_s`; a longer gap is an error
naming the marker) -> optionally minus one reference marker, frame by frame (`relative_to`) ->
resampled to `n_frames` frames (`resample_frames`; 0 keeps the recorded length) -> (T, 3 M)
positions in metres.

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

import numpy as np

import phmm_jax
from lfd_common import markdown_table, progress
from lfd_jax._src.marker_files import load_markers
from lfd_jax._src.markers import drop_untracked_markers, fill_gaps, resample_frames, select_markers
from lfd_common import check_int, check_real, enable_compilation_cache

MANIFEST = "model.json"
MARKER_SUFFIXES = (".csv", ".trc", ".c3d", ".csv.xz", ".trc.xz")
CLASS_NAME = re.compile(r"[\w.+-]+")


@dataclasses.dataclass(frozen=True)
class FitSettings:
    """What `phmm fit` does: the HMMs' structure (`phmm_jax.HMMConfig`; max_duration None is the
    classical HMM with self-loops), the EM options (`phmm_jax.FitOptions`) and the preprocessing
    (module docstring; markers () = every marker seen in all training files)."""

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

    def __post_init__(self):
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
            values = json.loads(Path(args.config).read_text())
        except json.JSONDecodeError as err:
            raise ValueError(f"config: {args.config} is not JSON ({err})") from err
        if not isinstance(values, dict) or set(values) - fields:
            unknown = sorted(set(values) - fields) if isinstance(values, dict) else values
            raise ValueError(f"config: expected a JSON object with keys among {sorted(fields)}, got {unknown!r}")
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


def label_of(path: Path, pattern: re.Pattern) -> str | None:
    """The first group of `pattern` searched in the file's name (None when it does not match)."""
    match = pattern.search(path.name)
    return None if match is None else match.group(1)


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
    """(file, class) of every training file: DIR/<class>/<marker files>, or every marker file under
    DIR whose name `label` matches (its first group the class)."""
    if not root.is_dir():
        raise FileNotFoundError(f"dir: no such folder {root}")
    if label is None:
        pairs = [(f, d.name) for d in sorted(p for p in root.iterdir() if p.is_dir())
                 for f in sorted(d.iterdir()) if is_marker_file(f)]
        where = f"class folders {root}/<class>/ with marker files ({', '.join(MARKER_SUFFIXES)})"
    else:
        pattern = compile_label(label)
        files = sorted(Path(folder) / name for folder, _, names in os.walk(root, followlinks=True) for name in names)
        pairs = [(f, c) for f in files if is_marker_file(f) and (c := label_of(f, pattern))]
        where = f"marker files under {root} whose names match '{label}'"
    if not pairs:
        raise ValueError(f"dir: found no {where}")
    for _, name in pairs:
        if not CLASS_NAME.fullmatch(name):
            raise ValueError(f"label: class {name!r} is not a plain name (letters, digits, . + - _)")
    return pairs


def common_markers(recordings, relative_to: str | None) -> tuple[str, ...]:
    """The markers seen in every recording, in the first recording's order (without `relative_to`)."""
    seen = [set(drop_untracked_markers(r).names) for r in recordings]
    names = tuple(n for n in recordings[0].names if all(n in s for s in seen) and n != relative_to)
    if not names:
        raise ValueError("markers: no marker is seen in every training file; choose them with --markers")
    return names


def features(path: Path, recording, markers: tuple[str, ...], relative_to: str | None, max_gap_s: float,
             n_frames: int) -> np.ndarray:
    """(T, 3 M) positions in metres of `markers` of the recording read from `path` (module
    docstring); ValueError naming the file."""
    try:
        chosen = select_markers(recording, markers + ((relative_to,) if relative_to else ()))
        positions = fill_gaps(chosen, max_gap_s).markers
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
    pairs = training_files(args.dir, args.label)
    recordings = [load_markers(path) for path, _ in progress(pairs, desc="reading marker files")]
    markers = settings.markers or common_markers(recordings, settings.relative_to)
    manifest = {"classes": sorted({c for _, c in pairs}), "markers": list(markers),
                "preprocessing": {"relative_to": settings.relative_to, "max_gap_s": settings.max_gap_s,
                                  "n_frames": settings.n_frames},
                "settings": dataclasses.asdict(settings)}
    sequences = [features(path, recording, markers, **manifest["preprocessing"])
                 for (path, _), recording in zip(pairs, recordings)]
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
    print(f"{len(pairs)} files, {len(markers)} markers -> D = {sequences[0].shape[1]} features; "
          f"HMM {settings.n_states} states, durations {settings.min_duration}-{settings.max_duration or 'inf'}")
    print(markdown_table(("class", "training files", "recognised on its own training files"), rows))
    print(f"wrote {args.out}/ ({MANIFEST} and {len(classes)} phmm_jax models)")
    return 0


def load_model_folder(folder: Path) -> tuple[dict, list]:
    """(manifest, one HMM per class) of a folder written by `fit`."""
    manifest_path = Path(folder) / MANIFEST
    if not manifest_path.is_file():
        raise FileNotFoundError(f"model: no {MANIFEST} in {folder} (write a model folder with 'lfd-jax phmm fit')")
    try:
        manifest = json.loads(manifest_path.read_text())
        valid = (isinstance(manifest["classes"], list) and isinstance(manifest["markers"], list)
                 and set(manifest["preprocessing"]) == {"relative_to", "max_gap_s", "n_frames"})
    except (json.JSONDecodeError, KeyError, TypeError) as err:
        raise ValueError(f"model: {manifest_path} is not a model manifest ({err})") from err
    if not valid:
        raise ValueError(f"model: {manifest_path} is not a model manifest (classes, markers, preprocessing)")
    return manifest, [phmm_jax.load(Path(folder) / f"{name}.npz") for name in manifest["classes"]]


def recognize(args) -> int:
    """Print each file's class and its log-likelihood under every class (and the accuracy with --label)."""
    manifest, hmms = load_model_folder(args.model)
    classes = manifest["classes"]
    pattern = compile_label(args.label) if args.label else None
    sequences = [features(path, load_markers(path), tuple(manifest["markers"]), **manifest["preprocessing"])
                 for path in progress(args.files, desc="reading marker files")]
    enable_compilation_cache()
    loglik = scores(hmms, sequences)
    best = loglik.argmax(axis=1)
    truth = [label_of(path, pattern) if pattern else None for path in args.files]
    rows = [(path.name, classes[b], *([t or "?"] if pattern else []), *(f"{v:.1f}" for v in ll))
            for path, b, t, ll in zip(args.files, best, truth, loglik)]
    header = ("file", "recognised", *(["true"] if pattern else []), *(f"log p(x | {c})" for c in classes))
    print(markdown_table(header, rows))
    if pattern:
        known = [(classes[b], t) for b, t in zip(best, truth) if t is not None]
        if known:
            right = sum(b == t for b, t in known)
            print(f"accuracy {right}/{len(known)} = {right / len(known):.1%} (files whose name gives a class)")
    return 0


def run(args) -> int:
    return fit(args) if args.run == "fit" else recognize(args)
