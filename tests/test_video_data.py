"""Demonstration videos (experiments/data/video, sim/person_scene): one tiny render checked against
independent references (float64 projection through the camera matrices, numpy mask moments, the
rectified-stereo relation), determinism, the cache, bad input."""
import dataclasses

import chex
import cv2
import numpy as np
import pytest
from hypothesis import given, settings as hsettings, strategies as st

from experiments.data import video
from sim.scenes import StereoRig

TINY = video.VideoSettings(seed=1, n_persons=1, n_repetitions=1, width=80, height=60, fps=2.0, n_empty=2,
                           entry_s=1.0, settle_s=0.5, idle_s=0.5, oac_duration_s=2.0, n_scripts=0)
SEATED = TINY.n_empty + 2 + 1  # the entry takes 1 s * 2 fps frames, putting the left hand on the table 1
SCRIPT = video.Script(person=0, primitives=(video.Primitive("oac", 1, 1),), seed=0)
FOCAL = 525.0 * TINY.width / 640  # the rig's focal length (f = 525 px at 640 x 480, scaled)


@pytest.fixture(scope="module")
def cache_root(tmp_path_factory):
    return tmp_path_factory.mktemp("video_cache")


@pytest.fixture(scope="module")
def tiny(cache_root):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("LFD_JAX_CACHE", str(cache_root))
        first = video.render_recording(TINY, SCRIPT, cache=True)
        cached = video.render_recording(TINY, SCRIPT, cache=True)  # read back from the cache
    return first, cached


def _project(p, points):
    h = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], -1) @ np.asarray(p, np.float64).T
    return h[..., :2] / h[..., 2:]


def test_shapes_and_dtypes(tiny):
    rec, _ = tiny
    t = len(rec.action)
    chex.assert_shape([rec.left, rec.right], (t, 60, 80, 3))
    chex.assert_shape([rec.left_labels, rec.right_labels], (t, 60, 80))
    chex.assert_shape([rec.hand_xyz, rec.face_xyz, rec.hand_cam, rec.face_cam], (t, 3))
    chex.assert_shape([rec.object_xyz, rec.object_cam], (t, 3, 3))
    chex.assert_shape(rec.ellipse_centre, (t, 2, len(video.TRACKED), 2))
    chex.assert_shape(rec.ellipse_cov, (t, 2, len(video.TRACKED), 2, 2))
    chex.assert_shape([rec.P_left, rec.P_right], (3, 4))
    assert rec.left.dtype == np.uint8 and rec.left_labels.dtype == np.uint8
    for field in ("hand_xyz", "face_xyz", "object_xyz", "ellipse_centre", "ellipse_cov", "light"):
        assert np.all(np.isfinite(getattr(rec, field))), field
    assert len(rec.pickup_frames) == len(rec.putdown_frames) == 1 and rec.event_object[0] == 1


def test_labels_empty_scene_then_person_face_hands_and_the_held_object(tiny):
    rec, _ = tiny
    for labels in (rec.left_labels, rec.right_labels):
        assert np.all(labels[:rec.n_empty] == 0)  # the empty scene: background only (objects stand still)
        after = labels[SEATED:]
        for value in (1, 2, 3):  # person, hand skin, face skin
            assert np.all((after == value).any(axis=(1, 2))), video.LABELS[value]
        held = rec.object == 1
        cup = (labels == 4 + 1).any(axis=(1, 2))
        assert held.sum() >= 4 and cup[held].mean() > 0.5
        assert not cup[~held].any() and not (labels >= 4 + 2).any() and not (labels == 4).any()
    assert np.all(rec.action[rec.pickup_frames[0]:rec.putdown_frames[0] + 1] == 1)
    assert np.all(rec.action[:rec.pickup_frames[0]] == -1) and np.all(rec.action[rec.putdown_frames[0] + 1:] == -1)


def test_hand_centroid_agrees_with_the_projected_hand_centre(tiny):
    rec, _ = tiny
    for v, p in enumerate((rec.P_left, rec.P_right)):
        ok = rec.ellipse_area[:, v, 0] >= 8
        assert ok.sum() >= 4
        err = np.linalg.norm(_project(p, rec.hand_xyz[ok]) - rec.ellipse_centre[ok, v, 0], axis=-1)
        assert np.median(err) < 0.6 and err.max() < 2.0, err


