"""Arm retargeting (phmm_jax.retarget, Humanoids 2008 eqs. 10-24) against float64 numpy forward
kinematics, geometric invariants and MuJoCo's kinematics of the robot model (sim.robot_arm)."""
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from experiments.data import tabletop as tt
from phmm_jax import DEFAULT_BASE_FRAME, MARKER_ORDER, retarget, solve_arm
from sim._src import robot_arm as robot_arm

A, B = robot_arm.UPPER_ARM_M, robot_arm.FOREARM_M


def _rot(axis, t):
    c, s = np.cos(t), np.sin(t)
    return {0: np.array([[1, 0, 0], [0, c, -s], [0, s, c]]), 1: np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            2: np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def _fk(cardan, delta, alpha):
    """float64 reference: upper-arm frame U = V Rz(psi) Ry(theta) Rx(phi) transposed (eq. 19), elbow,
    grasp point and the gripper's opening direction (the elbow axis twisted about the forearm)."""
    phi, theta, psi = cardan
    R = _rot(2, psi) @ _rot(1, theta) @ _rot(0, phi)  # R = U^T V
    U = DEFAULT_BASE_FRAME @ R.T
    u1, u2, u3 = U.T
    f = np.cos(delta) * u1 + np.sin(delta) * u2
    opening = np.cos(alpha) * u3 + np.sin(alpha) * np.cross(f, u3)
    return A * u1, A * u1 + B * f, opening


@pytest.fixture(scope="module")
def movements():
    rng = np.random.default_rng(0)
    subject = tt.sample_subject(rng)
    rec = tt.concatenate([tt.simulate(rng, [subject], tt.raster_targets(2, 2).reshape(-1, 3), 1, a)
                          for a in tt.ACTIONS])
    return tt.resample(rec, 60).reshape(-1, 60, 7, 3)


def test_marker_order_matches_the_data():
    assert MARKER_ORDER == tt.MARKERS


def test_forward_kinematics_reproduces_the_scaled_arm(movements):
    res = retarget(movements, A, B)
    assert res.shoulder.shape == movements.shape[:2] + (3,) and res.elbow.shape == movements.shape[:2]
    for arr in res:
        assert np.all(np.isfinite(np.asarray(arr)))
    for b in range(movements.shape[0]):
        for t in range(0, movements.shape[1], 7):
            elbow, hand, opening = _fk(np.asarray(res.shoulder[b, t], float), float(res.elbow[b, t]),
                                       float(res.wrist[b, t]))
            target = np.asarray(res.hand[b, t], float)
            if np.linalg.norm(target) < (A + B) * 0.999:
                np.testing.assert_allclose(hand, target, atol=2e-5)  # the robot hand on the scaled hand
            else:  # out of reach: fully extended towards it
                np.testing.assert_allclose(hand, target / np.linalg.norm(target) * (A + B), atol=2e-4)
            np.testing.assert_allclose(elbow, np.asarray(res.robot_elbow[b, t]), atol=2e-5)
            # The robot elbow lies in the plane of shoulder, human elbow and hand, on the elbow's side.
            q = np.asarray(res.elbow_point[b, t], float)
            normal = np.cross(q, target)
            assert abs(elbow @ normal) / np.linalg.norm(normal) < 1e-5
            side = q - (q @ target) / (target @ target) * target
            assert elbow @ side > 0
            # The gripper opens along the finger->thumb direction projected on the twist plane.
            x = movements[b, t]
            o = x[6] - x[5]
            f = (hand - elbow) / B
            o_proj = o - (o @ f) * f
            assert opening @ o_proj / np.linalg.norm(o_proj) > 1 - 1e-4


def test_scale_and_batch_consistency(movements):
    res = retarget(movements, A, B)
    human = np.median(np.linalg.norm(movements[0, :, 2] - movements[0, :, 1], axis=-1)
                      + np.linalg.norm(movements[0, :, 4:7].mean(1) - movements[0, :, 2], axis=-1))
    np.testing.assert_allclose(float(res.scale[0]), (A + B) / human, rtol=1e-5)
    one = retarget(movements[3], A, B)  # (T, 7, 3) and (T, 21) give the same as the batch
    flat = retarget(movements[3].reshape(60, 21), A, B)
    np.testing.assert_allclose(np.asarray(one.shoulder), np.asarray(res.shoulder[3]), atol=1e-6)
    np.testing.assert_allclose(np.asarray(flat.wrist), np.asarray(res.wrist[3]), atol=1e-6)
    fixed = retarget(movements, A, B, shoulder=movements[:, :, 1].mean(1), scale=0.4)
    np.testing.assert_allclose(np.asarray(fixed.hand[:, 10]),
                               0.4 * (movements[:, 10, 4:7].mean(1) - movements[:, :, 1].mean(1)), atol=1e-6)


def test_gradients_are_finite(movements):
    x = jnp.asarray(movements[0, 20:40])
    q, r, o = x[:, 2] - x[:, 1], x[:, 4:7].mean(1) - x[:, 1], x[:, 6] - x[:, 5]

    def loss(q, r):
        arm = solve_arm(0.4 * q, 0.4 * r, o, A, B)
        return jnp.sum(arm.shoulder**2) + jnp.sum(arm.elbow) + jnp.sum(jnp.sin(arm.wrist))

    gq, gr = jax.grad(loss, argnums=(0, 1))(q, r)
    assert np.all(np.isfinite(np.asarray(gq))) and np.all(np.isfinite(np.asarray(gr)))


def test_mujoco_model_agrees(movements):
    res = retarget(movements[:2], A, B)
    model = mujoco.MjModel.from_xml_string(robot_arm.arm_scene_xml(0.3))
    assert model.nq == len(robot_arm.JOINTS)
    qpos = robot_arm.joint_qpos(np.asarray(res.shoulder[1]), np.asarray(res.elbow[1]), np.asarray(res.wrist[1]))
    play = robot_arm.play(model, qpos)
    reachable = np.linalg.norm(np.asarray(res.hand[1]), axis=-1) < (A + B) * 0.999
    np.testing.assert_allclose(play.grasp[reachable] - robot_arm.SHOULDER_POS,
                               np.asarray(res.hand[1])[reachable], atol=3e-5)
    np.testing.assert_allclose(play.elbow - robot_arm.SHOULDER_POS, np.asarray(res.robot_elbow[1]), atol=3e-5)
    assert play.table_distance.shape == (60,) and np.all(np.isfinite(play.table_distance))


def test_table_distance_is_signed():
    model = mujoco.MjModel.from_xml_string(robot_arm.arm_scene_xml(0.3, table_near_y=-0.2))
    hanging = robot_arm.play(model, np.zeros((1, 5)))  # arm straight down: grasp point at z = 0.45 - 0.25
    np.testing.assert_allclose(hanging.grasp[0], robot_arm.SHOULDER_POS - [0, 0, A + B], atol=1e-9)
    assert hanging.table_distance[0] < -0.05  # the hanging arm goes through a table top at 0.3 m
    clear = robot_arm.play(mujoco.MjModel.from_xml_string(robot_arm.arm_scene_xml(0.1)), np.zeros((1, 5)))
    assert clear.table_distance[0] > 0.05


def test_bad_input():
    x = np.zeros((10, 7, 3))
    with pytest.raises(ValueError, match="markers"):
        retarget(np.zeros((10, 6, 3)))
    with pytest.raises(ValueError, match="markers"):
        retarget(np.full((10, 7, 3), np.nan))
    with pytest.raises(ValueError, match="upper_arm"):
        retarget(x, upper_arm=-1.0)
    with pytest.raises(ValueError, match="base_frame"):
        retarget(x, base_frame=2 * np.eye(3))
    with pytest.raises(ValueError, match="scale"):
        retarget(x, scale=0.0)


_solve = jax.jit(lambda q, r, o: solve_arm(q, r, o, A, B))
_grad = jax.jit(jax.grad(lambda q, r, o: sum(jnp.sum(jnp.sin(v)) for v in solve_arm(q, r, o, A, B)[:3]),
                         argnums=(0, 1, 2)))


def _pose(draw_unit, length, kind):
    """Elbow q, hand r, finger->thumb o in robot scale; `kind` builds the singular poses."""
    r = draw_unit(0) * length
    q = draw_unit(1) * A
    o = draw_unit(2) * 0.05
    if kind == "straight":
        q = r / np.linalg.norm(r) * A
    elif kind == "hand at shoulder":
        r = np.zeros(3)
    elif kind == "elbow at shoulder":
        q = np.zeros(3)
    return q, r, o


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**16), length=st.floats(0.02, 0.3),
       kind=st.sampled_from(["free", "straight", "hand at shoulder", "elbow at shoulder"]))
