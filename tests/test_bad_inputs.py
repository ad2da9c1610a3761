"""Bad input at the public boundaries: truncated or inconsistent files, arguments of the wrong type or
dtype. Each must end in a `ValueError` whose message names the argument (and the file, and what
differs), never in numpy's or JAX's own error deep inside; through `lfd-jax`, in one line on stderr
and exit status 2, never a traceback."""
import json
import lzma

import numpy as np
import pytest

import lfd_jax as L
from hog_jax import video as V
from lfd_jax.cli import main
from tests.mocap_files import write_c3d, write_nexus_csv, write_trc

NAMES = ("HAND", "ELBOW", "SHOULDER")


def markers_mm(n_frames: int = 10, n_markers: int = len(NAMES), seed: int = 0) -> np.ndarray:
    return np.round(np.random.default_rng(seed).uniform(-900, 900, (n_frames, n_markers, 3)), 3)


def cut(path, keep: float):
    """The file cut to the fraction `keep` of its bytes."""
    data = path.read_bytes()
    path.write_bytes(data[:int(len(data) * keep)])
    return path


def one_line_error(argv, capsys) -> str:
    """`lfd-jax ARGV` run in this process: exit status 2 and one line on stderr, which is returned."""
    assert main([str(a) for a in argv]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("lfd-jax: error: "), lines
    return lines[0]


# ------------------------------------------------------------------------------------- marker files
@pytest.fixture
def trc(tmp_path):
    """A TRC file of 10 frames of the three markers, in mm."""
    return write_trc(tmp_path / "t.trc", markers_mm(), NAMES)


def test_trc_with_fewer_rows_than_its_header_is_rejected(trc):
    lines = trc.read_text().splitlines()
    trc.write_text("\n".join(lines[:-4]) + "\n")  # cut at a row boundary: 6 of 10 frames left
    with pytest.raises(ValueError, match=r"^path: .*t\.trc header says 10 frames, file holds 6"):
        L.load_markers(trc)


def test_trc_rows_with_more_markers_than_its_header_are_rejected(trc):
    lines = trc.read_text().splitlines()
    lines[2] = lines[2].replace("\t3\tmm", "\t2\tmm")           # NumMarkers 3 -> 2
    lines[3] = lines[3].rsplit("\t\t\t", 1)[0]                    # and two names: the third marker's columns stay
    trc.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=r"^path: .*t\.trc rows have 11 values, expected 8 \(2 \+ 3 x 2 markers"):
        L.load_markers(trc)


@pytest.mark.parametrize("name", ["t.csv.xz", "t.trc.xz"])
def test_truncated_xz_marker_file_is_rejected_naming_the_path(tmp_path, name):
    path = tmp_path / name
    if name.startswith("t.csv"):
        write_nexus_csv(path, markers_mm(40), NAMES)
    else:
        path.write_bytes(lzma.compress(write_trc(tmp_path / "t.trc", markers_mm(40), NAMES).read_bytes()))
    with pytest.raises(ValueError, match=rf"^path: cannot read .*{name}"):
        L.load_markers(cut(path, 0.5))


def test_truncated_xz_marker_file_ends_phmm_fit_in_one_line_and_exit_2(tmp_path, capsys):
    folder = tmp_path / "train" / "reach"
    folder.mkdir(parents=True)
    path = write_nexus_csv(folder / "r1.csv.xz", markers_mm(40), NAMES)
    cut(path, 0.5)
    assert "r1.csv.xz" in one_line_error(["phmm", "fit", tmp_path / "train", "--out", tmp_path / "model"], capsys)


@pytest.mark.parametrize("keep", [0.5, 0.9, 0.96])  # 0.96: inside the last frame
def test_c3d_with_fewer_frames_than_its_header_is_rejected(tmp_path, keep):
    pytest.importorskip("ezc3d")
    # 40 markers: the data (10 frames x 40 x 4 float32) are most of the file, so every cut lands in them
    path = write_c3d(tmp_path / "t.c3d", markers_mm(10, 40), [f"M{k}" for k in range(40)])
    with pytest.raises(ValueError, match=r"^path: .*t\.c3d header says 10 frames, file holds [0-9] "):
        L.load_markers(cut(path, keep))


