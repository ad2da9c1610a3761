"""hog_jax.video's front end in one call (`front_end`) and its pieces: the camera pair from camera
matrices, the frame-rate scaled background options, the padding and the hand tracks; on a tiny
synthetic stereo recording whose person and skin patch are known."""
import jax
import numpy as np
import pytest

import hog_jax.video as hv
from tests.video_scene import PERSON_RGB, SKIN_RGB, toy_skin_model

H, W, T, START, SHIFT = 24, 32, 16, 10, 2
CAMERA = hv.StereoCamera(focal_px=30.0, baseline_m=0.12, width=W, height=H)


def scene(seed=0):
    """(left, right) (T, H, W, 3) uint8: a textured background; from frame 4 a person block entering from
    the right with two skin patches, a face at its top and a hand left of and below it that moves down
    from START on; the right view is the left one moved SHIFT pixels to the left (a constant
    disparity)."""
    rng = np.random.default_rng(seed)
    base = np.where((np.add.outer(np.arange(H) // 4, np.arange(W) // 4) % 2)[..., None] == 1, 150.0, 100.0)
    frames = []
    for t in range(T):
        img = np.broadcast_to(base, (H, W, 3)).copy()
        if t >= 4:
            left = max(W - 4 * (t - 3), 12)
            img[4:22, left:left + 12] = PERSON_RGB
            img[5:9, left + 7:left + 11] = SKIN_RGB
            top = 12 + (t - START) // 2 if t >= START else 12
            img[top:top + 4, left + 1:left + 4] = SKIN_RGB
        frames.append(np.clip(img + rng.normal(0, 3, img.shape), 0, 255).astype(np.uint8))
    left = np.stack(frames)
    right = np.concatenate([left[:, :, SHIFT:], left[:, :, -1:].repeat(SHIFT, axis=2)], axis=2)
    return left, right


@pytest.fixture(scope="module")
def skin():
    return toy_skin_model()


def test_camera_from_matrices_inverts_camera_matrices():
    camera = hv.StereoCamera(focal_px=300.0, baseline_m=0.12, width=320, height=240, cx=150.0, cy=130.0)
    got = hv.stereo_camera_from_matrices(*hv.camera_matrices(camera), 240, 320)
    assert (got.width, got.height) == (320, 240)
    np.testing.assert_allclose([got.focal_px, got.baseline_m, got.cx, got.cy], [300.0, 0.12, 150.0, 130.0],
                               rtol=1e-12)
    # a world frame turned and moved: the same pair, up to the scale of the matrices
    rot = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    world = np.vstack([np.hstack([rot, [[0.3], [-0.2], [1.5]]]), [0, 0, 0, 1]])
    left, right = (2.5 * p @ world for p in hv.camera_matrices(camera))
    again = hv.stereo_camera_from_matrices(left, right, 240, 320)
    np.testing.assert_allclose([again.focal_px, again.baseline_m, again.cx, again.cy], [300.0, 0.12, 150.0, 130.0],
                               rtol=1e-9)


def test_camera_from_matrices_names_the_bad_argument():
    left, right = hv.camera_matrices(CAMERA)
    with pytest.raises(ValueError, match="P_left"):
        hv.stereo_camera_from_matrices(left[:, :3], right, H, W)
    with pytest.raises(ValueError, match="P_left"):
        hv.stereo_camera_from_matrices(np.zeros((3, 4)), right, H, W)
    with pytest.raises(ValueError, match="P_right"):
        hv.stereo_camera_from_matrices(left, right + [[0, 0, 0, 0], [0, 0, 0, 5.0], [0, 0, 0, 0]], H, W)
    with pytest.raises(ValueError, match="P_right"):
        hv.stereo_camera_from_matrices(left, np.full((3, 4), np.nan), H, W)
    with pytest.raises(ValueError, match="height"):
        hv.stereo_camera_from_matrices(left, right, 0, W)


def test_background_options_for_fps_keep_the_forgetting_time():
    assert hv.BackgroundOptions.for_fps(25.0).alpha == pytest.approx(0.05, rel=1e-12)
    for fps in (5.0, 10.0, 50.0):
        alpha = hv.BackgroundOptions.for_fps(fps).alpha
        assert (1.0 - alpha) ** fps == pytest.approx(0.95 ** 25.0, rel=1e-12)  # the weight left after 1 s
    assert hv.BackgroundOptions.for_fps(10.0)._replace(alpha=0.05) == hv.BackgroundOptions()
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="fps"):
            hv.BackgroundOptions.for_fps(bad)
    with pytest.raises(ValueError, match="alpha"):
        hv.BackgroundOptions.for_fps(10.0, alpha=1.5)


def test_pad_frames_repeats_the_last_frame():
    frames = np.arange(7 * 2).reshape(7, 2)
    padded = hv.pad_frames(frames, 5)
    assert padded.shape == (10, 2)
    np.testing.assert_array_equal(padded[:7], frames)
    np.testing.assert_array_equal(padded[7:], np.repeat(frames[-1:], 3, axis=0))
    np.testing.assert_array_equal(hv.pad_frames(frames, 7), frames)
    with pytest.raises(ValueError, match="multiple"):
        hv.pad_frames(frames, 0)
    with pytest.raises(ValueError, match="frames"):
        hv.pad_frames(frames[:0], 3)


def test_front_end_is_its_pieces_and_padding_changes_nothing(skin):
    left, right = scene()
    options = hv.VideoOptions(person_frames=4, background=hv.BackgroundOptions.for_fps(10.0))
    tracking = hv.HandFaceOptions(tracking=hv.TrackOptions(min_init=2))
    out = hv.front_end(jax.random.key(1), skin, left, right, START, CAMERA, options, tracking, pad_multiple=6)
    models, _ = hv.fit_video_models(jax.random.key(1), skin, left, START, options)
    seg = hv.segment_stereo(models, left, right, START, CAMERA, options, tracking)
    assert out.labels.shape == (T, H, W) and out.hand_left.shape == (T, 2) and out.tracked.shape == (T,)
    np.testing.assert_array_equal(out.labels, np.asarray(seg.left.labels))
    jax.tree.map(lambda a, b: np.testing.assert_array_equal(np.asarray(a), np.asarray(b)), out.positions,
                 seg.positions)
    hand_left, hand_right, tracked = hv.hand_tracks(seg.positions, START)
    np.testing.assert_array_equal(out.hand_left, hand_left)
    np.testing.assert_array_equal(out.hand_right, hand_right)
    np.testing.assert_array_equal(out.tracked, tracked)
    # the hand tracks: (row, column) of the HAND target, tracked in both views and not before START
    lost = np.asarray(seg.positions.skin_left.lost)[:, hv.HAND] | np.asarray(seg.positions.skin_right.lost)[:, hv.HAND]
    np.testing.assert_array_equal(tracked, ~lost & (np.arange(T) >= START))
    np.testing.assert_array_equal(hand_left, np.asarray(seg.positions.skin_left.position)[:, hv.HAND, ::-1])
    assert tracked[START:].mean() > 0.5, tracked
    rows, cols = hand_left[tracked].T
    assert np.all((rows >= 11) & (rows < 22) & (cols >= 12) & (cols < 17)), hand_left[tracked]  # the hand patch


def test_front_end_names_the_bad_argument(skin):
    left, right = scene()
    with pytest.raises(ValueError, match="right"):
        hv.front_end(jax.random.key(0), skin, left, right[:, :, :-1], START, CAMERA)
    with pytest.raises(ValueError, match="pad_multiple"):
        hv.front_end(jax.random.key(0), skin, left, right, START, CAMERA, pad_multiple=0)
    with pytest.raises(ValueError, match="camera"):
        hv.front_end(jax.random.key(0), skin, left, right, START, None)
    with pytest.raises(ValueError, match="left"):
        hv.front_end(jax.random.key(0), skin, left[0], right, START, CAMERA)
    with pytest.raises(ValueError, match="start"):
        hv.hand_tracks(None, -1)
