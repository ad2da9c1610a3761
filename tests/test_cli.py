"""The `lfd-jax` command line, run as a user runs it: `python -m lfd_jax.cli ...` in a
subprocess. Every subcommand's --help; phmm fit + recognize on small Nexus CSV and TRC files written
here; grasp on two synthetic photos (one with a skin blob, one without) with a tiny database; video
on a tiny synthetic clip; bad input ends in one line on stderr and exit status 2."""
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from tests.mocap_files import write_nexus_csv, write_trc

ROOT = Path(__file__).resolve().parents[1]
MARKERS = ("WRIST", "FINGER")
SKIN_BGR, BACKGROUND_BGR = (120, 140, 200), (160, 90, 60)  # a skin tone and a blue background, OpenCV order


def lfd_jax(*args, cwd=ROOT) -> subprocess.CompletedProcess:
    env = {**os.environ, "LFD_NO_PROGRESS": "1"}
    return subprocess.run([sys.executable, "-m", "lfd_jax.cli", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def assert_one_line_error(result: subprocess.CompletedProcess, *fragments: str) -> None:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("lfd-jax: error: "), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


# `python -m lfd_jax.cli ARGS` for several ARGS in one new process: each run as `-m` runs it (`runpy`,
# `__main__`), its stdout, stderr and exit status kept apart. For the runs that end in an error (help,
# usage errors, bad files): one Python and JAX start-up instead of one per run.
_RUNS = """
import contextlib, io, json, runpy, sys
results = []
for argv in json.loads(sys.argv[1]):
    out, err, code = io.StringIO(), io.StringIO(), 0
    sys.argv = [sys.argv[0], *argv]
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            runpy.run_module("lfd_jax.cli", run_name="__main__", alter_sys=True)
        except SystemExit as end:
            code = end.code if isinstance(end.code, int) else (0 if end.code is None else 1)
    results.append((code, out.getvalue(), err.getvalue()))
print(json.dumps(results))
"""


def lfd_jax_runs(*commands) -> list[subprocess.CompletedProcess]:
    """`lfd_jax(*args)` for each argument tuple of `commands`, all in one new process (see `_RUNS`)."""
    env = {**os.environ, "LFD_NO_PROGRESS": "1"}
    argvs = [[str(a) for a in args] for args in commands]
    run = subprocess.run([sys.executable, "-c", _RUNS, json.dumps(argvs)], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    return [subprocess.CompletedProcess(["lfd-jax", *argv], code, out, err)
            for argv, (code, out, err) in zip(argvs, json.loads(run.stdout))]


def assert_one_line_errors(cases: dict) -> None:
    """Each argument tuple of `cases`, run in one process (`lfd_jax_runs`), ends in one line on stderr
    with its fragment (`assert_one_line_error`)."""
    for result, fragment in zip(lfd_jax_runs(*cases), cases.values()):
        assert_one_line_error(result, fragment)


HELP_COMMANDS = [(), ("grasp",), ("phmm",), ("phmm", "fit"), ("phmm", "recognize"), ("video",)]


@pytest.fixture(scope="module")
def parser_runs():
    """{args: CompletedProcess} of every subcommand's --help and of two usage errors, in one process."""
    commands = [(*command, "--help") for command in HELP_COMMANDS] + [("phmm", "fit"), ("teleport",)]
    return dict(zip(commands, lfd_jax_runs(*commands)))


@pytest.mark.parametrize("command", HELP_COMMANDS)
def test_help_of_every_subcommand(command, parser_runs):
    result = parser_runs[(*command, "--help")]
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: lfd-jax") and "--help" in result.stdout


def test_usage_errors_are_one_line(parser_runs):
    assert_one_line_error(parser_runs[("phmm", "fit")], "required")
    assert_one_line_error(parser_runs[("teleport",)], "invalid choice")


def movement(rng, kind: int, n_frames: int) -> np.ndarray:
    """(T, 2, 3) mm: a wrist and a finger marker moving up (kind 0) or sideways (kind 1), with noise."""
    t = np.linspace(0.0, 1.0, n_frames)[:, None]
    direction = np.array([[0.0, 0.0, 300.0]]) if kind == 0 else np.array([[300.0, 0.0, 0.0]])
    wrist = t * direction + 2.0 * rng.standard_normal((n_frames, 3))
    finger = wrist + np.array([80.0, 20.0, 0.0]) + 2.0 * rng.standard_normal((n_frames, 3))
    return np.stack([wrist, finger], axis=1)


@pytest.fixture(scope="module")
def marker_files(tmp_path_factory):
    """train/<up|side>/ Nexus CSVs (one with a 3-frame gap) and TRCs, and held-out test files."""
    root = tmp_path_factory.mktemp("markers")
    rng = np.random.default_rng(0)
    for kind, name in enumerate(("up", "side")):
        folder = root / "train" / name
        folder.mkdir(parents=True)
        for rep in range(4):
            xyz = movement(rng, kind, int(rng.integers(36, 48)))
            if rep == 0:
                xyz[10:13, 1] = np.nan  # filled by interpolation (0.05 s at 60 Hz)
                write_nexus_csv(folder / f"{name}{rep}.csv", xyz, MARKERS, rate_hz=60.0)
            else:
                write_trc(folder / f"{name}{rep}.trc", xyz, MARKERS, rate_hz=60.0)
        write_trc(root / f"test_{name}.trc", movement(rng, kind, 40), MARKERS, rate_hz=60.0)
    return root


PHMM_FLAGS = ("--n-states", 3, "--min-duration", 2, "--max-duration", 12, "--n-frames", 20, "--max-iter", 10)


@pytest.fixture(scope="module")
def fitted(marker_files, tmp_path_factory):
    """(the fit's CompletedProcess, the model folder) of `phmm fit` on the class folders."""
    model = tmp_path_factory.mktemp("phmm") / "model"
    return lfd_jax("phmm", "fit", marker_files / "train", "--out", model, *PHMM_FLAGS), model


def test_phmm_fit_and_recognize(marker_files, fitted):
    result, model = fitted
    assert result.returncode == 0, result.stderr
    assert "| up | 4 | 100% |" in result.stdout and "| side | 4 | 100% |" in result.stdout
    manifest = json.loads((model / "model.json").read_text())
    assert manifest["classes"] == ["side", "up"] and manifest["markers"] == list(MARKERS)
    assert (model / "up.npz").is_file() and (model / "side.npz").is_file()
    tests = [marker_files / "test_up.trc", marker_files / "test_side.trc"]
    recognised = lfd_jax("phmm", "recognize", model, *tests, "--label", r"test_(\w+)\.trc")
    assert recognised.returncode == 0, recognised.stderr
    rows = [line for line in recognised.stdout.splitlines() if line.startswith("| test_")]
    assert [row.split(" | ")[1:3] for row in rows] == [["up", "up"], ["side", "side"]]
    assert "accuracy 2/2 = 100.0%" in recognised.stdout


def test_phmm_label_expression_and_config_file(marker_files, tmp_path):
    """--label finds the classes in the file names of a flat tree; --config sets what flags do not."""
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"n_states": 3, "min_duration": 2, "max_duration": None, "n_frames": 0,
                                  "markers": ["WRIST"], "relative_to": "FINGER"}))
    model = tmp_path / "model"
    result = lfd_jax("phmm", "fit", marker_files / "train", "--out", model, "--label", r"^(up|side)\d",
                     "--config", config, "--max-iter", 5)
    assert result.returncode == 0, result.stderr
    settings = json.loads((model / "model.json").read_text())["settings"]
    assert settings["max_duration"] is None and settings["max_iter"] == 5 and settings["markers"] == ["WRIST"]
    assert "D = 3 features" in result.stdout