@pytest.mark.parametrize("blocks", [2, 3])
def test_c3d_cut_before_its_data_is_rejected(tmp_path, blocks):
    """Cut at a block boundary in the parameter section (2: ezc3d 1.7 reads 10 frames of nothing from this
    file; other cuts there make it hang or crash) or at the start of the data (3)."""
    pytest.importorskip("ezc3d")
    path = write_c3d(tmp_path / "t.c3d", markers_mm(), NAMES)
    assert path.read_bytes()[16] == 4  # header word 9: the data start at block 4
    path.write_bytes(path.read_bytes()[:512 * blocks])
    with pytest.raises(ValueError, match=r"^path: .*t\.c3d header says 10 frames, file holds 0 "):
        L.load_markers(path)


def test_complete_c3d_and_trc_files_still_load(tmp_path, trc):
    """The checks above leave whole files alone (the loaders' own tests cover their values)."""
    pytest.importorskip("ezc3d")
    assert L.load_markers(trc).markers.shape == (10, 3, 3)
    assert L.load_markers(write_c3d(tmp_path / "t.c3d", markers_mm(), NAMES)).markers.shape == (10, 3, 3)


# ------------------------------------------------------------------------------------- marker recordings
@pytest.fixture
def recording():
    return L.make_recording(markers_mm() / 1000, NAMES, 100.0)


def test_never_seen_marker_is_rejected_whatever_the_gap_limit(recording):
    x = recording.markers.copy()
    x[:, 1] = np.nan
    never = recording._replace(markers=x)
    for limit in (3, 10, 1000):  # shorter than, as long as and longer than the recording
        with pytest.raises(ValueError, match=r"^recording: marker 'ELBOW' is never seen .*drop_untracked_markers"):
            L.fill_gaps(never, max_gap_frames=limit)


def test_select_markers_rejects_a_name_given_twice(recording):
    with pytest.raises(ValueError, match=r"^names: .*'HAND' more than once"):
        L.select_markers(recording, ["HAND", "HAND"])
    assert L.select_markers(recording, ["SHOULDER", "HAND"]).names == ("SHOULDER", "HAND")


# ------------------------------------------------------------------------------------- video
FRAMES = np.zeros((3, 8, 8, 3), np.uint8)


def test_video_entry_points_reject_string_frames():
    text = np.full(FRAMES.shape, "7")
    with pytest.raises(ValueError, match="^frames: expected a numeric array, got dtype <U1"):
        V.run_background(text)
    with pytest.raises(ValueError, match="^first_frame: expected a numeric array"):
        V.init_background(text[0])
    with pytest.raises(ValueError, match="^frames: expected a numeric array"):
        V.segment_recording(None, text, 1)


CAMERA = V.StereoCamera(focal_px=10.0, baseline_m=0.1, width=8, height=8)
# every public entry point that takes the colour models, called with `m` in their place
VIDEO_CALLS = {
    "segment_recording": lambda m: V.segment_recording(m, FRAMES, 1),
    "segment_chunk": lambda m: V.segment_chunk(m, V.init_segment_state(FRAMES[0]), FRAMES, 1),
    "stream_recording": lambda m: next(V.stream_recording(m, [FRAMES], 1)),
    "region_scores": lambda m: V.region_scores(m, FRAMES, np.zeros(FRAMES.shape[:-1], bool)),
    "segment_stereo": lambda m: V.segment_stereo(m, FRAMES, FRAMES, 1, CAMERA),
    "stream_stereo": lambda m: next(V.stream_stereo(m, [(FRAMES, FRAMES)], 1, CAMERA)),
    "track_mono": lambda m: V.track_mono(m, FRAMES, 1),
}


@pytest.mark.parametrize("entry", VIDEO_CALLS)
@pytest.mark.parametrize("models, match", [
    (None, "^models: expected a VideoModels, got NoneType"),
    (("skin", "person", "background"), "^models: expected a VideoModels, got tuple"),
    ("video models", "^models: expected a VideoModels, got str"),
])
def test_video_entry_points_reject_models_of_another_type(entry, models, match):
    with pytest.raises(ValueError, match=match):
        VIDEO_CALLS[entry](models)


def test_video_models_with_a_field_of_another_type_are_rejected():
    with pytest.raises(ValueError, match="^models.person: expected a GMM, got NoneType"):
        V.segment_recording(V.VideoModels(_skin(), None, None), FRAMES, 1)


def _skin():
    from hog_jax import GMM, SkinModel

    gmm = GMM(np.zeros(1), np.zeros((1, 2)), np.eye(2)[None])
    return SkinModel(gmm, gmm, np.float32(0.0))


