"""experiments.data.cdnet: CDnet's pooled scoring on hand-made labels, and the loader on the real
highway frames (skipped without ../shared/data)."""
from pathlib import Path

import numpy as np
import pytest

from experiments.data.cdnet import load_cdnet, score_cdnet

CDNET = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cdnet_highway"


def test_score_counts_by_hand():
    # frame 0: labels  255 255   0  50      prediction  1 0 1 0
    #                   85 170 255   0                  1 1 1 1
    # frame 1: labels  255   0   0   0      prediction  1 1 0 0
    #                   50  50 255 255                  1 0 0 1
    gt = np.array([[[255, 255, 0, 50], [85, 170, 255, 0]],
                   [[255, 0, 0, 0], [50, 50, 255, 255]]], np.uint8)
    pred = np.array([[[1, 0, 1, 0], [1, 1, 1, 1]],
                     [[1, 1, 0, 0], [1, 0, 0, 1]]], bool)
    # scored pixels (85 and 170 ignored): TP = (0,0,0) (0,1,2) (1,0,0) (1,1,3) = 4; FP = (0,0,2) (0,1,3)
    # (1,0,1) (1,1,0) = 4; FN = (0,0,1) (1,1,2) = 2; TN = (0,0,3) (1,0,2) (1,0,3) (1,1,1) = 4
    s = score_cdnet(pred, gt)
    assert (s.tp, s.fp, s.fn, s.tn) == (4, 4, 2, 4)
    assert s.precision == pytest.approx(0.5) and s.recall == pytest.approx(4 / 6)
    assert s.f1 == pytest.approx(2 * 0.5 * (4 / 6) / (0.5 + 4 / 6))
    roi = np.array([[True, True, True, True], [False, False, False, False]])  # only the top rows
    s = score_cdnet(pred, gt, roi)
    assert (s.tp, s.fp, s.fn, s.tn) == (2, 2, 1, 3)


def test_score_degenerate_and_bad_input():
    gt = np.zeros((1, 2, 2), np.uint8)
    s = score_cdnet(np.zeros((1, 2, 2), bool), gt)  # nothing predicted, nothing true: 0, not NaN
    assert (s.precision, s.recall, s.f1, s.tn) == (0.0, 0.0, 0.0, 4)
    with pytest.raises(ValueError, match="pred_masks: shape"):
        score_cdnet(np.zeros((2, 2, 2), bool), gt)
    with pytest.raises(ValueError, match="groundtruth: labels must be"):
        score_cdnet(np.zeros((1, 2, 2), bool), gt + 7)
    with pytest.raises(ValueError, match="pred_masks: expected boolean"):
        score_cdnet(np.full((1, 2, 2), 3), gt)
    with pytest.raises(FileNotFoundError, match="no CDnet sequence"):
        load_cdnet("/nonexistent/cdnet")


@pytest.mark.skipif(not CDNET.is_dir(), reason="../shared/data/cdnet_highway is not here")
def test_real_highway_frames():
    video = load_cdnet(CDNET, first=1191, last=1210)  # 20 labelled frames
    assert video.frames.shape == (20, 240, 320, 3) and video.frames.dtype == np.uint8
    assert video.temporal_roi == (470, 1700) and video.evaluated().all() and video.roi.all()
    assert set(np.unique(video.groundtruth)) <= {0, 50, 85, 170, 255} and (video.groundtruth == 255).any()
    perfect = score_cdnet(video.groundtruth == 255, video.groundtruth, video.roi)
    assert perfect.f1 == 1.0 and perfect.fp == perfect.fn == 0
    assert score_cdnet(np.zeros(video.groundtruth.shape, bool), video.groundtruth).recall == 0.0
    early = load_cdnet(CDNET, first=1, last=2)
    assert not early.evaluated().any() and (early.groundtruth == 85).all()
