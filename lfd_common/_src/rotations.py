"""Rotations, once: unit quaternions, rotation matrices, Z-Y'-X'' Euler angles, axis-angle.

Conventions (every function):
* A quaternion is (..., 4) in the order (w, x, y, z), w the scalar part (MuJoCo's order; scipy's
  `Rotation.as_quat()` is (x, y, z, w)). q and -q are the same rotation; functions that return a
  quaternion return the one with w >= 0.
* A rotation matrix R (..., 3, 3) acts on column vectors, v_world = R v_body: its columns are the
  body axes in the world frame (MuJoCo's `xmat`, row-major).
* Euler angles (..., 3) are (phi, theta, psi) in radians, intrinsic Z-Y'-X'' (yaw about z, then pitch
  about the new y, then roll about the newest x): R = Rz(phi) Ry(theta) Rx(psi), scipy's
  `Rotation.from_euler("ZYX", [phi, theta, psi])`. Going back, theta lies in [-pi/2, pi/2].

Array kind: jax in, jax out (so the functions trace under `jit`, `vmap` and `grad`); numpy (or lists)
in, numpy out, computed in numpy so that float64 stays float64 when JAX runs in float32 (MJCF
written by `sim` needs the precision).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.typing import ArrayLike

__all__ = ["axis_angle_to_matrix", "euler_zyx_to_quat", "matrix_to_quat", "quat_to_euler_zyx", "quat_to_matrix"]


def _xp(*arrays):
    """jax.numpy when any argument is a jax array (or tracer), else numpy."""
    return jnp if any(isinstance(a, jax.Array) for a in arrays) else np


def _as(xp, a):
    return a if isinstance(a, jax.Array) else np.asarray(a, dtype=np.result_type(np.asarray(a), np.float32))


def quat_to_matrix(q: ArrayLike) -> ArrayLike:
    """Rotation matrices of unit quaternions (as MuJoCo's `mju_quat2Mat`).

    The quaternion is not normalised here: pass q / |q| when it may not be a unit quaternion.

    Args:
        q: (..., 4) unit quaternions (w, x, y, z); jax in, jax out; numpy in, numpy out.

    Returns:
        (..., 3, 3) rotation matrices acting on column vectors.
    """
    xp = _xp(q)
    q = _as(xp, q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return xp.stack([
        xp.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        xp.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        xp.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def matrix_to_quat(r: ArrayLike) -> ArrayLike:
    """Unit quaternions of rotation matrices (Shepperd's method, branch-free).

    The four candidate formulas are computed and, per matrix, the one dividing by the largest of
    (1 + tr R, 1 + 2 R_ii - tr R) is kept (the best conditioned).

    Args:
        r: (..., 3, 3) rotation matrices; jax in, jax out; numpy in, numpy out.

    Returns:
        (..., 4) unit quaternions (w, x, y, z) with w >= 0.
    """
    xp = _xp(r)
    r = _as(xp, r)
    m00, m11, m22 = r[..., 0, 0], r[..., 1, 1], r[..., 2, 2]
    tr = m00 + m11 + m22
    # 4 q_k^2 for k = w, x, y, z; and 4 q_k q_j for the off-diagonal combinations
    four_sq = xp.stack([1 + tr, 1 + 2 * m00 - tr, 1 + 2 * m11 - tr, 1 + 2 * m22 - tr], -1)
    a = r[..., 2, 1] - r[..., 1, 2]  # 4 w x
    b = r[..., 0, 2] - r[..., 2, 0]  # 4 w y
    c = r[..., 1, 0] - r[..., 0, 1]  # 4 w z
    d = r[..., 1, 0] + r[..., 0, 1]  # 4 x y
    e = r[..., 0, 2] + r[..., 2, 0]  # 4 x z
    f = r[..., 2, 1] + r[..., 1, 2]  # 4 y z
    cands = xp.stack([
        xp.stack([four_sq[..., 0], a, b, c], -1),
        xp.stack([a, four_sq[..., 1], d, e], -1),
        xp.stack([b, d, four_sq[..., 2], f], -1),
        xp.stack([c, e, f, four_sq[..., 3]], -1),
    ], -2)  # row k = 4 q_k q
    best = xp.argmax(four_sq, axis=-1)
    row = xp.take_along_axis(cands, best[..., None, None], axis=-2)[..., 0, :]
    q = row / xp.linalg.norm(row, axis=-1, keepdims=True)
    return q * xp.where(q[..., :1] < 0, -1.0, 1.0)


def euler_zyx_to_quat(euler: ArrayLike) -> ArrayLike:
    """Unit quaternions of intrinsic Z-Y'-X'' Euler angles, R = Rz(phi) Ry(theta) Rx(psi).

    The same Z-Y-X order as the robot shoulder's Cardan angles in Humanoids 2008 §IV-B (eq. 19).

    Args:
        euler: (..., 3) angles (phi, theta, psi) in radians; jax in, jax out; numpy in, numpy out.

    Returns:
        (..., 4) unit quaternions (w, x, y, z) (w >= 0 for |phi|, |theta|, |psi| <= pi/2).
    """
    xp = _xp(euler)
    half = 0.5 * _as(xp, euler)
    cz, sz = xp.cos(half[..., 0]), xp.sin(half[..., 0])
    cy, sy = xp.cos(half[..., 1]), xp.sin(half[..., 1])
    cx, sx = xp.cos(half[..., 2]), xp.sin(half[..., 2])
    w = cz * cy * cx + sz * sy * sx
    x = cz * cy * sx - sz * sy * cx
    y = cz * sy * cx + sz * cy * sx
    z = sz * cy * cx - cz * sy * sx
    return xp.stack([w, x, y, z], axis=-1)


def quat_to_euler_zyx(q: ArrayLike) -> ArrayLike:
    """Intrinsic Z-Y'-X'' Euler angles of quaternions (normalised here).

    Args:
        q: (..., 4) quaternions (w, x, y, z); jax in, jax out; numpy in, numpy out.

    Returns:
        (..., 3) angles (phi, theta, psi) with phi, psi in (-pi, pi] and theta in [-pi/2, pi/2].
    """
    xp = _xp(q)
    q = _as(xp, q)
    q = q / xp.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    phi = xp.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    theta = xp.arcsin(xp.clip(2 * (w * y - z * x), -1.0, 1.0))
    psi = xp.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    return xp.stack([phi, theta, psi], axis=-1)


def axis_angle_to_matrix(axis: ArrayLike, angle: ArrayLike) -> ArrayLike:
    """Rotation matrices about a unit axis (Rodrigues' formula).

    R = I + sin(a) K + (1 - cos(a)) K^2, K the cross-product matrix of the axis.

    Args:
        axis: (3,) unit axis; jax in, jax out; numpy in, numpy out.
        angle: (...,) angles in radians.

    Returns:
        (..., 3, 3) rotation matrices.
    """
    xp = _xp(axis, angle)
    axis = _as(xp, axis)
    zero = xp.zeros_like(axis[0])
    k = xp.stack([xp.stack([zero, -axis[2], axis[1]]), xp.stack([axis[2], zero, -axis[0]]),
                  xp.stack([-axis[1], axis[0], zero])])
    a = _as(xp, angle)[..., None, None]
    return xp.eye(3, dtype=k.dtype) + xp.sin(a) * k + (1 - xp.cos(a)) * (k @ k)