# ------------------------------------------------------------------------------------- grasp database
@pytest.fixture
def photo(tmp_path):
    import cv2

    path = tmp_path / "hand.png"
    cv2.imwrite(str(path), np.full((24, 32, 3), 128, np.uint8))
    return path


def _write_db(path, drop_array=None, drop_config=None):
    """A tiny database file of the CLI's kind, without the array or the config entry named."""
    from lfd_common import save_arrays
    from lfd_jax.cli._src import grasp

    n, s = 2, 4
    arrays = {"images": np.zeros((n, s, s), np.float32), "masks": np.ones((n, s, s), bool),
              "labels": np.zeros(n, np.int32), "euler": np.zeros((n, 3)), "quat": np.tile([1.0, 0, 0, 0], (n, 1)),
              "azimuth_deg": np.zeros(n), "elevation_deg": np.zeros(n), "features": np.zeros((n, 5), np.float32)}
    config = {"grasps": [1], "n_azimuth": 2, "n_elevation": 1, **grasp._settings()}
    arrays.pop(drop_array, None)
    config.pop(drop_config, None)
    return save_arrays(path, grasp.DB_KIND, arrays, config=config)


@pytest.mark.parametrize("drop_array, drop_config, missing", [
    ("euler", None, "array 'euler'"), ("features", None, "array 'features'"), (None, "grasps", "'grasps'")])
def test_grasp_database_without_an_entry_is_rejected_naming_it(tmp_path, drop_array, drop_config, missing):
    from lfd_jax.cli._src.grasp import load_database

    path = _write_db(tmp_path / "db.npz", drop_array, drop_config)
    with pytest.raises(ValueError, match=rf"^db: .*db\.npz .*{missing}"):
        load_database(path)
    assert len(load_database(_write_db(tmp_path / "whole.npz")).features) == 2


def test_grasp_database_without_an_entry_ends_the_cli_in_one_line_and_exit_2(tmp_path, photo, capsys):
    path = _write_db(tmp_path / "db.npz", drop_config="grasps")
    line = one_line_error(["grasp", photo, "--db", path, "--out", tmp_path / "out"], capsys)
    assert "db.npz" in line and "grasps" in line


# ------------------------------------------------------------------------------------- lfd-jax phmm
@pytest.fixture
def train(tmp_path):
    """train/reach/ with one TRC file of the three markers."""
    folder = tmp_path / "train" / "reach"
    folder.mkdir(parents=True)
    write_trc(folder / "r1.trc", markers_mm(40), NAMES)
    return tmp_path / "train"


def test_phmm_model_without_classes_is_rejected_naming_the_file(tmp_path, train, capsys):
    model = tmp_path / "model"
    model.mkdir()
    preprocessing = {"relative_to": None, "max_gap_s": 0.2, "n_frames": 0}
    (model / "model.json").write_text(json.dumps({"classes": [], "markers": list(NAMES), "preprocessing": preprocessing}))
    line = one_line_error(["phmm", "recognize", model, train / "reach" / "r1.trc"], capsys)
    assert "model.json" in line and "classes" in line


def test_binary_config_file_is_rejected_naming_config(tmp_path, train, capsys):
    config = tmp_path / "config.json"
    config.write_bytes(bytes(range(128, 256)))
    line = one_line_error(["phmm", "fit", train, "--out", tmp_path / "model", "--config", config], capsys)
    assert "--config" in line and "config.json" in line


def test_truncated_reach_npz_is_rejected_naming_the_path(tmp_path, capsys):
    path = tmp_path / "reach.npz"
    np.savez(path, t=np.zeros(500))
    cut(path, 0.5)
    with pytest.raises(ValueError, match=r"^path: cannot read .*reach\.npz as npz"):
        L.load_reach_npz(path)
    assert "reach.npz" in one_line_error(["phmm", "fit", path, "--out", tmp_path / "model"], capsys)


@pytest.mark.parametrize("content", [b"garbage, not an archive", None])
def test_reach_file_that_is_not_an_npz_is_rejected_naming_the_path(tmp_path, content):
    path = tmp_path / "reach.npz"
    if content is None:  # a plain .npy array under an .npz name
        with open(path, "wb") as f:
            np.save(f, np.zeros(5))
    else:
        path.write_bytes(content)
    with pytest.raises(ValueError, match=r"^path: cannot read .*reach\.npz as npz"):
        L.load_reach_npz(path)