def test_ellipses_are_the_moments_of_the_label_masks(tiny):
    rec, _ = tiny
    face = video.TRACKED.index("face")
    for t in range(len(rec.action)):
        for v, labels in enumerate((rec.left_labels[t], rec.right_labels[t])):
            rows, cols = np.nonzero(labels == 3)
            assert rec.ellipse_found[t, v, face] == (rows.size > 0)
            if rows.size:
                np.testing.assert_allclose(rec.ellipse_centre[t, v, face], [cols.mean(), rows.mean()], atol=1e-4)
                np.testing.assert_allclose(rec.ellipse_cov[t, v, face], np.cov(np.stack([cols, rows]), bias=True),
                                           atol=1e-3)


def test_stereo_pair_is_rectified(tiny):
    rec, _ = tiny
    points = np.concatenate([rec.hand_xyz, rec.face_xyz, rec.object_xyz.reshape(-1, 3)]).astype(np.float64)
    cam = np.concatenate([rec.hand_cam, rec.face_cam, rec.object_cam.reshape(-1, 3)]).astype(np.float64)
    left, right = _project(rec.P_left, points), _project(rec.P_right, points)
    np.testing.assert_allclose(left[:, 1], right[:, 1], atol=1e-6)
    np.testing.assert_allclose(left[:, 0] - right[:, 0], FOCAL * 0.12 / cam[:, 2], rtol=1e-4)
    # in the rendered images: the face mask sits on the same rows and shifted by f B / Z
    face = video.TRACKED.index("face")
    seen = rec.ellipse_found[:, 0, face] & rec.ellipse_found[:, 1, face] & (rec.object < 0)  # the hand away
    seen[:SEATED] = False
    assert seen.sum() >= 5
    c = rec.ellipse_centre[seen, :, face]
    rows = np.abs(c[:, 0, 1] - c[:, 1, 1])  # a 7 x 8 px mask: one pixel more or less moves it by 0.1-0.3 px
    disparity = np.abs(c[:, 0, 0] - c[:, 1, 0] - FOCAL * 0.12 / rec.face_cam[seen, 2])
    assert np.median(rows) < 0.1 and rows.max() < 0.5, rows
    assert np.median(disparity) < 0.25 and disparity.max() < 0.6, disparity


def test_deterministic_and_cache_round_trip(tiny, cache_root):
    rec, cached = tiny
    assert list(cache_root.joinpath("video").glob("*.npz"))
    again = video.render_recording(TINY, SCRIPT, cache=False)
    for name in video.Recording._fields:
        np.testing.assert_array_equal(np.asarray(getattr(cached, name)), np.asarray(getattr(rec, name)), err_msg=name)
        np.testing.assert_array_equal(np.asarray(getattr(again, name)), np.asarray(getattr(rec, name)), err_msg=name)
    assert isinstance(cached.n_empty, int) and isinstance(cached.fps, float)


class _BrokenWriter:  # an OpenCV build without an MP4 encoder: the writer does not open
    def __init__(self, *args):
        pass

    def isOpened(self):
        return False

    def release(self):
        pass


def test_outputs(tiny, tmp_path, monkeypatch):
    rec, _ = tiny
    sheet = video.contact_sheet(rec.left[::6], rec.left_labels[::6], tmp_path / "sheet.png")
    assert cv2.imread(str(sheet)) is not None
    path = video.write_video(rec.left, tmp_path / "clip.mp4", fps=rec.fps)
    if path.suffix == ".mp4":
        reader = cv2.VideoCapture(str(path))
        n = 0
        while reader.read()[0]:
            n += 1
        reader.release()
        assert n == len(rec.left)
    else:
        assert path.suffix == ".gif" and path.stat().st_size > 0
    with pytest.raises(ValueError, match="frames"):
        video.write_video(rec.left.astype(np.float32), tmp_path / "bad.mp4")
    monkeypatch.setattr(cv2, "VideoWriter", _BrokenWriter)
    gif = video.write_video(rec.left[:4], tmp_path / "fallback.mp4", fps=rec.fps)
    from PIL import Image

    with Image.open(gif) as image:
        assert gif.suffix == ".gif" and image.n_frames == 4 and image.size == (80, 60)
    with pytest.raises(ValueError, match="labels"):
        video.overlay(rec.left, rec.left_labels[:, :10])


