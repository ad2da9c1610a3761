"""The real-recording loaders of `lfd_jax` and `experiments.data.ue_adl`:
Nexus CSV, TRC and C3D files written here read back to one `MarkerRecording` in metres with NaN
gaps; gap filling against numpy.interp, the long-gap error, resampling; images, video and stereo
pairs into (T, H, W, 3) uint8 RGB; and, when ../shared/data/ue_adl is present, one real file of
each kind. Hypothesis states the loaders' promises on random small recordings."""
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lfd_jax as L
from experiments.data import ue_adl
from tests.mocap_files import write_angles, write_c3d, write_nexus_csv, write_trc
from tests.video_scene import write_video

NAMES = ("RSHO1", "RFTP", "STRN")
SETTINGS = settings(max_examples=15, deadline=None)


def _markers_mm(n_frames=12, n_markers=3, seed=0):
    rng = np.random.default_rng(seed)
    return np.round(rng.uniform(-900, 900, (n_frames, n_markers, 3)), 3)


@pytest.mark.parametrize("suffix", [".csv", ".csv.xz"])
def test_nexus_csv_gaps_units_rate(tmp_path, suffix):
    mm = _markers_mm()
    mm[3:5, 1] = np.nan
    rec = L.load_markers(write_nexus_csv(tmp_path / f"trial{suffix}", mm, NAMES, rate_hz=120))
    assert rec.names == NAMES and rec.rate_hz == 120.0 and rec.markers.shape == mm.shape
    np.testing.assert_allclose(rec.markers, mm / 1000, atol=1e-9)  # NaN where the cells are empty


def test_nexus_csv_skips_other_sections(tmp_path):
    path = write_nexus_csv(tmp_path / "t.csv", _markers_mm(), NAMES)
    path.write_text("Devices\n1000\n,,Force\nFrame,Sub Frame,Fx\n,,N\n1,0,3.0\n\n" + path.read_text(encoding="utf-8-sig"))
    assert L.load_markers(path).markers.shape == (12, 3, 3)


@pytest.mark.parametrize("units,scale", [("mm", 1e-3), ("m", 1.0)])
def test_trc_round_trip(tmp_path, units, scale):
    values = _markers_mm(seed=1) / (1.0 if units == "mm" else 1000.0)
    values[0, 2] = np.nan
    rec = L.load_markers(write_trc(tmp_path / "t.trc", values, NAMES, rate_hz=60, units=units))
    assert rec.names == NAMES and rec.rate_hz == 60.0
    np.testing.assert_allclose(rec.markers, values * scale, atol=1e-9)


def test_c3d_round_trip_with_invalid_samples(tmp_path):
    pytest.importorskip("ezc3d")
    mm = _markers_mm(seed=2)
    invalid = np.zeros(mm.shape[:2], bool)
    invalid[2:4, 0] = True
    rec = L.load_markers(write_c3d(tmp_path / "t.c3d", mm, NAMES, rate_hz=200, invalid=invalid))
    assert rec.names == NAMES and rec.rate_hz == 200.0
    expected = np.where(invalid[..., None], np.nan, mm / 1000)
    np.testing.assert_allclose(rec.markers, expected, atol=1e-6)  # C3D stores float32
    (tmp_path / "garbage.c3d").write_bytes(b"garbage")
    with pytest.raises(ValueError, match="^path: cannot read .* as C3D"):
        L.load_markers(tmp_path / "garbage.c3d")


