"""experiments.lfd_demonstration.features and .labelling: the pipeline's per-frame OAC
features against NumPy / OpenCV references, and the CHCRF labels, eq. 10's history and Z(x) against
hand computation and separable synthetic clips."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hog_jax
from experiments.peers.object_peer import window
from experiments.data.oac import OACData
from experiments.lfd_demonstration.config import Config
from experiments.lfd_demonstration.features import (FeatureSpec, as_oac_data, ellipse_masks, frame_features, held,
                                                    segment_frames, windows)
from experiments.lfd_demonstration.labelling import (PeriodLabels, best_pairs, chcrf_scores, label_metrics,
                                                     with_history)


@given(st.integers(1, 6), st.integers(0, 5), st.integers(0, 5), st.integers(0, 1000))
@settings(max_examples=25, deadline=None)
def test_windows_equal_the_per_frame_window(T, hh, hw, seed):
    rng = np.random.default_rng(seed)
    images = rng.integers(0, 255, (T, 9, 11)).astype(np.uint8)
    centres = np.stack([rng.uniform(-0.4, 8.4, T), rng.uniform(-0.4, 10.4, T)], axis=1)  # the reference's range
    ours = windows(images, centres, (hh, hw), fill=7)
    reference = np.stack([window(im, c, (hh, hw), fill=7) for im, c in zip(images, centres)])
    np.testing.assert_array_equal(ours, reference)
    assert (windows(images, centres + [30.0, -40.0], (hh, hw), fill=7) == 7).all()


def test_held_repeats_the_last_found_value():
    values = np.arange(6, dtype=float)[:, None] * [1.0, 10.0]
    found = np.array([False, True, False, False, True, False])
    np.testing.assert_array_equal(held(values, found)[:, 0], [1, 1, 1, 1, 4, 4])
    assert not held(values, np.zeros(6, bool)).any()


def test_ellipse_masks_against_the_quadratic_form():
    rng = np.random.default_rng(0)
    centres = rng.uniform(2, 10, (3, 2))
    a = rng.normal(size=(3, 2, 2))
    covs = a @ a.transpose(0, 2, 1) * 4
    ours = ellipse_masks((12, 14), centres, covs, 2.0)
    for t in range(3):
        inv = np.linalg.inv(covs[t] + np.eye(2))
        ys, xs = np.mgrid[:12, :14]
        d = np.stack([xs - centres[t, 0], ys - centres[t, 1]], -1)
        np.testing.assert_array_equal(ours[t], np.einsum("...i,ij,...j->...", d, inv, d) <= 4.0)


def test_crop_components_is_segments_crop_of_the_skin_mask():
    """`segment` is skin masks followed by `crop_components`: the same crops from the same masks."""
    rng = np.random.default_rng(1)
    frames = rng.integers(0, 256, (2, 24, 30, 3)).astype(np.uint8)
    frames[:, 5:15, 8:20] = (200, 120, 90)
    skin = rng.integers(0, 256, (400, 3))
    skin[:] = (200, 120, 90)
    skin = skin + rng.integers(-5, 6, skin.shape)
    model = hog_jax.fit_skin_model(__import__("jax").random.key(0), skin, rng.integers(0, 256, (400, 3)),
                                   n_components=1, n_background=2, n_iter=10)
    seeds = np.array([[10.0, 14.0], [0.0, 0.0]])
    seg = hog_jax.segment(model, frames, seeds, out_size=16)
    gray = (frames.astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)) / 255.0
    again = hog_jax.crop_components(gray, np.asarray(seg.skin), seeds, out_size=16)
    for a, b in zip(seg, again):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    empty = hog_jax.crop_components(gray, np.zeros(gray.shape, bool), None, out_size=8)
    assert not np.asarray(empty.found).any() and (np.asarray(empty.boxes) == -1).all()
    with pytest.raises(ValueError, match="masks"):
        hog_jax.crop_components(gray, np.zeros((2, 5, 5), bool))


def test_frame_features_shapes_flags_and_zero_hog_without_a_mask():
    rng = np.random.default_rng(2)
    T = 4
    grey = rng.integers(0, 256, (T, 30, 40)).astype(np.uint8)
    hand = np.zeros((T, 30, 40), bool)
    hand[:3, 10:20, 12:22] = True  # frame 3: no hand
    obj_grey = rng.integers(0, 256, (T, 9, 9)).astype(np.uint8)
    obj = np.zeros((T, 9, 9), bool)
    obj[1:, 2:7, 3:8] = True  # frame 0: no object
    spec = FeatureSpec()
    f = frame_features(grey, hand, np.full((T, 2), 15.0), obj_grey, obj, rng.normal(size=(T, 2)),
                       rng.normal(size=(T, 3)), np.array([True, False, True, True]), spec)
    assert f.hand_hog.shape == (T, hog_jax.hog_dim(hog_jax.HOGConfig(n_bins=4, n_levels=4)))
    assert f.object_hog.shape == (T, hog_jax.hog_dim(hog_jax.HOGConfig(n_bins=4, n_levels=1)))
    np.testing.assert_array_equal(f.hand_found, [True, True, True, False])
    np.testing.assert_array_equal(f.object_found, [False, True, True, True])
    assert not f.hand_hog[3].any() and not f.object_hog[0].any()
    np.testing.assert_array_equal(f.pos2d[1], f.pos2d[0])  # held where not found
    assert np.isfinite(f.hand_hog).all() and np.isfinite(f.object_hog).all()


def test_segment_frames_resamples_within_the_segment():
    np.testing.assert_array_equal(segment_frames(10, 20, 25.0, 10.0), [10, 12, 15, 18])
    np.testing.assert_array_equal(segment_frames(3, 6, 10.0, 10.0), [3, 4, 5])


def test_history_is_equation_10_in_recording_order():
    rng = np.random.default_rng(3)
    joint = rng.dirichlet(np.ones(9), size=3).reshape(3, 3, 3)
    starts, ends = rng.uniform(0, 50, (3, 2)), rng.uniform(0, 50, (3, 2))
    ours = np.exp(with_history(np.log(joint), starts, ends, 20.0))
    for k in range(3):
        prior = np.full((3, 3), 1.0 / 9) / 20.0
        for i in range(k):
            prior = prior + joint[i] / np.linalg.norm(ends[i] - starts[k])
        expected = joint[k] * prior / (k + 1)
        np.testing.assert_allclose(ours[k], expected / expected.sum(), rtol=1e-5)


def _clips(rng, persons=4, reps=2, T=6, noise=0.3) -> OACData:
    """Separable synthetic clips: class c has mean c on every action and object feature."""
    from experiments.lfd_demonstration.features import FrameFeatures

    segs, meta = [], []
    for p in range(persons):
        for c in range(3):
            for r in range(reps):
                x = lambda d: (c + noise * rng.normal(size=(T, d))).astype(np.float32)  # noqa: E731
                segs.append(FrameFeatures(x(2), x(3), x(5), x(4), np.ones(T, bool), np.ones(T, bool),
                                          np.ones(T, bool)))
                meta.append((c, c, p, r))
    return as_oac_data(segs, *np.array(meta).T)


def test_chcrf_labels_separable_clips_and_gives_unseen_pairs_a_small_z():
    rng = np.random.default_rng(4)
    clips = _clips(rng)
    cfg = Config(crf_max_iter=30)
    test = _clips(rng, persons=1, reps=1)  # one clip of each seen OAC, by a new person
    mixed = test._replace(object_hog=test.object_hog[[2, 0, 1]])  # actions 0, 1, 2 with objects 2, 0, 1: unseen
    both = OACData(*(np.concatenate([a, b]) for a, b in zip(test, mixed)))
    log_joint, log_z, log_z_sequence = chcrf_scores(cfg, clips, person=99, periods=both)
    np.testing.assert_array_equal(best_pairs(log_joint[:3]), [[0, 0], [1, 1], [2, 2]])
    assert np.all(np.isfinite(log_z)) and log_z[:3].min() > log_z[3:].max() + 2.0
    assert np.all(log_z <= np.log(1 / 3) + 1e-4) and np.all(log_z_sequence <= log_z + 1e-4)  # Z <= max K
    truth = np.array([[0, 0], [1, 1], [2, 2], [0, 2], [1, 0], [2, 1]])
    labels = PeriodLabels(log_joint, log_z, log_joint, log_z_sequence)
    labelled = [{"found": labels, "found_truth": truth, "true": labels, "true_truth": truth}]
    m = label_metrics(labelled)
    # decisive evidence beats the co-occurrence prior: the unseen pairs are labelled right too, at a low Z
    assert m["oac_correct_rate"] == 1.0 and m["z_seen_above_unseen"] and m["oacs"] == 6
    assert m["z_seen"] > m["z_unseen"] > 0
    with pytest.raises(ValueError, match="person"):
        chcrf_scores(cfg, clips._replace(person=np.zeros_like(clips.person)), person=0, periods=both)


def test_label_periods_of_a_recording_with_history_and_an_empty_one():
    from experiments.lfd_demonstration.features import FrameFeatures
    from experiments.lfd_demonstration.labelling import label_periods
    from experiments.data.video import preset

    rng = np.random.default_rng(5)
    clips = _clips(rng)
    T = 80
    cls = np.repeat([0, 0, 1, 1, 2, 2, 2, 2], 10)  # frames 20-39 look like class 1, 40-79 like class 2
    x = lambda d: (cls[:, None] + 0.3 * rng.normal(size=(T, d))).astype(np.float32)  # noqa: E731
    feats = FrameFeatures(x(2), x(3), x(5), x(4), np.ones(T, bool), np.ones(T, bool), np.ones(T, bool))
    hand = rng.uniform(0, 100, (T, 2))
    settings = preset("quick")  # 10 fps: every frame is a feature frame
    got = label_periods(Config(crf_max_iter=30), settings, clips, 99, feats, hand, np.array([20, 45]),
                        np.array([40, 80]), 1.0)
    np.testing.assert_array_equal(best_pairs(got.log_joint), [[1, 1], [2, 2]])
    assert got.log_joint_history.shape == (2, 3, 3) and np.isfinite(got.log_z).all()
    np.testing.assert_allclose(got.log_joint_history[0], got.log_joint[0], atol=1e-5)  # no history before it
    empty = label_periods(Config(), settings, clips, 99, feats, hand, np.zeros(0, int), np.zeros(0, int), 1.0)
    assert empty.log_joint.shape == (0, 3, 3) and empty.log_z.shape == (0,)
