import json

import numpy as np
import pytest

import hog_jax
import sim
from experiments import grasp_recognition as gr
from experiments.data.grasp_tests import (STAGES, Nuisances, clutter_background, random_set, sequence_set,
                                          skin_training_pixels, stage_subsets)

sim.setup_rendering()  # offscreen rendering (EGL) before any scene is rendered


@pytest.fixture(scope="module")
def x_set():
    return sequence_set(seed=3, frame_size=64)


def test_sequence_set_follows_the_paper_protocol(x_set):
    X = x_set
    assert X.frames.shape == (36, 64, 64, 3) and X.frames.dtype == np.uint8
    assert np.bincount(X.labels, minlength=6).tolist() == [6] * 6
    assert np.bincount(X.stage).tolist() == [12, 12, 12]
    subsets = stage_subsets(X.stage)
    assert [int(subsets[k].sum()) for k in ("X", "Xp", "Xpp")] == [36, 24, 12]
    az = np.degrees(X.euler[:, 0]) % 360.0
    el = -np.degrees(X.euler[:, 1])
    # off the database grid: azimuths never on a multiple of 6, elevations never on a band centre 3 + 6 k
    assert np.all(np.abs((az + 3.0) % 6.0 - 3.0) > 0.5)
    assert np.all(np.abs(el % 6.0 - 3.0) > 0.5)
    assert np.all((el > 0) & (el < 90))
    # the hand is in every frame, and the background is clutter (not one flat colour)
    assert np.all(X.hand_masks.sum((1, 2)) > 20)
    assert np.all(X.frames.reshape(36, -1, 3).std(1).max(1) > 10)
    np.testing.assert_allclose(np.linalg.norm(X.quat, axis=1), 1.0, atol=1e-5)


def test_random_set_and_clutter_are_deterministic():
    a = random_set(4, seed=1, frame_size=48)
    b = random_set(4, seed=1, frame_size=48)
    np.testing.assert_array_equal(a.frames, b.frames)
    assert set(a.stage.tolist()) <= {0, 1, 2} and len(STAGES) == 3
    c1 = clutter_background(np.random.default_rng(0), 32)
    c2 = clutter_background(np.random.default_rng(0), 32)
    np.testing.assert_array_equal(c1, c2)
    with pytest.raises(ValueError, match="n"):
        random_set(0)


def test_randomized_scenes_are_labelled_cached_and_checked(tmp_path, monkeypatch):
    from experiments.data.grasp_database import randomized_scenes
    monkeypatch.setenv("LFD_JAX_CACHE", str(tmp_path))
    scenes = randomized_scenes(3, 1, seed=4, frame_size=48, completed_share=0.5)
    assert scenes.frames.shape == (18, 48, 48, 3) and scenes.frames.dtype == np.uint8
    assert scenes.labels.tolist() == [g for g in range(6) for _ in range(3)]
    assert np.all((scenes.reach >= 0) & (scenes.reach <= 1)) and scenes.frames.std() > 10  # clutter, not blank
    np.testing.assert_allclose(np.linalg.norm(scenes.quat, axis=1), 1.0, atol=1e-5)
    again = randomized_scenes(3, 1, seed=4, frame_size=48, completed_share=0.5)  # from the cache
    np.testing.assert_array_equal(again.frames, scenes.frames)
    assert np.all(randomized_scenes(1, 1, seed=4, frame_size=48, completed_share=1.0).reach == 1.0)
    with pytest.raises(ValueError, match="completed_share"):
        randomized_scenes(3, 1, completed_share=1.5)
    with pytest.raises(ValueError, match="n_hands_per_grasp"):
        randomized_scenes(3, 4)


def test_skin_pixels_separate_skin_from_background():
    skin, bg = skin_training_pixels(seed=0, n_images=3, frame_size=48, n_pixels=500)
    assert skin.shape == bg.shape == (500, 3)
    # skin is reddish: R > B on (nearly) every skin pixel, not on the background in general
    assert np.mean(skin[:, 0] > skin[:, 2]) > 0.95
    assert np.mean(bg[:, 0] > bg[:, 2] + 10) < 0.8