def test_c3d_without_ezc3d_says_how_to_install(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_ezc3d(name, *args, **kwargs):
        if name == "ezc3d":
            raise ImportError("no ezc3d")
        return real_import(name, *args, **kwargs)

    (tmp_path / "t.c3d").write_bytes(b"\0" * 512)
    monkeypatch.setattr(builtins, "__import__", no_ezc3d)
    with pytest.raises(ImportError, match=r"lfd-jax\[mocap\]"):
        L.load_markers(tmp_path / "t.c3d")


def test_bad_marker_files_name_the_path(tmp_path):
    with pytest.raises(ValueError, match="^path: expected a file path, got NoneType"):
        L.load_markers(None)
    with pytest.raises(ValueError, match="^path: no such file"):
        L.load_markers(tmp_path / "missing.csv")
    (tmp_path / "x.mat").write_text("")
    with pytest.raises(ValueError, match="^path: expected a .csv"):
        L.load_markers(tmp_path / "x.mat")
    (tmp_path / "y.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="^path: .*no 'Trajectories' section"):
        L.load_markers(tmp_path / "y.csv")
    (tmp_path / "z.trc").write_text("not a trc\n")
    with pytest.raises(ValueError, match="^path: .*not a TRC file"):
        L.load_markers(tmp_path / "z.trc")
    bad = write_nexus_csv(tmp_path / "w.csv", _markers_mm(), NAMES)
    bad.write_text(bad.read_text(encoding="utf-8-sig").replace("mm,mm,mm", "in,in,in"))
    with pytest.raises(ValueError, match="^path: .*unit 'in'"):
        L.load_markers(bad)


def test_fill_gaps_matches_numpy_interp():
    x = _markers_mm(20, 3, seed=3) / 1000
    holes = x.copy()
    holes[4:7, 1] = np.nan          # 3 frames inside
    holes[0:2, 2, 0] = np.nan       # one coordinate missing: the frame is a gap
    rec = L.fill_gaps(L.make_recording(holes, NAMES, 100.0), max_gap_frames=3)
    t = np.arange(20)
    for k in range(3):
        keep = np.r_[t[:4], t[7:]]
        np.testing.assert_allclose(rec.markers[:, 1, k], np.interp(t, keep, x[keep, 1, k]))
    np.testing.assert_allclose(rec.markers[:2, 2], np.broadcast_to(x[2, 2], (2, 3)))  # nearest seen frame
    np.testing.assert_array_equal(rec.markers[:, 0], x[:, 0])


def test_long_gap_names_marker_and_frames():
    x = _markers_mm(20, 3, seed=4) / 1000
    x[5:11, 2] = np.nan
    rec = L.make_recording(x, NAMES, 50.0)
    with pytest.raises(ValueError, match=r"^recording: marker 'STRN' has a gap longer than 5 frames \(frames 5-10 of 20\)"):
        L.fill_gaps(rec, max_gap_frames=5)
    with pytest.raises(ValueError, match="STRN"):
        L.fill_gaps(rec, max_gap_s=0.1)  # 0.1 s at 50 Hz: 5 frames
    assert np.isfinite(L.fill_gaps(rec, max_gap_s=0.12).markers).all()  # 6 frames
    x[:, 0] = np.nan
    rec = L.make_recording(x, NAMES, 50.0)
    with pytest.raises(ValueError, match="RSHO1"):
        L.fill_gaps(rec, max_gap_frames=10)
    kept = L.drop_untracked_markers(rec)
    assert kept.names == NAMES[1:] and kept.markers.shape == (20, 2, 3)


def test_select_markers_and_resample():
    x = _markers_mm(11, 3, seed=5) / 1000
    rec = L.make_recording(x, NAMES, 100.0)
    picked = L.select_markers(rec, ("STRN", "RSHO1"))
    np.testing.assert_array_equal(picked.markers, x[:, [2, 0]])
    with pytest.raises(ValueError, match=r"^names: no marker\(s\) \['LFTP'\] in the recording"):
        L.select_markers(rec, ("LFTP",))
    out = L.resample(rec, 31)
    assert out.markers.shape == (31, 3, 3) and out.rate_hz == pytest.approx(300.0)
    ref = np.interp(np.linspace(0, 10, 31), np.arange(11), x[:, 1, 2])
    np.testing.assert_allclose(out.markers[:, 1, 2], ref, atol=1e-12)
    with pytest.raises(ValueError, match="^n_frames: must be >= 2"):
        L.resample(rec, 1)


def test_make_recording_rejects_bad_input():
    x = np.zeros((4, 2, 3))
    with pytest.raises(ValueError, match=r"^markers: expected shape \(\?, \?, 3\)"):
        L.make_recording(np.zeros((4, 2)), ("a", "b"), 100.0)
    with pytest.raises(ValueError, match="^names: expected 2 names"):
        L.make_recording(x, ("a",), 100.0)
    with pytest.raises(ValueError, match="^names: marker names must be unique"):
        L.make_recording(x, ("a", "a"), 100.0)
    with pytest.raises(ValueError, match="^rate_hz: must be > 0"):
        L.make_recording(x, ("a", "b"), 0.0)
    with pytest.raises(ValueError, match="^markers: contains infinite"):
        L.make_recording(np.full((4, 2, 3), np.inf), ("a", "b"), 100.0)
    with pytest.raises(ValueError, match="^recording: expected a MarkerRecording"):
        L.fill_gaps(x)


@SETTINGS
@given(n_frames=st.integers(2, 30), n_gap=st.integers(1, 6), start=st.integers(0, 29), limit=st.integers(0, 6),
       seed=st.integers(0, 10 ** 6))
def test_fill_gaps_promise(n_frames, n_gap, start, limit, seed):
    """Gaps up to the limit: finite result equal to the input where it was seen; a longer gap: a
    ValueError naming the marker."""
    x = np.random.default_rng(seed).normal(size=(n_frames, 2, 3))
    start = min(start, n_frames - 1)
    holes = x.copy()
    holes[start:start + n_gap, 1] = np.nan
    gap = min(n_gap, n_frames - start)
    rec = L.make_recording(holes, ("a", "b"), 100.0)
    if gap == n_frames or gap > limit:
        with pytest.raises(ValueError, match="^recording: marker 'b'"):
            L.fill_gaps(rec, max_gap_frames=limit)
        return
    out = L.fill_gaps(rec, max_gap_frames=limit).markers
    assert np.isfinite(out).all()
    seen = ~np.isnan(holes)
    np.testing.assert_array_equal(out[seen], x[seen])


@SETTINGS
@given(n_frames=st.integers(1, 40), n_out=st.integers(2, 60), seed=st.integers(0, 10 ** 6))
def test_resample_promise(n_frames, n_out, seed):
    """n_out frames, the first and last frames kept, values within the input's range."""
    x = np.random.default_rng(seed).normal(size=(n_frames, 4))
    out = L.resample_frames(x, n_out)
    assert out.shape == (n_out, 4)
    np.testing.assert_allclose(out[[0, -1]], x[[0, -1]], atol=1e-12)
    assert (out >= x.min(0) - 1e-12).all() and (out <= x.max(0) + 1e-12).all()


@SETTINGS
@given(n_frames=st.integers(1, 8), n_markers=st.integers(1, 4), gap_rate=st.floats(0, 0.5),
       fmt=st.sampled_from([".csv", ".trc"]), seed=st.integers(0, 10 ** 6))
def test_text_marker_files_round_trip(n_frames, n_markers, gap_rate, fmt, seed, tmp_path_factory):
    """What a Nexus CSV or TRC file holds comes back in metres, gaps as NaN, names and rate kept."""
    rng = np.random.default_rng(seed)
    mm = np.round(rng.uniform(-2000, 2000, (n_frames, n_markers, 3)), 3)
    mm[rng.random(mm.shape[:2]) < gap_rate] = np.nan
    names = tuple(f"M{k}" for k in range(n_markers))
    path = tmp_path_factory.mktemp("rt") / f"t{fmt}"
    (write_nexus_csv if fmt == ".csv" else write_trc)(path, mm, names, 100.0)
    rec = L.load_markers(path)
    assert rec.names == names and rec.rate_hz == 100.0
    np.testing.assert_allclose(rec.markers, mm / 1000, atol=1e-9)


def test_angles_file(tmp_path):
    values = np.random.default_rng(6).normal(size=(9, 11))
    loaded = ue_adl.load_joint_angles(write_angles(tmp_path / "P1FR1angles.csv.xz", values))
    np.testing.assert_allclose(loaded.angles, values, atol=1e-6)
    assert loaded.names[0] == "Finger Velocity" and loaded.rate_hz == 100.0
    (tmp_path / "bad.csv").write_text("a,b\n1,2,3\n")
    with pytest.raises(ValueError, match="^path: .* rows of 3 values under a header of 2 columns"):
        ue_adl.load_joint_angles(tmp_path / "bad.csv")
    (tmp_path / "text.csv").write_text("a,b\n1,x\n")
    with pytest.raises(ValueError, match="^path: cannot read .* as a joint-angle CSV"):
        ue_adl.load_joint_angles(tmp_path / "text.csv")
    with pytest.raises(ValueError, match="^path: no such file"):
        ue_adl.load_joint_angles(tmp_path / "none.csv")
    with pytest.raises(ValueError, match="^root: no folder"):
        ue_adl.list_trials(tmp_path, "angles")


def _frames(n, h=24, w=32, seed=7):
    return np.random.default_rng(seed).integers(0, 256, (n, h, w, 3), dtype=np.uint8)


def test_image_folder_is_rgb_uint8_in_name_order(tmp_path):
    import cv2

    frames = _frames(3)
    for k, f in enumerate(frames):
        cv2.imwrite(str(tmp_path / f"f{k:02d}.png"), cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    (tmp_path / "notes.txt").write_text("not an image")
    clip = L.load_image_folder(tmp_path, rate_hz=25.0)
    assert clip.frames.dtype == np.uint8 and clip.rate_hz == 25.0
    np.testing.assert_array_equal(clip.frames, frames)  # PNG is lossless
    assert len(L.load_image_folder(tmp_path, max_frames=2).frames) == 2
    cv2.imwrite(str(tmp_path / "f99.png"), np.zeros((5, 5, 3), np.uint8))
    with pytest.raises(ValueError, match="^path: f99.png is 5x5 pixels"):
        L.load_image_folder(tmp_path)
    (tmp_path / "f99.png").write_bytes(b"broken")
    with pytest.raises(ValueError, match="^path: cannot read the image"):
        L.load_image_folder(tmp_path)
    with pytest.raises(ValueError, match="^path: no such folder"):
        L.load_image_folder(tmp_path / "none")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="^path: .* holds no image"):
        L.load_image_folder(tmp_path / "empty")


def test_video_and_stereo_pair(tmp_path):
    colours = np.array([[200, 30, 30], [30, 200, 30], [30, 30, 200], [200, 200, 30], [30, 200, 200]], np.uint8)
    frames = np.broadcast_to(colours[:, None, None], (5, 24, 32, 3)).copy()  # one colour a frame: RGB order shows
    video = L.load_video(write_video(tmp_path / "left.avi", frames))
    assert video.frames.shape == frames.shape and video.frames.dtype == np.uint8 and video.rate_hz == 10.0
    assert np.abs(video.frames.astype(int) - frames).max() < 12  # MJPG is lossy
    stereo = L.load_stereo_videos(tmp_path / "left.avi", write_video(tmp_path / "right.avi", frames[::-1]))
    assert stereo.left.shape == stereo.right.shape == frames.shape
    write_video(tmp_path / "short.avi", frames[:3])
    with pytest.raises(ValueError, match="^right: 3 frames, the left video has 5"):
        L.load_stereo_videos(tmp_path / "left.avi", tmp_path / "short.avi")
    write_video(tmp_path / "small.avi", _frames(5, 16, 16))
    with pytest.raises(ValueError, match="^right: frames of 16x16 pixels"):
        L.load_stereo_videos(tmp_path / "left.avi", tmp_path / "small.avi")
    with pytest.raises(ValueError, match="^left: no such file"):
        L.load_stereo_videos(tmp_path / "none.avi", tmp_path / "left.avi")
    (tmp_path / "broken.avi").write_bytes(b"not a video")
    with pytest.raises(ValueError, match="^path: "):
        L.load_video(tmp_path / "broken.avi")


REAL = Path(__file__).resolve().parents[1] / ue_adl.UE_ADL_DIR
needs_real = pytest.mark.skipif(not REAL.is_dir(), reason=f"no UE-ADL data at {REAL} (../shared/data/ue_adl)")


@needs_real
def test_real_ue_adl_files():
    marker_trial = ue_adl.list_trials(REAL, "markers")[0]
    rec = L.load_markers(marker_trial.path)
    assert rec.rate_hz == 100.0 and rec.markers.shape[1:] == (49, 3) and rec.names[0] == "RSHO1"
    tracked = L.fill_gaps(L.drop_untracked_markers(rec))
    assert len(tracked.names) == 39 and np.isfinite(tracked.markers).all()
    assert 0.05 < np.nanmax(np.abs(rec.markers)) < 5.0  # metres, not millimetres
    angle_trials = ue_adl.list_trials(REAL, "angles")
    assert {t.action for t in angle_trials} == {0, 1, 2, 3} and {t.side for t in angle_trials} == {"L", "R"}
    angles = ue_adl.load_joint_angles(angle_trials[0].path)
    assert angles.angles.shape[1] == 11 and np.isfinite(angles.angles).all()
