"""The WAM-like arm with a robot hand (`sim.manipulator`) and its batched inverse kinematics
(`sim.manipulator_ik`): JAX forward kinematics against MuJoCo's, IK on reachable and unreachable
targets (checked with MuJoCo), gravity compensation of a held pose, the hand on the flange, bad input."""
import copy

import chex
import jax
import mujoco
import numpy as np
import pytest

from sim import arm_chain, forward_kinematics, manipulator_model, manipulator_qpos, manipulator_scene_xml, solve_ik
from sim.grasping import GRASP_OBJECTS
from sim.robot import BASE_POS, DEFAULT_OBJECTS, HOME_Q, JOINT_RANGE, SHOULDER_M
from sim.hands import HAND_NAMES

N_RANDOM, N_FAR = 24, 4


@pytest.fixture(scope="module", params=HAND_NAMES)
def scene(request):
    model, layout = manipulator_model(request.param)
    return model, layout, arm_chain(model, "palm_centre")


@pytest.fixture(scope="module")
def barrett():
    model, layout = manipulator_model("barrett")
    return model, layout, arm_chain(model, "palm_centre")


def _mujoco_site(model, layout, q):
    """(B, 3) positions and (B, 3, 3) rotations of the palm site by `mj_kinematics` at arm angles q (B, 7)."""
    data = mujoco.MjData(model)
    pos, rot = [], []
    for qi in q:
        data.qpos[layout.arm_qpos] = qi
        mujoco.mj_kinematics(model, data)
        pos.append(data.site_xpos[layout.palm_site].copy())
        rot.append(data.site_xmat[layout.palm_site].reshape(3, 3).copy())
    return np.array(pos), np.array(rot)


def _within_limits(q):
    """q (B, 7) within the limits, up to float32 rounding of the limits (IK runs in float32)."""
    return np.all((q >= JOINT_RANGE[:, 0] - 1e-6) & (q <= JOINT_RANGE[:, 1] + 1e-6))


def _random_q(n, seed):
    return np.random.default_rng(seed).uniform(JOINT_RANGE[:, 0], JOINT_RANGE[:, 1], size=(n, 7))


def _grasp_targets(model, layout):
    """(K, 3) palm positions 15 cm above each default object's top (clear of the open fingers), palm
    facing down (its +z along world -z), and (K, 3, 3) such rotations turned about the vertical, as a
    controller's pre-grasp poses."""
    heights = np.array([GRASP_OBJECTS[g].rest_height_m for g in DEFAULT_OBJECTS])
    top = model.body_pos[layout.object_body] + np.stack([0 * heights, 0 * heights, heights], 1)
    angles = 0.4 * np.arange(len(top))
    c, s = np.cos(angles), np.sin(angles)
    rots = np.stack([np.stack([c, s, 0 * c], -1), np.stack([s, -c, 0 * c], -1),
                     np.tile([0.0, 0.0, -1.0], (len(top), 1))], 1)
    return top + [0, 0, 0.15], rots


@pytest.fixture(scope="module")
def ik_batch(barrett):
    """One IK call (one compilation) for the file: random reachable targets, far targets, pre-grasps."""
    model, layout, chain = barrett
    q_true = _random_q(N_RANDOM, 0)
    pos, rot = map(np.array, forward_kinematics(chain, q_true))
    far_dir = np.random.default_rng(1).normal(size=(N_FAR, 3))
    far = BASE_POS + [0, 0, SHOULDER_M] + 3.0 * far_dir / np.linalg.norm(far_dir, axis=1, keepdims=True)
    grasp_pos, grasp_rot = _grasp_targets(model, layout)
    target_pos = np.concatenate([pos, far, grasp_pos])
    target_rot = np.concatenate([rot, rot[:N_FAR], grasp_rot])
    q0 = np.tile(HOME_Q, (len(target_pos), 1))
    return target_pos, target_rot, q0, solve_ik(chain, target_pos, target_rot, q0)


