"""Simulated OAC recordings (experiments/data/oac/) and a smoke run of experiments/oac_recognition."""
import json

import numpy as np
import pytest

import sim
from experiments.data import oac

sim.setup_rendering()  # offscreen rendering (EGL) before any scene is rendered

TINY = oac.OACSettings(seed=3, n_persons=3, n_repetitions=1, fps=3.0, image_px=24, object_px=16)


@pytest.fixture(scope="module")
def tiny():
    return oac.generate(TINY, cache=False)


def test_settings_reject_bad_values():
    for bad in ({"n_persons": 0}, {"fps": float("nan")}, {"image_px": 4}, {"pixel_noise": -1.0}):
        with pytest.raises(ValueError):
            oac.OACSettings(**bad)
    with pytest.raises(ValueError, match="settings"):
        oac.generate({"seed": 0})


def test_persons_differ_and_are_seven_men_three_women():
    persons = oac.draw_persons(np.random.default_rng(0), 10)
    assert [p.female for p in persons] == [False] * 7 + [True] * 3
    for field in ("size", "speed", "amplitude", "hold", "tilt"):
        values = np.array([getattr(p, field) for p in persons])
        assert np.ptp(values) > 0.05, field
    women = np.mean([p.size for p in persons[7:]])
    men = np.mean([p.size for p in persons[:7]])
    assert women < men


def test_trajectories_start_and_end_on_the_table_and_look_through_is_like_drink():
    rng = np.random.default_rng(1)
    person = oac.draw_persons(rng, 1)[0]
    face = np.array([0.0, 0.0, oac.TABLE_Z_M + 0.45 * person.size])
    targets = []
    for cls in range(oac.N_CLASSES):
        pos, rots = oac.object_trajectory(cls, person, rng, 40)
        assert pos.shape == (40, 3) and rots.shape == (40, 3, 3)
        np.testing.assert_allclose(rots @ np.swapaxes(rots, 1, 2), np.broadcast_to(np.eye(3), rots.shape), atol=1e-9)
        np.testing.assert_allclose(np.linalg.det(rots), 1.0, atol=1e-9)
        for end in (0, -1):  # resting on the table: the grasped part's centre at its rest height
            assert abs(pos[end, 2] - oac.TABLE_Z_M - oac.grip_of(cls, person).rest_height_m) < 1e-9
        targets.append(pos[20] - face)
    with pytest.raises(ValueError, match="cls"):
        oac.object_trajectory(3, person, rng, 40)
    look, drink, pour = (np.linalg.norm(t) for t in targets)
    assert look < 0.2 and drink < 0.2 and pour > 0.3  # two actions at the face, one far from it
    assert np.linalg.norm(targets[0] - targets[1]) < 0.15  # look through / drink: alike in position


def test_stereo_projection_and_triangulation_invert_each_other():
    person = oac.draw_persons(np.random.default_rng(2), 1)[0]
    centre, rot = oac.camera_pose(person)
    np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=1e-12)
    points = np.array([[0.1, -0.2, 1.1], [-0.2, -0.5, 0.9], [0.0, 0.0, 1.2]])
    right = centre + oac.BASELINE_M * rot[:, 0]
    got = oac.triangulate(oac.project(points, centre, rot), oac.project(points, right, rot))
    np.testing.assert_allclose(got, (points - centre) @ rot, atol=1e-9)


def test_noise_free_positions_are_the_exact_geometry():
    settings = oac.OACSettings(centroid_noise_px=0.0, stereo_noise_px=0.0, merge_noise_px=0.0)
    person = oac.draw_persons(np.random.default_rng(4), 1)[0]
    hand = np.array([[-0.2, -0.3, 0.9], [-0.05, -0.1, 1.15]])
    pos2d, pos3d = oac.measured_positions(hand, person, np.random.default_rng(0), settings)
    centre, rot = oac.camera_pose(person)
    face = np.array([0.0, 0.0, oac.TABLE_Z_M + 0.45 * person.size])
    np.testing.assert_allclose(pos2d, oac.project(hand, centre, rot) - oac.project(face, centre, rot), atol=1e-9)
    np.testing.assert_allclose(pos3d, (hand - face) @ rot, atol=1e-9)
    noisy2d, noisy3d = oac.measured_positions(hand, person, np.random.default_rng(0), oac.OACSettings())
    assert 0.5 < np.abs(noisy2d - pos2d).max() < 40.0  # pixels
    assert np.abs(noisy3d - pos3d).max() < 0.5  # metres


