"""hog_jax.video.hand_ends: the hand at the far end of an arm blob, against a NumPy computation."""
import numpy as np
import pytest

from hog_jax.video import FACE, HAND, HandEndOptions, TrackOptions, connected_blobs, hand_ends, track


def _scene():
    """Two frames of 40 x 60: a face blob at the top and an arm (a 6 x 30 bar) reaching down-right, then
    a compact hand (6 x 8) at the same place."""
    masks = np.zeros((2, 40, 60), bool)
    masks[:, 2:10, 26:34] = True  # face
    masks[0, 20:26, 20:50] = True  # arm: forearm and hand, pointing right
    masks[1, 20:26, 42:50] = True  # the hand alone
    return masks


def _numpy_end(mask, reference, end_widths):
    ys, xs = np.nonzero(mask)
    d = np.hypot(xs - reference[0], ys - reference[1])
    cov = np.cov(np.stack([xs, ys]).astype(float), bias=True)
    width = 4.0 * np.sqrt(np.linalg.eigvalsh(cov)[0])
    end = d >= d.max() - end_widths * width
    return np.array([xs[end].mean(), ys[end].mean()])


def test_arm_blob_gives_its_far_end_and_a_compact_blob_the_tracker_position():
    masks = _scene()
    blobs = connected_blobs(masks, max_blobs=4, min_area=4)
    tracks = track(blobs, ("top", "largest"), TrackOptions(min_init=2))
    options = HandEndOptions(end_widths=1.0)
    ends = np.asarray(hand_ends(blobs.labels, tracks, [HAND], FACE, options))
    labels, slot = np.asarray(blobs.labels), np.asarray(tracks.blob)
    face = np.asarray(tracks.position)[0, FACE]
    expected = _numpy_end(labels[0] == slot[0, HAND] + 1, face, 1.0)
    np.testing.assert_allclose(ends[0, 0], expected, atol=1e-3)
    assert ends[0, 0, 0] > 40  # at the hand (x 42-49), not mid-forearm (x ~35)
    np.testing.assert_allclose(ends[1, 0], np.asarray(tracks.position)[1, HAND], atol=1e-5)  # compact: unchanged


def test_bad_arguments_name_themselves():
    masks = _scene()
    blobs = connected_blobs(masks, max_blobs=4, min_area=4)
    tracks = track(blobs, ("top", "largest"), TrackOptions(min_init=2))
    with pytest.raises(ValueError, match="labels: expected 2 frames"):
        hand_ends(np.asarray(blobs.labels)[:1], tracks, [HAND], FACE)
    with pytest.raises(ValueError, match="hands"):
        hand_ends(blobs.labels, tracks, [7], FACE)
    with pytest.raises(ValueError, match="min_elongation"):
        HandEndOptions(min_elongation=1.0)