def test_forward_kinematics_matches_mujoco(scene):
    model, layout, chain = scene
    q = _random_q(16, 2)
    pos, rot = forward_kinematics(chain, q)
    chex.assert_shape((pos, rot), ((16, 3), (16, 3, 3)))
    want_pos, want_rot = _mujoco_site(model, layout, q)
    np.testing.assert_allclose(pos, want_pos, atol=2e-6)
    np.testing.assert_allclose(rot, want_rot, atol=2e-6)


def test_the_hand_is_on_the_flange_and_moves_with_the_arm(scene):
    """The palm site is 0.12 m along the flange's z with the flange's rotation, whatever the pose, and
    the last joint turns it (the hand rides on the arm, not on a floating wrist)."""
    model, layout, _ = scene
    assert model.body("hand").parentid[0] == model.body("hand_mount").id
    assert model.nu == 7 + len(layout.hand_ctrl)
    data = mujoco.MjData(model)
    palms = []
    for q in _random_q(4, 3):
        data.qpos[layout.arm_qpos] = q
        mujoco.mj_kinematics(model, data)
        flange_rot = data.site_xmat[layout.flange_site].reshape(3, 3)
        np.testing.assert_allclose(data.site_xmat[layout.palm_site].reshape(3, 3), flange_rot, atol=1e-12)
        np.testing.assert_allclose(data.site_xpos[layout.palm_site] - data.site_xpos[layout.flange_site],
                                   0.12 * flange_rot[:, 2], atol=1e-12)
        palms.append(data.site_xmat[layout.palm_site].copy())
    assert np.abs(np.diff(palms, axis=0)).max() > 0.1


def test_ik_reaches_random_reachable_poses_within_1mm(barrett, ik_batch):
    model, layout, chain = barrett
    target_pos, target_rot, _, res = ik_batch
    b = len(target_pos)
    chex.assert_shape((res.q, res.pos_error, res.rot_error, res.reachable), ((b, 7), (b,), (b,), (b,)))
    ok = slice(0, N_RANDOM)
    assert np.all(np.asarray(res.reachable[ok]))
    q = np.asarray(res.q, float)
    assert _within_limits(q)
    # checked independently: MuJoCo's kinematics at the returned angles
    pos, rot = _mujoco_site(model, layout, q[ok])
    assert np.linalg.norm(pos - target_pos[ok], axis=1).max() < 1e-3
    cos = (np.einsum("bij,bij->b", rot, target_rot[ok]) - 1) / 2
    assert np.arccos(np.clip(cos, -1, 1)).max() < 1e-2


def test_far_targets_are_flagged_unreachable_with_a_finite_best_effort(barrett, ik_batch):
    model, layout, _ = barrett
    target_pos, _, _, res = ik_batch
    far = slice(N_RANDOM, N_RANDOM + N_FAR)
    assert not np.any(np.asarray(res.reachable[far]))
    q = np.asarray(res.q[far], float)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(np.asarray(res.pos_error)))
    assert _within_limits(q)
    # best effort: the reported error is the true one, and the hand reaches out towards the target
    pos, _ = _mujoco_site(model, layout, q)
    dist = np.linalg.norm(pos - target_pos[far], axis=1)
    np.testing.assert_allclose(np.asarray(res.pos_error[far]), dist, atol=1e-4)
    assert np.all(dist < 3.0 - 0.6)


def test_quaternion_targets_give_the_matrix_answer(barrett, ik_batch):
    from lfd_common import matrix_to_quat
    _, _, chain = barrett
    target_pos, target_rot, q0, res = ik_batch
    again = solve_ik(chain, target_pos, matrix_to_quat(target_rot), q0)
    np.testing.assert_array_equal(np.asarray(again.reachable), np.asarray(res.reachable))
    np.testing.assert_allclose(np.asarray(again.q), np.asarray(res.q), atol=1e-3)