def test_data_set_scripts_and_persons():
    assert len(video.clip_scripts(TINY)) == 3
    paper = video.VideoSettings()
    assert [p.female for p in video.persons(paper)] == [False] * 7 + [True] * 3
    assert len(video.clip_scripts(paper)) == 10 * 3 * 5
    looks = {video.actor(paper, i).look.cloth_rgba for i in range(3)}
    assert len(looks) == 3
    for script in video.long_scripts(dataclasses.replace(paper, n_persons=2)):
        oacs = [(p.action, p.object) for p in script.primitives if p.kind == "oac"]
        assert len(oacs) >= 5 and set(video.UNSEEN) <= set(oacs)
        assert {p.kind for p in script.primitives} == set(video.PRIMITIVES)
        video.check_script(script, paper)


@pytest.mark.parametrize("bad, field", [({"width": 100}, "height"), ({"fps": 0.0}, "fps"),
                                        ({"n_distractors": 3}, "n_distractors"), ({"light_drift": -0.1}, "light_drift"),
                                        ({"shadows": 1}, "shadows"), ({"n_empty": -1}, "n_empty")])
def test_bad_settings_name_the_field(bad, field):
    with pytest.raises(ValueError, match=field):
        video.VideoSettings(**bad)


def test_bad_scripts_and_arguments_name_the_field():
    with pytest.raises(ValueError, match="settings"):
        video.render_recording({"seed": 0}, SCRIPT)
    with pytest.raises(ValueError, match="settings"):
        video.iter_clips({"seed": 0})
    cases = [(SCRIPT._replace(person=1), r"script\.person"), (SCRIPT._replace(primitives=()), "script.primitives"),
             (SCRIPT._replace(primitives=(video.Primitive("dance"),)), r"script\.primitives\[0\]"),
             (SCRIPT._replace(primitives=(video.Primitive("oac", 3, 0),)), r"primitives\[0\]\.action"),
             (SCRIPT._replace(primitives=(video.Primitive("pointing", target=(0.0, 0.3)),)), r"target\[1\]")]
    for script, field in cases:
        with pytest.raises(ValueError, match=field):
            video.render_recording(TINY, script, cache=False)
    with pytest.raises(ValueError, match="rotation"):
        StereoRig(centre=(0.0, 0.0, 0.0), rotation=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, -1.0)))
    with pytest.raises(ValueError, match="name"):
        video.preset("huge")


@hsettings(max_examples=10, deadline=None)
@given(st.integers(1, 3), st.integers(2, 9), st.integers(2, 9), st.integers(0, 2**31 - 1))
def test_ellipses_match_numpy_moments(n, h, w, seed):
    parts = np.random.default_rng(seed).integers(0, 8, (n, h, w)).astype(np.uint8)
    ids = np.array([2, 4, 5, 6, 7])
    centre, cov, area = video.ellipses(parts, ids)
    chex.assert_shape([centre, cov, area], [(n, 5, 2), (n, 5, 2, 2), (n, 5)])
    for i in range(n):
        for j, part in enumerate(ids):
            rows, cols = np.nonzero(parts[i] == part)
            assert area[i, j] == rows.size
            if rows.size:
                np.testing.assert_allclose(centre[i, j], [cols.mean(), rows.mean()], atol=1e-9)
                np.testing.assert_allclose(cov[i, j], np.cov(np.stack([cols, rows]), bias=True), atol=1e-9)
            else:
                assert np.all(centre[i, j] == 0) and np.all(cov[i, j] == 0)
    with pytest.raises(ValueError, match="parts"):
        video.ellipses(parts.astype(np.float32), ids)
