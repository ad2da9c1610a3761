"""The hand-box scoring of the hand-finder benchmarks (`experiments.peers.mediapipe_hands`): IoU against
pixel counting, greedy matching, the scores; MediaPipe itself is not needed."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from experiments.peers.mediapipe_hands import (HandsOptions, box_iou, inclusive_to_edges, match_boxes,
                                               require_mediapipe, score_boxes)


def _mask(box, size=40):
    m = np.zeros((size, size), bool)
    x0, y0, x1, y1 = (int(v) for v in box)
    m[y0:y1, x0:x1] = True
    return m


_box = st.tuples(st.integers(0, 30), st.integers(0, 30), st.integers(1, 10), st.integers(1, 10)).map(
    lambda b: (b[0], b[1], b[0] + b[2], b[1] + b[3]))


@settings(max_examples=40, deadline=None)
@given(st.lists(_box, min_size=1, max_size=4), st.lists(_box, min_size=1, max_size=4))
def test_iou_equals_pixel_count(a, b):
    iou = box_iou(np.array(a), np.array(b))
    for i, p in enumerate(a):
        for j, q in enumerate(b):
            mp, mq = _mask(p), _mask(q)
            assert iou[i, j] == pytest.approx((mp & mq).sum() / (mp | mq).sum())


@settings(max_examples=40, deadline=None)
@given(st.lists(_box, min_size=0, max_size=5), st.lists(_box, min_size=0, max_size=5),
       st.floats(0.05, 1.0))
def test_matching_is_one_to_one_and_above_threshold(found, truth, threshold):
    pairs = match_boxes(np.array(found).reshape(-1, 4), np.array(truth).reshape(-1, 4), threshold)
    assert len({i for i, _, _ in pairs}) == len({j for _, j, _ in pairs}) == len(pairs)
    assert all(iou >= threshold for _, _, iou in pairs)
    assert [iou for _, _, iou in pairs] == sorted((iou for _, _, iou in pairs), reverse=True)


def test_greedy_takes_the_best_pair_first_and_scores():
    truth = [np.array([[0, 0, 10, 10], [20, 0, 30, 10]], float), np.zeros((0, 4))]
    found = [np.array([[1, 0, 11, 10], [0, 0, 10, 10], [50, 50, 60, 60]], float), np.array([[0, 0, 5, 5]], float)]
    assert [(i, j) for i, j, _ in match_boxes(found[0], truth[0])] == [(1, 0)]
    s = score_boxes(found, truth, 0.5)
    assert (s["true_boxes"], s["found_boxes"], s["matched"], s["false_boxes"]) == (2, 4, 1, 3)
    assert s["recall"] == 0.5 and s["precision"] == 0.25 and s["false_boxes_per_frame"] == 1.5
    assert s["mean_iou_matched"] == 1.0 and s["mean_best_iou"] == pytest.approx(0.5)


def test_inclusive_boxes_and_bad_input():
    np.testing.assert_array_equal(inclusive_to_edges([[2, 3, 4, 5]]), [[2, 3, 5, 6]])
    with pytest.raises(ValueError, match="a"):
        box_iou(np.array([[5, 0, 1, 1]]), np.zeros((0, 4)))
    with pytest.raises(ValueError, match="threshold"):
        match_boxes(np.zeros((0, 4)), np.zeros((0, 4)), 0.0)
    with pytest.raises(ValueError, match="found"):
        score_boxes([np.zeros((0, 4))], [])
    with pytest.raises(ValueError, match="max_num_hands"):
        HandsOptions(max_num_hands=0)


def test_missing_mediapipe_says_make_peers():
    try:
        require_mediapipe()
    except ImportError as err:
        assert "make peers" in str(err)