def test_orientation_errors_wrap_and_match_a_matrix_reference():
    rng = np.random.default_rng(0)
    e1 = np.column_stack([rng.uniform(-np.pi, np.pi, 50), rng.uniform(-1.4, 1.4, 50), rng.uniform(-np.pi, np.pi, 50)])
    e2 = e1 + rng.normal(0, 0.3, e1.shape)
    q = lambda e: np.asarray(hog_jax.euler_to_quat(np.asarray(e, np.float32)), float)
    d, geo = gr.orientation_errors_deg(e1, e2, q(e1), q(e2))

    def mat(e):
        cz, sz, cy, sy, cx, sx = np.cos(e[0]), np.sin(e[0]), np.cos(e[1]), np.sin(e[1]), np.cos(e[2]), np.sin(e[2])
        Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        return Rz @ Ry @ Rx

    ref = [np.degrees(np.arccos(np.clip((np.trace(mat(a).T @ mat(b)) - 1) / 2, -1, 1))) for a, b in zip(e1, e2)]
    np.testing.assert_allclose(geo, ref, atol=1e-3)
    d, _ = gr.orientation_errors_deg(np.radians([[179.0, 0, -179.0]]), np.radians([[-179.0, 0, 179.0]]),
                                     np.array([[1.0, 0, 0, 0]]), np.array([[1.0, 0, 0, 0]]))
    np.testing.assert_allclose(d, [[2.0, 0.0, 2.0]], atol=1e-9)


def test_confusion_and_wilson_interval():
    c = gr.confusion([0, 0, 1, 2], [0, -1, 2, 2], 3)
    assert c.tolist() == [[1, 0, 0, 1], [0, 0, 1, 0], [0, 0, 1, 0]]
    lo, hi = gr.wilson_interval(50, 100)
    assert lo == pytest.approx(0.4038, abs=1e-3) and hi == pytest.approx(0.5962, abs=1e-3)
    with pytest.raises(ValueError, match="db_grids"):
        gr.Config(db_grids=("60-15",))


def test_experiment_smoke(tmp_path):
    argv = ["--out", str(tmp_path), "--n-azimuth", "8", "--n-elevation", "3", "--render-size", "64",
            "--crop-size", "32", "--n-large", "12", "--n-held-out", "12", "--frame-size", "96", "--k", "3",
            "--k-values", "1,3", "--db-grids", "6x2", "--bins-sweep", "4", "--levels-sweep", "3",
            "--n-skin-images", "3", "--timing-repeats", "1",
            # the paths beyond the paper: randomised views, a network class from rendered scenes, LSH tuned on
            # validation images
            "--n-random-views", "4", "--random-pool", "6", "--n-random-hands", "2", "--classifier", "scene_cnn",
            "--n-scenes", "4", "--n-scene-hands", "2", "--cnn-epochs", "1", "--cnn-width", "2", "--lsh-probes", "1",
            "--lsh-tuning", "validation", "--n-validation", "12", "--ladder", "true"]
    m = gr.main(argv)
    for key in ("accuracy_X", "accuracy_Xp", "accuracy_Xpp", "accuracy_large", "lsh_recall_at_k", "query_ms",
                "orientation_geodesic_error_deg_X", "orientation_geodesic_error_deg_correct", "classifier_ms"):
        assert key in m
    assert all(0.0 <= m[k] <= 1.0 for k in ("accuracy_X", "accuracy_Xp", "accuracy_Xpp", "accuracy_large"))
    assert m["n_database_views"] == 6 * (24 + 4) and m["n_test_X"] == 36
    assert len(m["ladder_accuracy"]) == 6 and 0.0 <= m["lsh_recall_at_k_test_queries"] <= 1.0
    saved = json.loads((tmp_path / "metrics.json").read_text())
    assert len(saved["orientation_error_deg"]) == 3
    for png in ("confusion.png", "orientation.png", "neighbours.png", "sweeps.png", "contact_sheet.png", "ladder.png"):
        assert (tmp_path / png).stat().st_size > 1000
    assert "61 %" in (tmp_path / "report.md").read_text()