def _hold(model, layout, q, seconds=1.0):
    """Start at rest at q (7,) with the servos commanding q; max joint drift (rad) and palm drift (m)."""
    data = mujoco.MjData(model)
    data.qpos[:] = manipulator_qpos(model, layout, q)
    data.ctrl[layout.arm_ctrl] = q
    data.ctrl[layout.hand_ctrl] = data.qpos[model.jnt_qposadr[model.actuator_trnid[layout.hand_ctrl, 0]]]
    mujoco.mj_forward(model, data)
    palm = data.site_xpos[layout.palm_site].copy()
    for _ in range(int(round(seconds / model.opt.timestep))):
        mujoco.mj_step(model, data)
    return (np.abs(data.qpos[layout.arm_qpos] - q).max(),
            np.linalg.norm(data.site_xpos[layout.palm_site] - palm))


def test_gravity_compensation_holds_a_pose_for_a_second(barrett):
    model, layout, _ = barrett
    reach = np.array([0.5, 1.2, -0.3, 0.8, 0.2, -0.5, 0.3])  # outstretched: the largest gravity torques
    for q in (HOME_Q, reach):
        joint, palm = _hold(model, layout, q)
        assert joint < 1e-4 and palm < 1e-4, (joint, palm)
    # the test can tell: the same servos without gravity compensation let the arm sag
    plain = copy.copy(model)
    plain.body_gravcomp[:] = 0.0
    assert _hold(plain, layout, reach)[1] > 5e-3


def test_ik_pregrasp_poses_are_reached_in_simulation(barrett, ik_batch):
    """Commanding the IK answer for a pose above each object: the palm gets there in a second."""
    model, layout, _ = barrett
    target_pos, _, _, res = ik_batch
    grasp = slice(N_RANDOM + N_FAR, None)
    assert np.all(np.asarray(res.reachable[grasp]))
    data = mujoco.MjData(model)
    for goal, q in zip(target_pos[grasp], np.asarray(res.q[grasp], float)):
        mujoco.mj_resetData(model, data)
        data.qpos[:] = manipulator_qpos(model, layout, HOME_Q)
        data.ctrl[layout.arm_ctrl] = q
        for _ in range(500):
            mujoco.mj_step(model, data)
        assert np.linalg.norm(data.site_xpos[layout.palm_site] - goal) < 3e-3


def test_scene_xml_has_the_table_objects_and_pedestal():
    xml = manipulator_scene_xml("karlsruhe", objects=(9, 12), object_xy=[[0.0, -0.4], [0.1, -0.5]])
    model = mujoco.MjModel.from_xml_string(xml)
    for name in ("table", "pedestal", "object0", "object1"):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name) >= 0
    free = model.jnt_type == mujoco.mjtJoint.mjJNT_FREE
    assert free.sum() == 2 and np.all(model.jnt_type[~free] == mujoco.mjtJoint.mjJNT_HINGE)
    np.testing.assert_allclose(model.body("object1").pos, [0.1, -0.5, 0.75 + 0.01])
    assert _within_limits(HOME_Q[None])


@pytest.mark.parametrize("kwargs, match", [
    (dict(target_pos=np.full((2, 3), np.nan)), "target_pos"),
    (dict(target_pos=np.zeros((2, 2))), "target_pos"),
    (dict(target_rot=np.ones((2, 3, 3))), "target_rot"),
    (dict(target_rot=-np.tile(np.eye(3), (2, 1, 1))), "target_rot"),   # det -1: a reflection
    (dict(target_rot=np.tile([2.0, 0, 0, 0], (2, 1))), "target_rot"),
    (dict(target_rot=np.tile(np.eye(3), (3, 1, 1))), "target_rot"),
    (dict(q0=np.zeros((2, 6))), "q0"),
    (dict(q0=np.full((2, 7), np.inf)), "q0"),
    (dict(pos_tol=0.0), "pos_tol"),
    (dict(n_restarts=0), "n_restarts"),
])
def test_bad_input_raises_naming_the_argument(barrett, kwargs, match):
    _, _, chain = barrett
    args = dict(target_pos=np.zeros((2, 3)), target_rot=np.tile(np.eye(3), (2, 1, 1)), q0=None) | kwargs
    with pytest.raises(ValueError, match=match):
        solve_ik(chain, **args)