def test_generated_set_shapes_labels_and_rendered_features(tiny):
    n = 3 * TINY.n_persons * TINY.n_repetitions
    T = int(tiny.lengths.max())
    assert tiny.action.shape == (n,) and tiny.lengths.shape == (n,)
    np.testing.assert_array_equal(tiny.action, tiny.object)  # one object per action (K is diagonal)
    assert sorted(np.unique(tiny.action)) == [0, 1, 2]
    assert sorted(np.unique(tiny.person)) == list(range(TINY.n_persons))
    assert tiny.pos2d.shape == (n, T, 2) and tiny.pos3d.shape == (n, T, 3)
    assert tiny.hand_hog.shape == (n, T, 4 * (16 + 4 + 1)) and tiny.object_hog.shape == (n, T, 4)
    valid = np.arange(T)[None] < tiny.lengths[:, None]
    assert np.all(tiny.hand_hog[~valid] == 0) and np.all(tiny.pos2d[~valid] == 0)
    # every frame sees the rendered hand: global HOG normalisation makes each of the L levels sum to 1
    np.testing.assert_allclose(tiny.hand_hog[valid].sum(-1), 3.0, atol=1e-4)
    obj_sums = tiny.object_hog[valid].sum(-1)
    assert np.mean(np.abs(obj_sums - 1.0) < 1e-4) > 0.9
    # the hand goes from the table up to the face (look through, drink) and back
    for i in np.flatnonzero(tiny.action < 2):
        distance = np.linalg.norm(tiny.hand_true[i, : tiny.lengths[i]], axis=-1)
        assert distance[0] > 0.45 and distance.min() < 0.25 and distance[tiny.lengths[i] - 1] > 0.45
        height = -tiny.pos2d[i, : tiny.lengths[i], 1]  # image y points down
        assert height[0] < -80 and height.max() > -60


def test_generation_is_deterministic_and_persons_differ(tiny):
    again = oac.generate(TINY, cache=False)
    for a, b in zip(tiny, again):
        np.testing.assert_array_equal(a, b)
    other = oac.generate(oac.OACSettings(**{**TINY.__dict__, "seed": 4}), cache=False)
    assert not np.array_equal(tiny.pos2d, other.pos2d)
    rows = [np.flatnonzero((tiny.action == 0) & (tiny.person == p))[0] for p in range(TINY.n_persons)]
    assert len({int(tiny.lengths[r]) for r in rows}) > 1 or not np.allclose(tiny.pos2d[rows[0]], tiny.pos2d[rows[1]])


def test_re_rendered_recording_matches_the_generated_one(tiny):
    rec = oac.recording_images(TINY, 2, 1, 0)
    i = np.flatnonzero((tiny.action == 2) & (tiny.person == 1) & (tiny.repetition == 0))[0]
    assert rec["n"] == tiny.lengths[i]
    np.testing.assert_allclose(rec["pos2d"], tiny.pos2d[i, : rec["n"]], atol=1e-4)
    assert rec["hand_mask"].any(axis=(1, 2)).all()
    with pytest.raises(ValueError, match="cls"):
        oac.recording_images(TINY, 3, 0, 0)


def test_standardise_uses_training_frames_only():
    from experiments.data.oac_protocol import standardise

    X = np.zeros((3, 4, 2))
    X[0, :2] = [[1.0, 2.0], [3.0, 6.0]]
    X[1, :4] = 5.0
    X[2, :1] = [[100.0, -100.0]]
    lengths = np.array([2, 4, 1])
    out = standardise(X, lengths, np.array([True, False, False]))
    np.testing.assert_allclose(out[0, :2], [[-1, -1], [1, 1]])
    assert np.all(out[0, 2:] == 0) and np.all(out[2, 1:] == 0)  # padding stays zero
    np.testing.assert_allclose(out[2, 0], [(100 - 2) / 1, (-100 - 4) / 2])


def test_experiment_smoke(tmp_path):
    from experiments import oac_recognition

    metrics = oac_recognition.main([
        "--preset", "quick", "--out", str(tmp_path), "--n-persons", "3", "--n-repetitions", "1", "--fps", "3",
        "--image-px", "24", "--n-runs", "1", "--max-iter", "3", "--seed", "3",
    ])
    saved = json.loads((tmp_path / "metrics.json").read_text())
    for table in ("table2", "table3", "table4", "table_lfd"):
        assert any(key.startswith(table + "_") for key in saved), table
    cell = {stat: saved[f"table3_actions_chcrf_error_pct_{stat}"] for stat in ("median", "max")}
    assert 0.0 <= cell["median"] <= cell["max"] <= 100.0
    assert all(np.isscalar(v) for v in saved.values())  # flat keys, units in the names
    assert saved["runtime_s"] > 0 and metrics["n_recordings"] == 9
    assert "table2_actions_crf_conn0_error_pct_median" in saved
    report = (tmp_path / "report.md").read_text()
    assert "paper" in report and "CHCRF" in report
    for fig in ("trajectories.png", "views.png", "errors.png"):
        assert (tmp_path / fig).stat().st_size > 1000


def test_demo_stage_classifies_one_recording(tmp_path):
    from types import SimpleNamespace

    from experiments.config import RunOutput
    from experiments.oac_recognition import demo_stage

    result = demo_stage(SimpleNamespace(seed=0))
    metrics, section = result.metrics, result.report
    RunOutput(tmp_path, "demo").write(metrics, section, result.figures)
    assert metrics["oac_demo_true_class"] in oac.CLASSES
    assert 0.0 < metrics["oac_demo_p_joint"] <= 1.0 and np.isfinite(metrics["oac_demo_log_z"])
    assert "CHCRF" in section and (tmp_path / "oac_demo.png").exists()
