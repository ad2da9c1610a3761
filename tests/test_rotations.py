"""lfd_common.rotations against independent references: scipy's Rotation and MuJoCo's mju_* functions."""
import chex
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from lfd_common import (axis_angle_to_matrix, euler_zyx_to_quat, matrix_to_quat, quat_to_euler_zyx,
                        quat_to_matrix)


def _wxyz(rot: Rotation) -> np.ndarray:
    q = rot.as_quat()[..., [3, 0, 1, 2]]  # scipy: (x, y, z, w)
    return q * np.where(q[..., :1] < 0, -1.0, 1.0)


@pytest.fixture(scope="module")
def rotations():
    return Rotation.random(200, random_state=0)


def test_quat_to_matrix_matches_scipy_and_mujoco(rotations):
    q = _wxyz(rotations)
    r = quat_to_matrix(q)
    assert isinstance(r, np.ndarray) and r.dtype == np.float64
    chex.assert_shape(r, (200, 3, 3))
    np.testing.assert_allclose(r, rotations.as_matrix(), atol=1e-12)
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, q[7])
    np.testing.assert_allclose(r[7].ravel(), m, atol=1e-12)


def test_matrix_to_quat_matches_scipy_in_every_branch(rotations):
    mats = rotations.as_matrix()
    # near-180-degree rotations about each axis exercise the x, y and z branches of Shepperd's method
    extra = Rotation.from_rotvec(np.array([[np.pi - 1e-3, 0, 0], [0, np.pi, 0], [0, 0, np.pi], [0.0, 0.0, 0.0]]))
    mats = np.concatenate([mats, extra.as_matrix()])
    q = matrix_to_quat(mats)
    chex.assert_shape(q, (204, 4))
    want = _wxyz(Rotation.from_matrix(mats))
    # q and -q are the same rotation; where w = 0 the sign of the rest is free
    same = np.minimum(np.abs(q - want).max(-1), np.abs(q + want).max(-1))
    assert same.max() < 1e-12
    assert np.all(q[:, 0] >= 0)
    back = np.zeros(4)
    mujoco.mju_mat2Quat(back, mats[3].ravel())
    np.testing.assert_allclose(q[3], back * np.sign(back[0]), atol=1e-12)


def test_euler_zyx_is_intrinsic_zyx(rotations):
    e = rotations.as_euler("ZYX")  # (phi, theta, psi), theta in [-pi/2, pi/2]
    q = euler_zyx_to_quat(e)
    np.testing.assert_allclose(quat_to_matrix(q), Rotation.from_euler("ZYX", e).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(quat_to_euler_zyx(q), e, atol=1e-9)
    np.testing.assert_allclose(quat_to_euler_zyx(-3.0 * q), e, atol=1e-9)  # normalised, sign-free


def test_axis_angle_matches_scipy():
    axis = np.array([0.48, -0.6, 0.64])
    angles = np.linspace(-3.0, 3.0, 7)
    r = axis_angle_to_matrix(axis, angles)
    chex.assert_shape(r, (7, 3, 3))
    np.testing.assert_allclose(r, Rotation.from_rotvec(angles[:, None] * axis).as_matrix(), atol=1e-12)


def test_jax_in_jax_out_under_jit_and_grad(rotations):
    q = jnp.asarray(_wxyz(rotations), jnp.float32)
    r = jax.jit(quat_to_matrix)(q)
    assert isinstance(r, jax.Array)
    chex.assert_shape(r, (200, 3, 3))
    np.testing.assert_allclose(np.asarray(r), rotations.as_matrix(), atol=1e-5)
    q2 = jax.jit(matrix_to_quat)(r)
    np.testing.assert_allclose(np.abs(np.sum(np.asarray(q2) * np.asarray(q), -1)), 1.0, atol=1e-5)
    e = jax.jit(quat_to_euler_zyx)(q)
    np.testing.assert_allclose(np.asarray(quat_to_matrix(jax.jit(euler_zyx_to_quat)(e))), rotations.as_matrix(),
                               atol=1e-5)
    g = jax.grad(lambda a: axis_angle_to_matrix(jnp.array([0.0, 0.0, 1.0]), a)[0, 1])(0.3)
    assert float(g) == pytest.approx(-np.cos(0.3), abs=1e-6)  # R[0, 1] = -sin(a) about z
    assert np.asarray(quat_to_matrix(np.asarray(q))).dtype == np.float32  # numpy float32 stays float32