@pytest.mark.parametrize("far", [1e39, 2e38])  # beyond float32; each coordinate within it, the distance not
def test_targets_beyond_the_float32_range_are_rejected_naming_target_pos(barrett, far):
    _, _, chain = barrett
    with pytest.raises(ValueError, match="^target_pos: expected positions within 1.7e.38 m"):
        solve_ik(chain, np.full((2, 3), far), np.tile(np.eye(3), (2, 1, 1)))


def test_far_but_representable_targets_give_a_finite_error(barrett):
    """Squared, these distances overflow float32 (beyond ~1.8e19 m); the error is still their float64 value."""
    model, layout, chain = barrett
    target_pos = np.array([[1e20, 0.0, 1.0], [-3e30, 1e30, 0.0], [9e37, -9e37, 0.0]])
    res = solve_ik(chain, target_pos, np.tile(np.eye(3), (3, 1, 1)), iterations=5, n_restarts=1, rounds=1)
    q = np.asarray(res.q, float)
    assert np.all(np.isfinite(q)) and _within_limits(q) and not np.any(np.asarray(res.reachable))
    pos, _ = _mujoco_site(model, layout, q)
    np.testing.assert_allclose(np.asarray(res.pos_error, float), np.linalg.norm(target_pos - pos, axis=1), rtol=1e-6)


def test_bad_scene_and_chain_input_raises(barrett):
    model, _, chain = barrett
    with pytest.raises(ValueError, match="hand"):
        manipulator_scene_xml("shadow")
    with pytest.raises(ValueError, match="objects"):
        manipulator_scene_xml(objects=(3,))
    with pytest.raises(ValueError, match="site"):
        arm_chain(model, "nowhere")
    with pytest.raises(ValueError, match="joints"):
        arm_chain(model, "palm_centre", joints=("arm1", "arm2"))
    with pytest.raises(ValueError, match="site"):
        arm_chain(model, "f1_tip")          # finger f1's base body has two hinges (spread, flexion)
    with pytest.raises(ValueError, match="q"):
        forward_kinematics(chain, np.zeros((3, 6)))
    jax.block_until_ready(forward_kinematics(chain, np.zeros(7)))


def test_a_rolling_ball_stops_by_its_rolling_friction():
    # the objects declare a rolling friction of 0.001 m; MuJoCo applies it only with condim 6 (with 4, a ball
    # nudged by the opening fingers rolled on at constant speed, 12-27 cm off its place)
    model, layout = manipulator_model("barrett")
    data = mujoco.MjData(model)
    ball = layout.object_body[list(DEFAULT_OBJECTS).index(10)]
    dof, adr = model.jnt_dofadr[model.body_jntadr[ball]], model.jnt_qposadr[model.body_jntadr[ball]]
    for _ in range(200):                                 # settle on the table
        mujoco.mj_step(model, data)
    start = data.qpos[adr:adr + 2].copy()
    radius, speed, rolling = GRASP_OBJECTS[10].size[0], 0.1, GRASP_OBJECTS[10].friction[2]
    data.qvel[dof:dof + 3] = (speed, 0.0, 0.0)
    data.qvel[dof + 3:dof + 6] = (0.0, speed / radius, 0.0)   # rolling, not sliding
    for _ in range(int(2.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    moved = np.linalg.norm(data.qpos[adr:adr + 2] - start)
    # a solid sphere decelerates at (5/7) g mu_r / r: 3.2 cm to stop from 0.1 m/s (no rolling friction: 20 cm)
    analytic = speed ** 2 / (2 * 5 / 7 * 9.81 * rolling / radius)
    assert 0.5 * analytic < moved < 2 * analytic
    assert np.linalg.norm(data.qvel[dof:dof + 2]) < 0.01
