"""experiments.lfd_demonstration.object_pixels: the position prior and the features against NumPy written out,
the cues of a segmentation, an object recovered from a prior and its label on new windows, and the errors."""
from __future__ import annotations

import numpy as np
import pytest

from experiments.lfd_demonstration.object_pixels import (CUE_CAP, MASK_LOG_ODDS, PixelCues, PixelFrames,
                                                         fit_object_pixels, object_pixel_log_odds,
                                                         object_pixel_masks, pixel_features, position_prior,
                                                         window_cues)
from hog_jax.video import OBJECT, PERSON, SKIN, LogRatio, ObjectSegmentation


def test_position_prior_is_the_smoothed_frequency_in_log_odds():
    truth = np.random.default_rng(0).random((7, 3, 4)) < 0.3
    p = (truth.sum(0) + 1.0) / 9.0
    np.testing.assert_allclose(position_prior(truth), np.log(p) - np.log1p(-p), rtol=1e-12)


def test_features_are_the_prior_the_cues_and_the_label_indicators():
    rng = np.random.default_rng(1)
    cues = PixelCues(rng.normal(size=(2, 3, 4)).astype(np.float16), rng.normal(size=(2, 3, 4)).astype(np.float16),
                     rng.integers(-1, 4, size=(2, 3, 4)).astype(np.int8))
    prior = rng.normal(size=(3, 4))
    f = pixel_features(prior, cues)
    assert f.shape == (2, 3, 4, 6) and f.dtype == np.float32
    for t in range(2):
        for i in range(3):
            for j in range(4):
                label = cues.labels[t, i, j]
                expected = [prior[i, j], cues.temporal[t, i, j], cues.stereo[t, i, j], label == PERSON,
                            label == SKIN, label == OBJECT]
                np.testing.assert_allclose(f[t, i, j], np.asarray(expected, np.float32), rtol=1e-6)


def test_window_cues_keep_valid_ratios_clipped_and_the_temporal_one_where_the_hand_moved():
    rng = np.random.default_rng(2)
    T, shape = 4, (3, 3)
    ratio = lambda: LogRatio(rng.normal(0, 10, size=(T - 1,) + shape), rng.random((T - 1,) + shape) < 0.7)  # noqa
    temporal, stereo = ratio(), ratio()
    moved = np.array([False, True, False, True])
    seg = ObjectSegmentation(np.zeros((T,) + shape, bool), np.zeros(T, bool), moved, temporal, stereo)
    labels = rng.integers(-1, 4, size=(T,) + shape)
    centre = np.ones((T, 2))  # a 3 x 3 window around the middle of a 3 x 3 frame: the whole frame
    cues = window_cues(seg, labels, centre, (1, 1))
    for t in range(T):
        for cue, source, gate in ((cues.temporal, temporal, moved[t]), (cues.stereo, stereo, True)):
            if t == 0:
                assert not cue[0].any()
                continue
            keep = source.valid[t - 1] & gate
            expected = np.where(keep, np.clip(source.log_ratio[t - 1], -CUE_CAP, CUE_CAP), 0.0)
            np.testing.assert_allclose(cue[t].astype(np.float64), expected, atol=0.01)
    np.testing.assert_array_equal(cues.labels, labels)
    with pytest.raises(ValueError, match="labels"):
        window_cues(seg, labels[:3], centre[:3], (1, 1))


def _windows(rng, n: int, label_rate: float) -> tuple[np.ndarray, PixelCues]:
    """Windows (n, 9, 9) whose object is a 3 x 4 block right of the centre or, in every other window, at the top
    left (the position alone cannot tell), labelled object with probability `label_rate` per pixel; noise cues;
    other pixels labelled person or background at random."""
    truth = np.zeros((n, 9, 9), bool)
    truth[::2, 3:6, 5:9] = True
    truth[1::2, 0:3, 0:4] = True
    labels = np.where(rng.random(truth.shape) < 0.5, PERSON, 0)
    labels = np.where(truth & (rng.random(truth.shape) < label_rate), OBJECT, labels)
    noise = lambda: rng.normal(size=truth.shape).astype(np.float16)  # noqa: E731
    return truth, PixelCues(noise(), noise(), labels.astype(np.int8))


def test_an_object_beside_the_hand_is_recovered_on_new_windows_and_only_in_held_frames():
    rng = np.random.default_rng(3)
    truth, cues = _windows(rng, 60, 0.95)
    model = fit_object_pixels(PixelFrames(np.zeros(60, int), truth, cues))
    w = np.asarray(model.model.weights)
    assert w[5, 1] - w[5, 0] > 0  # the object label speaks for the object
    test_truth, test_cues = _windows(rng, 10, 0.95)
    held = np.arange(10) < 7
    masks = object_pixel_masks(model, test_cues, held)
    assert not masks[~held].any()
    iou = (masks[held] & test_truth[held]).sum() / (masks[held] | test_truth[held]).sum()
    assert iou > 0.85
    log_odds = object_pixel_log_odds(model, test_cues)
    np.testing.assert_array_equal(masks[held], log_odds[held] > MASK_LOG_ODDS)


def test_one_class_training_pixels_and_a_held_of_another_length_are_refused():
    rng = np.random.default_rng(4)
    truth, cues = _windows(rng, 3, 0.5)
    with pytest.raises(ValueError, match="frames"):
        fit_object_pixels(PixelFrames(np.zeros(3, int), np.zeros_like(truth), cues))
    model = fit_object_pixels(PixelFrames(np.zeros(3, int), truth, cues))
    with pytest.raises(ValueError, match="held"):
        object_pixel_masks(model, cues, np.ones(4, bool))
    with pytest.raises(ValueError, match="prior_log_odds"):
        pixel_features(np.zeros((9, 8)), cues)

