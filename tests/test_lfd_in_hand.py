"""experiments.lfd_demonstration.in_hand and its features: the hand-window features against windows cut by hand, the
decision at equal priors, a held object told from an empty hand on synthetic frames, and the two-state
path against enumeration."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

import hog_jax
from experiments.lfd_demonstration.features import IN_HAND_HOG, LABEL_GRID, WINDOW_SCALE, hand_window_features
from hog_jax.video import OBJECT, PERSON, SKIN
from experiments.lfd_demonstration.in_hand import fit_in_hand, in_hand_log_odds, in_hand_path

HALF = (8, 8)
SIDE = 2 * round(WINDOW_SCALE * HALF[0]) + 1


def test_window_features_are_the_hog_and_label_fractions_of_the_windows_cut_by_hand():
    rng = np.random.default_rng(0)
    grey = rng.integers(0, 256, size=(2, 60, 80)).astype(np.uint8)
    labels = rng.integers(0, 4, size=(2, 60, 80))
    centres = np.array([[30.0, 40.0], [5.0, 70.0]])  # the second window leaves the image: grey 0, background
    reach = round(WINDOW_SCALE * HALF[0])
    pad = lambda x: np.pad(x, ((0, 0), (reach, reach), (reach, reach)))  # noqa: E731
    cut = lambda x: np.stack([pad(x)[t, r:r + SIDE, c:c + SIDE] for t, (r, c) in enumerate(centres.astype(int))])  # noqa
    hog = np.asarray(hog_jax.hog(cut(grey.astype(np.float32)) + 1.0, IN_HAND_HOG))
    around, edges = cut(labels), np.linspace(0, SIDE, LABEL_GRID + 1).astype(int)
    fractions = np.array([[np.mean(around[t, edges[i]:edges[i + 1], edges[j]:edges[j + 1]] == region)
                           for i in range(LABEL_GRID) for j in range(LABEL_GRID) for region in (PERSON, SKIN, OBJECT)]
                          for t in range(2)])
    np.testing.assert_allclose(hand_window_features(grey, labels, centres, HALF), np.concatenate([hog, fractions], 1),
                               rtol=1e-6, atol=1e-7)


def _frames(rng, held: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Noise frames and their labels (all background); a held object is a dark disc beside the window's
    centre, labelled object."""
    grey = rng.normal(150.0, 10.0, size=(held.size, 48, 48))
    rows, cols = np.mgrid[:48, :48]
    disc = np.hypot(rows - 20, cols - 30) < 7
    grey[held] = np.where(disc, 40.0, grey[held])
    labels = np.where(held[:, None, None] & disc, OBJECT, 0)
    return np.clip(grey, 0, 255), labels


def test_a_held_object_is_told_from_an_empty_hand_on_new_frames():
    rng = np.random.default_rng(1)
    centres = np.full((40, 2), 24.0)
    train = rng.random(40) < 0.75  # mostly held, as the clips are
    classifier = fit_in_hand(hand_window_features(*_frames(rng, train), centres, HALF), train)
    test = np.arange(40) % 2 == 0
    log_odds = in_hand_log_odds(classifier, hand_window_features(*_frames(rng, test), centres, HALF))
    assert np.all(log_odds[test] > 0) and np.all(log_odds[~test] < 0)


def test_uninformative_features_give_even_odds_whatever_the_training_prior():
    held = np.arange(40) < 30  # 75 % held
    classifier = fit_in_hand(np.ones((40, 3)), held)
    assert classifier.log_prior_odds == pytest.approx(np.log(3.0))
    np.testing.assert_allclose(in_hand_log_odds(classifier, np.ones((5, 3))), 0.0, atol=4e-3)


def test_one_class_only_is_refused():
    with pytest.raises(ValueError, match="held"):
        fit_in_hand(np.ones((4, 3)), np.ones(4, bool))


def test_the_path_is_the_best_of_all_paths_by_enumeration():
    rng = np.random.default_rng(2)
    paths = np.array(list(itertools.product((0, 1), repeat=10)))
    for cost in (0.0, 1.5, 6.0):
        log_odds = rng.normal(0.0, 3.0, size=10)
        score = lambda s: np.sum((s - 0.5) * log_odds) - cost * np.abs(np.diff(s)).sum()  # noqa: E731
        best = max(score(s) for s in paths)
        assert score(in_hand_path(log_odds, cost).astype(int)) == pytest.approx(best, abs=1e-4)


def test_a_short_flicker_does_not_pay_for_two_switches():
    log_odds = np.r_[np.full(10, 3.0), [-2.0, -2.0], np.full(10, 3.0)]
    assert in_hand_path(log_odds, 5.0).all()
    assert not in_hand_path(log_odds, 1.0)[10:12].any()
