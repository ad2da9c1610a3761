"""The reach clip's annotated boxes and the track scoring against them (experiments.data.video.reach_clip)."""
import numpy as np
import pytest

from experiments.data.video.reach_clip import PARTS, clip_boxes, on_box, score_tracks


def test_boxes_cover_every_part_of_every_annotated_frame():
    boxes = clip_boxes()
    assert boxes.boxes.shape == (len(boxes.frames), len(PARTS), 4)
    assert (boxes.boxes[..., 2] > boxes.boxes[..., 0]).all() and (boxes.boxes[..., 3] > boxes.boxes[..., 1]).all()
    assert boxes.boxes[..., 2].max() < 260 and boxes.boxes[..., 3].max() < 238  # inside the 260 x 238 clip


def test_on_box_margin_and_nan():
    box = np.array([10.0, 20.0, 30.0, 40.0])
    points = np.array([[10.0, 20.0], [8.0, 20.0], [np.nan, 25.0], [31.5, 41.0]])
    np.testing.assert_array_equal(on_box(points, np.broadcast_to(box, (4, 4)), 0.0), [True, False, False, False])
    np.testing.assert_array_equal(on_box(points, np.broadcast_to(box, (4, 4)), 2.0), [True, True, False, True])


def test_scores_centres_as_hits_and_untracked_as_misses():
    boxes = clip_boxes()
    T = int(boxes.frames.max()) + 1
    centre = (boxes.boxes[:, PARTS.index("face"), :2] + boxes.boxes[:, PARTS.index("face"), 2:]) / 2
    face = np.full((T, 2), np.nan)
    face[boxes.frames] = centre
    hand = face.copy()
    hand[boxes.frames[:2]] = np.nan  # not tracked on two annotated frames
    scores = score_tracks({"face": face, "right_hand": hand}, boxes, margin=0.0)
    assert scores["face"] == {"on_part": 1.0, "centre_distance_px": 0.0, "frames": len(boxes.frames)}
    assert scores["right_hand"]["on_part"] == pytest.approx(0.0)  # the face's centre is not on the hand