def test_phmm_bad_input(marker_files, fitted, tmp_path):
    train, model = marker_files / "train", fitted[1]
    (tmp_path / "empty").mkdir()
    wrong = tmp_path / "notes.txt"
    wrong.write_text("not markers\n")
    bad = tmp_path / "bad.json"
    bad.write_text('{"n_states": 3, "colour": "red"}')
    cases = {("phmm", "recognize", tmp_path / "empty", train / "up" / "up1.trc"): "model.json",
             ("phmm", "recognize", model, tmp_path / "missing.trc"): "no such file",
             ("phmm", "recognize", model, wrong): "expected a .csv",
             ("phmm", "fit", train, "--out", tmp_path / "m2", "--config", bad): "colour",
             ("phmm", "fit", train, "--out", tmp_path / "m3", "--n-states", 30): "n_frames",
             ("phmm", "fit", train, "--out", tmp_path / "m4", "--label", "up"): "group"}
    assert_one_line_errors(cases)


def write_skin_pixels(folder: Path) -> Path:
    """folder/skin_nonskin_uci.tsv in the UCI layout (B G R label): skin around SKIN_BGR, the rest
    around BACKGROUND_BGR and greys."""
    rng = np.random.default_rng(1)
    skin = np.clip(rng.normal(SKIN_BGR, 10, size=(400, 3)), 0, 255)
    other = np.clip(np.concatenate([rng.normal(BACKGROUND_BGR, 20, size=(300, 3)),
                                    rng.uniform(0, 255, size=(100, 1)).repeat(3, 1)]), 0, 255)
    rows = [f"{b:.0f}\t{g:.0f}\t{r:.0f}\t1" for b, g, r in skin] + [f"{b:.0f}\t{g:.0f}\t{r:.0f}\t2" for b, g, r in other]
    path = folder / "skin_nonskin_uci.tsv"
    path.write_text("R\tG\tB\tT\n" + "\n".join(rows) + "\n")
    return folder


