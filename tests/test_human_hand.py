import mujoco
import numpy as np
import pytest

import hog_jax
from sim.grasping import GRASP_CLASSES, GRASP_OBJECTS
from sim.grasping import (ViewOptions, crop_hand, hand_center, look_at_rotation, render_grasp, render_views,
    sphere_camera, view_euler, view_grid)
from sim.hands import (GRASP_POSTURES, GraspSceneOptions, grasp_contacts, grasp_plausibility, grasp_scene_xml,
    hand_pose_in_world, posture, scene_qpos)
from sim.hands import (DEFAULT_SHAPE, FINGERS, JOINT_NAMES, JOINT_RANGES_DEG, NEUTRAL_POSTURE_DEG,
    TEST_SHAPE, HandShape, clip_posture, hand_model_xml, posture_qpos)


def _hand(shape=DEFAULT_SHAPE):
    model = mujoco.MjModel.from_xml_string(hand_model_xml(shape))
    return model, mujoco.MjData(model)


def _tip(model, data, finger, shape=DEFAULT_SHAPE):
    b = model.body(f"{finger}_distal").id
    return data.xpos[b] + data.xmat[b].reshape(3, 3)[:, 0] * shape.finger_lengths[FINGERS.index(finger)][2]


def test_hand_has_20_joints_with_the_declared_ranges():
    model, _ = _hand()
    assert model.nq == model.njnt == len(JOINT_NAMES) == 20
    assert [model.joint(j).name for j in range(model.njnt)] == list(JOINT_NAMES)
    np.testing.assert_allclose(model.jnt_range, np.radians(JOINT_RANGES_DEG), atol=1e-4)
    assert np.all((NEUTRAL_POSTURE_DEG >= JOINT_RANGES_DEG[:, 0]) & (NEUTRAL_POSTURE_DEG <= JOINT_RANGES_DEG[:, 1]))


def test_right_hand_geometry_and_flexion_towards_the_palm():
    model, data = _hand()
    mujoco.mj_forward(model, data)
    tips = {f: _tip(model, data, f) for f in FINGERS}
    # extended fingers: radial to ulnar order along +y, thumb on the radial (+y) side of the index
    ys = [tips[f][1] for f in FINGERS]
    assert ys == sorted(ys, reverse=True)
    # the extended middle finger ends at palm length + its three segments (analytic reference)
    L = DEFAULT_SHAPE
    assert tips["middle"][0] == pytest.approx(L.palm_length + sum(L.finger_lengths[2]), abs=1e-6)
    # flexing the MCP joint by 90 degrees turns the finger to the palm side (-z)
    q = np.zeros(20)
    q[JOINT_NAMES.index("index_mcp")] = np.pi / 2
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    tip = _tip(model, data, "index")
    assert tip[2] < -0.08 and abs(tip[0] - tips["index"][0]) > 0.05


def test_test_hand_is_different_and_bigger_fingered():
    assert TEST_SHAPE != DEFAULT_SHAPE
    assert TEST_SHAPE.skin_rgba != DEFAULT_SHAPE.skin_rgba
    m1, d1 = _hand(DEFAULT_SHAPE)
    m2, d2 = _hand(TEST_SHAPE)
    mujoco.mj_forward(m1, d1)
    mujoco.mj_forward(m2, d2)
    assert _tip(m2, d2, "middle", TEST_SHAPE)[0] > _tip(m1, d1, "middle")[0] + 0.005


@pytest.mark.parametrize("kwargs", [dict(finger_lengths=((0.04, 0.03),) * 5), dict(palm_width=float("nan")),
                                    dict(palm_length=0.5), dict(skin_rgba=(1.0, 0.5, 0.5, 2.0))])
def test_hand_shape_rejects_bad_values(kwargs):
    with pytest.raises(ValueError):
        HandShape(**kwargs)


