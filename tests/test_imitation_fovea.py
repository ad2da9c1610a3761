"""The grasp stage's foveal camera (`experiments.imitation.fovea`) on a rendered frame of known geometry:
the hand's 3-D centre (MuJoCo's kinematics of the demonstration's pose) projected with the wide left
camera's matrix is where the fovea is aimed; the rendered fovea (MuJoCo's own camera, set from the
fovea's rig) shows the whole hand, tens of pixels across, where the fovea's camera matrix puts it, and
moves it as the angles say when the aim moves."""
import numpy as np
import pytest

import sim
from experiments.data import video
from experiments.imitation import Config, Demo, PRESETS
from experiments.imitation.fovea import Fovea, camera_of, fovea_rig
from sim.scenes import PART_NAMES, StereoRig

CFG = Config(**PRESETS["quick"])
# person 0 picks the cup (object 1) with a power grasp and puts it nearer the cameras
DEMO = Demo("transfer", person=0, seed=7, objects_xy=np.array([[-0.24, -0.32], [0.02, -0.36], [-0.30, -0.47]]),
            target=1, grasp=1, place_xy=np.array([-0.05, -0.45]))
SIZE, FOV_DEG = 96, 12.0
HAND = PART_NAMES.index("hand")


def _project(P, x):
    p = P @ np.append(x, 1.0)
    return p[1::-1] / p[2]  # (row, col)


def test_camera_of_recovers_a_rig():
    rot = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))[0]
    rot *= np.linalg.det(rot)
    rig = StereoRig(centre=(0.1, -1.2, 1.4), rotation=rot, width=160, height=120, focal_px=131.25)
    K, R, c = camera_of(rig.projection_matrices()[0])
    np.testing.assert_allclose(K, rig.intrinsics(), atol=1e-9)
    np.testing.assert_allclose(R, rot, atol=1e-9)
    np.testing.assert_allclose(c, rig.centre, atol=1e-9)
    with pytest.raises(ValueError, match="P"):
        camera_of(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="fov_deg"):
        fovea_rig(rig.projection_matrices()[0], (60, 80), 64, 0.0)
    with pytest.raises(ValueError, match="fovea_px"):
        Config(fovea_px=4)
    with pytest.raises(ValueError, match="fovea_fov_deg"):
        Config(fovea_fov_deg=90.0)
    with pytest.raises(ValueError, match="grasp_classifier"):
        Config(grasp_classifier="svm")
    with pytest.raises(ValueError, match="grasp_classifier"):
        Config(grasp_database="study", grasp_classifier="cnn")


def test_fovea_shows_the_hand_where_the_geometry_says():
    sim.setup_rendering()
    settings = CFG.video_settings()
    with Fovea(settings, SIZE, FOV_DEG) as fovea:
        wide = video.actor(settings, DEMO.person).rig.projection_matrices()[0]  # the left camera
        frame = int(fovea.movement(DEMO).pickups[0])
        hand_xyz = fovea.pose(DEMO, frame).centres()[0]     # the pose at the pick-up: the hand's centre
        rc = _project(wide, hand_xyz)                       # the reference: where the wide camera sees it
        shift = np.array([2.0, -3.0])                       # a tracking error, wide-view pixels
        _, parts, rig = fovea.view(DEMO, frame, wide, rc, noise=False)
        _, parts_s, _ = fovea.view(DEMO, frame, wide, rc + shift, noise=False)
    centre = (SIZE - 1) / 2
    np.testing.assert_allclose(_project(rig.projection_matrices()[0], hand_xyz), (centre, centre), atol=1e-6)
    mask, mask_s = parts == HAND, parts_s == HAND
    assert mask.any() and mask_s.any()
    ys, xs = np.nonzero(mask)
    # the whole hand inside the fovea, tens of pixels across (the database's crops are 64 px)
    assert 30 <= max(np.ptp(ys), np.ptp(xs)) < SIZE - 2 and not (mask[0].any() or mask[-1].any()
                                                                 or mask[:, 0].any() or mask[:, -1].any())
    # the rendered hand about the projected centre (visible pixels' centroid vs the centre of volume)
    assert np.hypot(ys.mean() - centre, xs.mean() - centre) < 0.12 * SIZE
    # aiming `shift` off moves the rendered hand by -shift x the focal lengths' ratio (small angles)
    expected = -shift * rig.focal_px / camera_of(wide)[0][0, 0]
    moved = np.array(np.nonzero(mask_s)).mean(1) - np.array([ys.mean(), xs.mean()])
    np.testing.assert_allclose(moved, expected, atol=1.0)