@example(seed=13105, length=0.28125, kind="straight")  # the largest float32 elbow error seen (1.2e-5 m)
def test_solve_arm_singular_poses_are_finite_and_flagged(seed, length, kind):
    rng = np.random.default_rng(seed)

    def draw_unit(_):
        v = rng.normal(size=3)
        return v / np.linalg.norm(v)

    q, r, o = (jnp.asarray(v, jnp.float32) for v in _pose(draw_unit, length, kind))
    arm = _solve(q, r, o)
    for value in (*arm[:4], *_grad(q, r, o)):
        assert np.all(np.isfinite(np.asarray(value)))
    assert bool(arm.singular) == (kind != "free")
    elbow, grasp, _ = _fk(np.asarray(arm.shoulder, float), float(arm.elbow), float(arm.wrist))
    # float32 at a straight arm, where the angles are ill-conditioned: up to 1.2e-5 m (a few thousand
    # straight poses: 3e-6 m but for the pinned example), far below anything a robot resolves
    np.testing.assert_allclose(elbow, np.asarray(arm.robot_elbow), atol=3e-5)
    if kind != "hand at shoulder" and abs(A - B) < length < A + B:  # reachable: the grasp point is on the hand
        np.testing.assert_allclose(grasp, np.asarray(r), atol=1e-4)


def test_retarget_flags_a_straight_arm_and_rejects_a_zero_length_arm(movements):
    straight = movements[:1].copy()
    wrist_dir = straight[0, :, 4:7].mean(1) - straight[0, :, 1]
    straight[0, :, 2] = straight[0, :, 1] + 0.4 * wrist_dir  # elbow on the shoulder-hand line
    res = retarget(straight, A, B)
    assert np.all(np.asarray(res.singular)) and np.all(np.isfinite(np.asarray(res.shoulder)))
    assert not np.any(np.asarray(retarget(movements, A, B).singular))
    with pytest.raises(ValueError, match="markers"):
        retarget(np.ones((10, 7, 3)))