def test_posture_checks_ranges_and_clips():
    bad = NEUTRAL_POSTURE_DEG.copy()
    bad[JOINT_NAMES.index("ring_pip")] = 150.0
    with pytest.raises(ValueError, match="ring_pip"):
        posture_qpos(bad)
    with pytest.raises(ValueError, match="posture_deg"):
        posture_qpos(np.zeros(19))
    assert clip_posture(bad)[JOINT_NAMES.index("ring_pip")] == JOINT_RANGES_DEG[JOINT_NAMES.index("ring_pip"), 1]
    np.testing.assert_allclose(posture(9, 0.0), NEUTRAL_POSTURE_DEG)
    np.testing.assert_allclose(posture(9, 1.0), GRASP_POSTURES[9].joints_deg)
    with pytest.raises(ValueError, match="grasp"):
        posture(3)
    with pytest.raises(ValueError, match="stage"):
        posture(9, 1.5)


@pytest.mark.parametrize("grasp", GRASP_CLASSES)
def test_reference_grasps_touch_without_deep_penetration(grasp):
    c = grasp_contacts(grasp)
    p = grasp_plausibility(grasp)
    assert p["n_contacts"] == len(c.parts) >= 4
    assert {"thumb", "index"} <= set(p["fingers_in_contact"])
    assert ("palm" in p["fingers_in_contact"]) == (grasp in (1, 2, 4, 10))  # power grasps touch with the palm
    assert 0.0 < p["max_penetration_mm"] < 1.5
    np.testing.assert_allclose(np.linalg.norm(c.normals, axis=1), 1.0, atol=1e-6)
    obj = GRASP_OBJECTS[grasp]
    # contacts lie on the object's surface and normals point out of it (independent geometry)
    if obj.geom_type == "sphere":
        r = np.linalg.norm(c.positions, axis=1)
        np.testing.assert_allclose(r, obj.size[0], atol=2e-3)
        np.testing.assert_allclose(c.normals, c.positions / r[:, None], atol=0.05)
    if obj.geom_type == "cylinder":
        radial = np.linalg.norm(c.positions[:, :2], axis=1)
        on_side = np.abs(radial - obj.size[0]) < 2e-3
        on_cap = np.abs(np.abs(c.positions[:, 2]) - obj.size[1]) < 2e-3
        assert np.all(on_side | on_cap)
        out = np.where(on_side, np.sum(c.normals[:, :2] * c.positions[:, :2], 1) / radial,
                       c.normals[:, 2] * np.sign(c.positions[:, 2]))
        assert np.all(out > 0.6)  # at the rim the normal may lean halfway between side and cap


def test_hand_pose_puts_the_object_upright_at_the_origin():
    for grasp in GRASP_CLASSES:
        pos, quat = hand_pose_in_world(grasp)
        r = np.zeros(9)
        mujoco.mju_quat2Mat(r, quat)
        obj_world = pos + r.reshape(3, 3) @ np.asarray(GRASP_POSTURES[grasp].object_pos)
        np.testing.assert_allclose(obj_world, 0.0, atol=1e-9)
        model = mujoco.MjModel.from_xml_string(grasp_scene_xml(grasp))
        data = mujoco.MjData(model)
        data.qpos[:] = scene_qpos(GRASP_POSTURES[grasp].joints_deg)
        mujoco.mj_forward(model, data)
        np.testing.assert_allclose(data.xmat[model.body("object").id], np.eye(3).ravel(), atol=1e-9)


def test_cameras_look_at_their_target():
    rot = look_at_rotation([0.3, -0.2, 0.4], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(-rot[:, 2], -np.array([0.3, -0.2, 0.4]) / np.linalg.norm([0.3, -0.2, 0.4]))
    pos, rot = sphere_camera(30.0, 45.0, 0.5, roll_deg=10.0, target=(0.1, 0.0, 0.0))
    assert np.linalg.norm(pos - [0.1, 0.0, 0.0]) == pytest.approx(0.5)
    np.testing.assert_allclose(-rot[:, 2], ([0.1, 0.0, 0.0] - pos) / 0.5, atol=1e-12)
    assert pos[2] == pytest.approx(0.5 * np.sin(np.radians(45.0)))
    euler = view_euler(30.0, 45.0, 10.0)
    np.testing.assert_allclose(euler, np.radians([30.0, -45.0, 10.0]))
    # the recorded rotation is the viewing frame: its x axis points from the target to the camera, its z
    # axis is the image's up (hog_jax's quaternion convention, an independent implementation)
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, np.asarray(hog_jax.euler_to_quat(euler), float))
    r = r.reshape(3, 3)
    np.testing.assert_allclose(r[:, 0], rot[:, 2], atol=1e-6)
    np.testing.assert_allclose(r[:, 2], rot[:, 1], atol=1e-6)
    with pytest.raises(ValueError, match="look_at"):
        look_at_rotation([0, 0, 1], [0, 0, 1])