def test_symmetric_error_is_the_smallest_error_over_the_objects_symmetries():
    """Closed form (cylinders, disc, ball) and quarter turns (cube) against a dense search over θ."""
    rng = np.random.default_rng(2)
    q = lambda e: np.asarray(hog_jax.euler_to_quat(np.asarray(e, np.float32)), float)
    e1 = np.column_stack([rng.uniform(-np.pi, np.pi, 40), rng.uniform(-1.4, 1.4, 40), rng.uniform(-0.5, 0.5, 40)])
    e2 = e1 + rng.normal(0, 0.6, e1.shape)
    labels = np.arange(40) % 6
    sym = gr.symmetric_errors_deg(q(e1), q(e2), labels)
    _, plain = gr.orientation_errors_deg(e1, e2, q(e1), q(e2))
    for i in range(40):
        order = {9: 4}.get(gr.GRASP_CLASSES[labels[i]], 0)
        thetas = np.arange(4) * np.pi / 2 if order else np.linspace(-np.pi, np.pi, 7201)
        shifted = np.column_stack([e1[i, 0] + thetas, np.full_like(thetas, e1[i, 1]), np.full_like(thetas, e1[i, 2])])
        _, g = gr.orientation_errors_deg(shifted, np.tile(e2[i], (len(thetas), 1)), q(shifted),
                                         np.tile(q(e2[i:i + 1]), (len(thetas), 1)))
        assert sym[i] == pytest.approx(g.min(), abs=0.05)
    assert np.all(sym <= plain + 1e-3)


def test_nuisances_switch_off_one_difference_at_a_time(x_set):
    """The ladder's renders share every draw with the full test: same views, grasps and stages; without
    clutter and photometric changes the background is black, without posture the hand is the grasp's."""
    bare = sequence_set(seed=3, frame_size=64, nuisances=Nuisances(posture=False, photometric=False, clutter=False))
    posed = sequence_set(seed=3, frame_size=64, nuisances=Nuisances(posture=True, photometric=False, clutter=False))
    for a in (bare, posed):
        np.testing.assert_array_equal(a.euler, x_set.euler)
        np.testing.assert_array_equal(a.stage, x_set.stage)
        background = a.frames[~(a.hand_masks | x_set.hand_masks)].max(-1)
        assert np.mean(background > 30) < 0.01 and np.median(background) == 0  # black (hand edges aside)
    assert np.mean(x_set.frames[~x_set.hand_masks].max(-1) > 30) > 0.5     # the full test's clutter
    # the completed grasp (stage 2) differs only by joint noise; the reach stage 0 is far from the grasp
    overlap = lambda a, b: (a & b).sum((1, 2)) / (a | b).sum((1, 2))
    iou = overlap(bare.hand_masks, posed.hand_masks)
    assert np.median(iou[x_set.stage == 0]) < np.median(iou[x_set.stage == 2])
    with pytest.raises(ValueError, match="nuisances"):
        sequence_set(seed=3, frame_size=64, nuisances=(True, True, True))


def test_degraded_crops_lose_detail_finer_than_the_hand_s_pixels_and_keep_the_rest():
    from experiments.data.grasp_database import degrade_crops

    S = 32
    r, c = np.mgrid[:S, :S]
    fine = ((r + c) % 2).astype(np.float32)                        # one-pixel checkerboard
    smooth = (0.5 + 0.4 * np.sin(2 * np.pi * c / S)).astype(np.float32)  # one period across the crop
    full = np.ones((2, S, S), bool)
    same, m_same = degrade_crops(np.stack([fine, smooth]), full, S)
    np.testing.assert_allclose(same, [fine, smooth], atol=1e-5)
    assert m_same.all()
    out, masks = degrade_crops(np.stack([fine, smooth]), full, S // 4)
    assert out.shape == (2, S, S) and masks.all()
    assert out[0, 4:-4, 4:-4].std() < 0.02 * fine.std()           # the checkerboard is gone ...
    np.testing.assert_allclose(out[1, 4:-4, 4:-4], smooth[4:-4, 4:-4], atol=0.05)  # ... the slow wave stays
    half = np.zeros((1, S, S), bool)
    half[0, :, : S // 2] = True
    _, m_half = degrade_crops(np.ones((1, S, S), np.float32), half, 8)
    assert abs(int(m_half.sum()) - S * S // 2) <= 2 * S            # a mask keeps its area
    for bad in (0, S + 1, 2.5, True):
        with pytest.raises(ValueError, match="pixels"):
            degrade_crops(np.stack([fine]), full[:1], bad)
    with pytest.raises(ValueError, match="masks"):
        degrade_crops(np.stack([fine]), full, 8)