def test_grasp_on_two_photos(tmp_path):
    skin_data = write_skin_pixels(tmp_path)
    hand = np.full((120, 160, 3), BACKGROUND_BGR, np.uint8)
    cv2.ellipse(hand, (80, 60), (22, 34), 20, 0, 360, SKIN_BGR, -1)
    cv2.rectangle(hand, (95, 40), (104, 80), SKIN_BGR, -1)  # a thumb
    cv2.imwrite(str(tmp_path / "hand.png"), hand)
    cv2.imwrite(str(tmp_path / "empty.png"), np.full((120, 160, 3), BACKGROUND_BGR, np.uint8))
    db = tmp_path / "db.npz"
    result = lfd_jax("grasp", tmp_path / "hand.png", tmp_path / "empty.png", "--db", db, "--db-size", 4, "-k", 3,
                     "--skin-data", skin_data, "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    assert "building the grasp database: 6 grasps x 4 x 1 views" in result.stdout and db.is_file()
    rows = {line.split(" | ")[0].strip("| "): line for line in result.stdout.splitlines() if ".png |" in line}
    assert rows["hand.png"].rstrip().endswith("| found |")
    assert rows["empty.png"].rstrip().endswith("| not found (no hand) |")
    assert (tmp_path / "out" / "hand_grasp.png").is_file() and (tmp_path / "out" / "empty_grasp.png").is_file()
    cases = {("grasp", tmp_path / "hand.png", "--db", db, "--grasps", "1,7", "--skin-data", skin_data): "grasps",
             ("grasp", tmp_path / "missing.jpg", "--db", db): "no such file"}
    assert_one_line_errors(cases)


def write_clip(path: Path, n_frames: int = 16) -> Path:
    """A 64 x 48 mp4: an empty textured scene, then a blue 'person' with a skin face and hand entering."""
    rng = np.random.default_rng(2)
    scene = rng.integers(90, 140, size=(48, 64, 3)).astype(np.uint8)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (64, 48))
    for t in range(n_frames):
        frame = scene.copy()
        if t >= 5:
            x = max(20, 64 - 8 * (t - 5))
            cv2.rectangle(frame, (x, 20), (x + 20, 48), (170, 60, 30), -1)
            cv2.circle(frame, (x + 10, 13), 6, SKIN_BGR, -1)
            cv2.circle(frame, (x - 4, 30 - t % 4), 4, SKIN_BGR, -1)
        writer.write(frame)
    writer.release()
    return path


def test_video_on_a_tiny_clip(tmp_path):
    clip = write_clip(tmp_path / "clip.mp4")
    skin_data = write_skin_pixels(tmp_path)
    result = lfd_jax("video", clip, "--out", tmp_path / "out", "--skin-data", skin_data)
    assert result.returncode == 0, result.stderr
    assert "| frames (segmented from) | 16 (11) |" in result.stdout
    for name in ("overlay.mp4", "sheet.png", "tracks.csv"):
        assert (tmp_path / "out" / name).is_file(), name
    with open(tmp_path / "out" / "tracks.csv") as f:
        assert len(list(csv.DictReader(f))) == 16
    cases = {("video", tmp_path / "missing.mp4", "--out", tmp_path / "o"): "no such file",
             ("video", clip, "--out", tmp_path / "o", "--skin-data", tmp_path / "none"): "skin_nonskin_uci.tsv",
             ("video", clip, "--out", tmp_path / "o", "--max-frames", 8, "--skin-data", skin_data): "at least 12"}
    assert_one_line_errors(cases)