def test_render_shows_a_skin_coloured_hand_partly_hidden_by_the_black_object():
    grasp = 10
    centre = hand_center(grasp)
    pos, rot = sphere_camera(90.0, 0.0, 0.5, target=centre)
    blue = GraspSceneOptions(background_rgb=(0.0, 0.0, 1.0))
    kw = dict(rotation=rot, width=64, height=64)
    with_obj = render_grasp(grasp, pos, options=blue, **kw)
    bare = render_grasp(grasp, pos, options=GraspSceneOptions(with_object=False, background_rgb=(0.0, 0.0, 1.0)), **kw)
    assert with_obj.shape == (64, 64, 3) and with_obj.dtype == np.uint8
    assert tuple(with_obj[0, 0]) == (0, 0, 255)                       # the background colour
    skin = lambda im: (im[..., 0] > im[..., 2] + 30).sum()            # reddish pixels
    assert skin(with_obj) > 100
    dark = lambda im: (im.max(-1) < 30).sum()
    assert dark(with_obj) > dark(bare) + 20                            # the black ball is there
    same = render_grasp(grasp, pos, look_at=centre, width=64, height=64, options=blue)
    assert np.mean(np.abs(same.astype(int) - with_obj.astype(int))) < 2.0  # look-at == the rotation
    with pytest.raises(ValueError, match="look_at"):
        render_grasp(grasp, pos)


def test_view_grid_is_the_papers_half_sphere():
    az, el = view_grid(60, 15)
    assert az.size == el.size == 900
    np.testing.assert_allclose(np.unique(np.diff(np.unique(az))), 6.0)
    np.testing.assert_allclose(np.unique(el), np.arange(3.0, 90.0, 6.0))
    with pytest.raises(ValueError, match="n_azimuth"):
        view_grid(0, 15)


def test_crop_hand_centres_the_mask_in_a_square_box():
    mask = np.zeros((100, 120), bool)
    mask[10:30, 50:90] = True                     # 20 x 40 box
    rgb = np.full((100, 120, 3), 200.0)
    img, m = crop_hand(rgb, mask, out_size=48, margin=0.1)
    rows, cols = np.flatnonzero(m.any(1)), np.flatnonzero(m.any(0))
    # long side 40 px -> box side 48 px -> 1 px per output px: the 40 columns fill 40 of the 48
    assert cols.size == 40 and abs(cols.mean() - 23.5) <= 0.5
    assert 19 <= rows.size <= 21 and abs(rows.mean() - 23.5) <= 1.0
    np.testing.assert_allclose(img[m], 200.0 / 255.0, atol=1e-5)
    assert np.all(img[~m] == 0.0)
    empty, none = crop_hand(rgb, np.zeros((100, 120), bool), out_size=16)
    assert not none.any() and not empty.any()


def test_render_views_gives_centred_hand_crops():
    images, masks = render_views(2, [0.0, 123.0], [10.0, 60.0], ViewOptions(render_size=64, out_size=32))
    assert images.shape == masks.shape == (2, 32, 32)
    assert np.all(masks.sum((1, 2)) > 100) and images.max() <= 1.0
    for m in masks:                               # the crop is centred on the hand
        rows, cols = np.nonzero(m)
        assert abs(rows.mean() - 15.5) < 5 and abs(cols.mean() - 15.5) < 5
