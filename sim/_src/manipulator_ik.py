"""Forward and inverse kinematics of a serial chain of hinges (the arm of `sim.robot.manipulator_model`), in JAX.

`arm_chain(model, site, joints)` reads a chain from a compiled MuJoCo model: the fixed transforms
between consecutive joints (the body offsets, jointless bodies folded in), each hinge's axis and
anchor, the joint limits, and the site at the end. `forward_kinematics(chain, q)` composes them (no
MJX needed) and matches `mujoco.mj_kinematics`'s site pose.

`solve_ik(chain, target_pos (B, 3), target_rot (B, 3, 3) or quaternions (B, 4), q0 (B, K))` places the
site by damped least squares: each step solves (J Jᵀ + λ² I) y = e, dq = Jᵀ y, for the 6-D pose error
e = (position error, `ROT_WEIGHT_M` x rotation error as a world-frame rotation vector) and the
geometric Jacobian J (6, K), then clips q to the joint limits; a joint that sits on a limit and that
the error pulls further out is held for the step (its column of J is zeroed), so the others do not
compensate for a move that the clip then undoes. The 6 x 6 system is solved by an unrolled Cholesky
factorisation (`lfd_common.solve_spd`): batched LAPACK calls under `jit` can deadlock XLA:CPU (see the
known problems in the docs). The error fed to a step is capped (`MAX_STEP`), so far targets move the arm in
bounded steps and an unreachable target ends at the nearest pose the iterations find, with finite
numbers. Every target runs from q0 and from `n_restarts - 1` random joint vectors within the limits
(vmapped with the batch); the answer is, among the runs that converged, the one nearest to q0 (so a
controller that passes its current q gets continuous joint paths), else the one with the smallest
weighted error. `reachable` = converged within `pos_tol` (m) and `rot_tol` (rad). Hard poses (on the
limits) trap some starts in local minima: while a target is unreached, another round runs it from
its best q so far and fresh random starts (up to `rounds`; the batch keeps its shape, so nothing
compiles again). Measured on 1024 random poses of the whole joint range from `HOME_Q`: 14 missed
after one round of 4 starts, 3 after one round of 8, none after 3 rounds of 8 (the defaults).
"""
from __future__ import annotations

from collections.abc import Sequence
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from numpy.typing import ArrayLike

from lfd_common import as_array, axis_angle_to_matrix, check_int, check_real, float_dtype, matrix_to_quat, \
    quat_to_matrix, solve_spd

__all__ = ["ArmChain", "IKResult", "arm_chain", "forward_kinematics", "solve_ik"]

ROT_WEIGHT_M = 0.3   # metres per radian of rotation error in the DLS error (about a forearm's length)
MAX_STEP = 0.1       # cap on the weighted error one DLS step tries to remove (m)


class ArmChain(NamedTuple):
    """A serial chain of K hinges ending in a site (a pytree of arrays; float32 unless x64 is on).

    Attributes:
        fixed_pos: (K + 1, 3) the fixed translation from the world (k = 0) or from joint k - 1's body
            (after its rotation) to joint k's body; the last one leads to the site.
        fixed_rot: (K + 1, 3, 3) the fixed rotations, likewise.
        axis: (K, 3) each hinge's unit axis in its body's frame.
        anchor: (K, 3) each hinge's point in its body's frame.
        lower: (K,) lower joint limits (rad).
        upper: (K,) upper joint limits (rad).
    """

    fixed_pos: jax.Array
    fixed_rot: jax.Array
    axis: jax.Array
    anchor: jax.Array
    lower: jax.Array
    upper: jax.Array


class IKResult(NamedTuple):
    """The answer of `solve_ik` for B targets.

    Attributes:
        q: (B, K) joint angles (within the limits; best effort where unreachable).
        pos_error: (B,) metres of the site's position at q from the target.
        rot_error: (B,) radians of its rotation at q from the target.
        reachable: (B,) bool: within the tolerances.
    """

    q: jax.Array
    pos_error: jax.Array
    rot_error: jax.Array
    reachable: jax.Array


def _compose(pos_a, rot_a, pos_b, rot_b):
    """The transform a then b (b given in a's frame)."""
    return pos_a + rot_a @ pos_b, rot_a @ rot_b


def _body_transform(model: mujoco.MjModel, body: int):
    return np.asarray(model.body_pos[body], float), quat_to_matrix(np.asarray(model.body_quat[body], float))


def arm_chain(model: mujoco.MjModel, site: str = "palm_centre", joints: Sequence[str] | None = None) -> ArmChain:
    """The kinematic chain from the world to a site of a compiled model.

    Reads the fixed transforms between consecutive joints (the body offsets, jointless bodies folded
    in), each hinge's axis and anchor, and the joint limits (unlimited joints: [-pi, pi]).

    Args:
        model: a compiled MuJoCo model (e.g. `manipulator_model`'s).
        site: the site at the chain's end.
        joints: if given, the names of the chain's joints, in order from the root.

    Returns:
        The `ArmChain`.

    Raises:
        ValueError: no such site; a joint on the way that is not one hinge per body with its zero at
            qpos 0; no joint at all; or `joints` other than the chain's.
    """
    site_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
    if site_id < 0:
        raise ValueError(f"site: no site named {site!r} in the model")
    path, body = [], int(model.site_bodyid[site_id])
    while body > 0:
        path.append(body)
        body = int(model.body_parentid[body])
    pos, rot = np.zeros(3), np.eye(3)
    fixed, axes, anchors, limits, names = [], [], [], [], []
    for body in reversed(path):
        pos, rot = _compose(pos, rot, *_body_transform(model, body))
        n_jnt, first = int(model.body_jntnum[body]), int(model.body_jntadr[body])
        if n_jnt == 0:
            continue
        if n_jnt > 1 or model.jnt_type[first] != mujoco.mjtJoint.mjJNT_HINGE:
            raise ValueError(f"site: body {model.body(body).name!r} on the chain has joints other than one hinge")
        if model.qpos0[model.jnt_qposadr[first]] != 0:
            raise ValueError(f"site: joint {model.joint(first).name!r} has a nonzero reference angle")
        fixed.append((pos, rot))
        axes.append(model.jnt_axis[first])
        anchors.append(model.jnt_pos[first])
        limited = bool(model.jnt_limited[first])
        limits.append(model.jnt_range[first] if limited else (-np.pi, np.pi))
        names.append(model.joint(first).name)
        pos, rot = np.zeros(3), np.eye(3)
    if not names:
        raise ValueError(f"site: no joint between the world and site {site!r}")
    if joints is not None and tuple(joints) != tuple(names):
        raise ValueError(f"joints: the chain to {site!r} has joints {tuple(names)}, not {tuple(joints)}")
    fixed.append(_compose(pos, rot, np.asarray(model.site_pos[site_id], float),
                          quat_to_matrix(np.asarray(model.site_quat[site_id], float))))
    dtype = float_dtype()
    limits = np.asarray(limits, float)
    return ArmChain(*(jnp.asarray(a, dtype) for a in (
        [p for p, _ in fixed], [r for _, r in fixed], axes, anchors, limits[:, 0], limits[:, 1])))


def _frames(chain: ArmChain, q):
    """Site pose and joint frames of one configuration q (K,): site position (3,), rotation (3, 3),
    joint axes (K, 3) and anchors (K, 3) in the world."""
    def joint(frame, link):
        fixed_pos, fixed_rot, axis, anchor, angle = link
        pos, rot = _compose(*frame, fixed_pos, fixed_rot)
        turn = axis_angle_to_matrix(axis, angle)
        # a rotation about the anchor: the body origin moves by (I - turn) anchor in the body frame
        moved = (pos + rot @ (anchor - turn @ anchor), rot @ turn)
        return moved, (rot @ axis, pos + rot @ anchor)

    # a scan, not a Python loop over the joints: the program XLA compiles stays one joint long
    start = (jnp.zeros(3, q.dtype), jnp.eye(3, dtype=q.dtype))
    (pos, rot), (axes, anchors) = jax.lax.scan(
        joint, start, (chain.fixed_pos[:-1], chain.fixed_rot[:-1], chain.axis, chain.anchor, q))
    pos, rot = _compose(pos, rot, chain.fixed_pos[-1], chain.fixed_rot[-1])
    return pos, rot, axes, anchors


@jax.jit
def _forward(chain: ArmChain, q):
    flat = jnp.reshape(q, (-1, q.shape[-1]))
    pos, rot, _, _ = jax.vmap(partial(_frames, chain))(flat)
    return pos.reshape(*q.shape[:-1], 3), rot.reshape(*q.shape[:-1], 3, 3)


def forward_kinematics(chain: ArmChain, q: ArrayLike) -> tuple[jax.Array, jax.Array]:
    """The site's pose at given joint angles; matches `mujoco.mj_kinematics`'s site pose.

    Jittable with jax input; numpy input is checked (shape, finite) first.

    Args:
        chain: the chain (`arm_chain`).
        q: (..., K) joint angles (rad).

    Returns:
        (position (..., 3), rotation (..., 3, 3)), the rotation's columns the site's axes in the world.

    Raises:
        ValueError: q of the wrong shape or not finite (numpy input).
    """
    if not isinstance(q, jax.Array):
        q = jnp.asarray(as_array(q, "q", ndim=(1, 2, 3)), float_dtype())
    if q.shape[-1] != chain.axis.shape[0]:
        raise ValueError(f"q: expected {chain.axis.shape[0]} joint angles in the last axis, got shape {q.shape}")
    return _forward(chain, q)


def _rotation_vector(rot):
    """The rotation vector (3,) (axis times angle in [0, pi]) of a rotation matrix (3, 3), finite
    everywhere: near the identity it tends to the quaternion's vector part times 2."""
    quat = matrix_to_quat(rot)  # w >= 0
    vec = quat[1:]
    sin_half = jnp.linalg.norm(vec)
    safe = jnp.where(sin_half > 1e-7, sin_half, 1.0)
    scale = jnp.where(sin_half > 1e-7, 2.0 * jnp.arctan2(sin_half, quat[0]) / safe, 2.0)
    return vec * scale


def _norm(v):
    """The Euclidean norm of a vector that does not overflow: squaring entries beyond ~1.8e19 overflows
    float32, so large vectors are scaled by a power of two first (exact, and never by 1 / max |v|,
    which XLA computes as a reciprocal that is subnormal, hence flushed to 0, beyond ~8.5e37)."""
    half = jnp.finfo(v.dtype).maxexp // 2  # float32: entries beyond 2^60 are scaled by 2^-66
    scale = jnp.where(jnp.max(jnp.abs(v)) > 2.0 ** (half - 4), 2.0 ** -(half + 2), 1.0).astype(v.dtype)
    return jnp.sqrt(jnp.sum((v * scale) ** 2)) / scale


def _pose_error(chain: ArmChain, q, target_pos, target_rot):
    """Weighted pose error e (6,), Jacobian J (6, K) of the weighted pose, and the position (m) and
    rotation (rad) error norms at q (K,)."""
    pos, rot, axes, anchors = _frames(chain, q)
    e_rot = _rotation_vector(target_rot @ rot.T)           # world frame, as the Jacobian's rows
    e = jnp.concatenate([target_pos - pos, ROT_WEIGHT_M * e_rot])
    jac = jnp.concatenate([jnp.cross(axes, pos - anchors), ROT_WEIGHT_M * axes], -1).T
    return e, jac, _norm(target_pos - pos), jnp.linalg.norm(e_rot)


def _dls(chain: ArmChain, target_pos, target_rot, q, damping, iterations: int):
    """`iterations` damped least-squares steps from q (K,) towards one target: (q, pos_err, rot_err)."""
    eye = jnp.eye(6, dtype=q.dtype)

    def step(_, q):
        e, jac, _, _ = _pose_error(chain, q, target_pos, target_rot)
        e = e * jnp.minimum(1.0, MAX_STEP / jnp.maximum(_norm(e), 1e-12))
        # a joint at a limit that the error pulls further out is held (its column dropped): clipping
        # its step afterwards would waste the step the other joints took to compensate for it
        pull = jac.T @ e
        held = ((q <= chain.lower) & (pull < 0)) | ((q >= chain.upper) & (pull > 0))
        jac = jnp.where(held[None, :], 0.0, jac)
        dq = jac.T @ solve_spd(jac @ jac.T + damping ** 2 * eye, e)
        return jnp.clip(q + dq, chain.lower, chain.upper)

    q = jax.lax.fori_loop(0, iterations, step, q)
    _, _, pos_err, rot_err = _pose_error(chain, q, target_pos, target_rot)
    return q, pos_err, rot_err


@partial(jax.jit, static_argnames=("iterations",))
def _solve(chain, target_pos, target_rot, q_ref, starts, damping, pos_tol, rot_tol, iterations: int):
    """DLS from starts (B, R, K) -> IKResult: per row the converged run nearest to q_ref (B, K), else
    the run with the smallest weighted error."""
    per_start = jax.vmap(partial(_dls, chain, damping=damping, iterations=iterations), in_axes=(None, None, 0))
    q, pos_err, rot_err = jax.vmap(per_start)(target_pos, target_rot, starts)      # (B, R, K), (B, R)
    ok = (pos_err <= pos_tol) & (rot_err <= rot_tol)
    moved = jnp.sum((q - q_ref[:, None]) ** 2, -1)
    score = jnp.where(ok, moved, 1e6 + pos_err + ROT_WEIGHT_M * rot_err)
    best = jnp.argmin(score, axis=1)
    def pick(a):  # (B, R, ...) -> (B, ...) at each row's best run
        return jnp.take_along_axis(a, best.reshape((-1,) + (1,) * (a.ndim - 1)), axis=1)[:, 0]

    return IKResult(pick(q), pick(pos_err), pick(rot_err), pick(ok))


def _check_rotations(target_rot, b: int) -> np.ndarray:
    """(B, 3, 3) rotation matrices or (B, 4) quaternions (w, x, y, z) -> (B, 3, 3) rotation matrices."""
    rot = as_array(target_rot, "target_rot", ndim=(2, 3))
    if rot.shape == (b, 4):
        norm = np.linalg.norm(rot, axis=-1)
        if np.any(np.abs(norm - 1.0) > 1e-3):
            raise ValueError(f"target_rot: quaternions must have unit norm, got norms in "
                             f"[{norm.min():.4g}, {norm.max():.4g}]")
        return quat_to_matrix(rot / norm[:, None])
    if rot.shape != (b, 3, 3):
        raise ValueError(f"target_rot: expected shape ({b}, 3, 3) or ({b}, 4), got {rot.shape}")
    ortho = np.abs(np.swapaxes(rot, 1, 2) @ rot - np.eye(3)).max(axis=(1, 2))
    bad = (ortho > 1e-4) | (np.linalg.det(rot) <= 0)
    if np.any(bad):
        raise ValueError(f"target_rot: {int(bad.sum())} matrices are not rotations (orthonormal, det +1), "
                         f"first at row {int(np.argmax(bad))}")
    return rot


@jax.jit
def _keep_reached(old: IKResult, new: IKResult) -> IKResult:
    """Per row, `old` where it was reachable, else `new` (whose starts included old's q)."""
    return jax.tree.map(lambda a, b: jnp.where(old.reachable.reshape((-1,) + (1,) * (a.ndim - 1)), a, b), old, new)


def solve_ik(chain: ArmChain, target_pos: ArrayLike, target_rot: ArrayLike, q0: ArrayLike | None = None, *,
             pos_tol: float = 1e-3, rot_tol: float = 1e-2,
             iterations: int = 100, n_restarts: int = 8, rounds: int = 3, damping: float = 0.05,
             key: jax.Array | None = None) -> IKResult:
    """Joint angles placing the chain's site at B target poses, by damped least squares.

    See the module docstring for the method. Each of up to `rounds` rounds runs `iterations` DLS steps
    from `n_restarts` starts per target: q0 (later rounds: the best q so far) and random joint vectors
    within the limits drawn with `key`; a round after the first runs only while some target is
    unreached.

    Args:
        chain: the chain (`arm_chain`).
        target_pos: (B, 3) target positions (m, world).
        target_rot: (B, 3, 3) target rotations, or unit quaternions (B, 4), w first.
        q0: (B, K) the first start and the reference a converged answer stays nearest to (clipped to
            the limits); None: the middle of the limits.
        pos_tol: what counts as reachable: position error (m, > 0).
        rot_tol: what counts as reachable: rotation error (rad, > 0).
        iterations: DLS steps per start and round.
        n_restarts: starts per target and round (q0 and n_restarts - 1 random ones).
        rounds: rounds at most.
        damping: λ of the DLS steps (m, > 0).
        key: a `jax.random` key for the random starts; None: key 0.

    Returns:
        The `IKResult`: per target the converged run nearest to q0, else the one with the smallest
            weighted error.

    Raises:
        ValueError: bad input, naming the argument (rotations that are not rotations, quaternions that
            are not unit, shapes that do not match B and K, target positions farther from the origin
            than half the compute dtype's range (float32: 1.7e38 m), tolerances not positive, ...).
    """
    k = int(chain.axis.shape[0])
    dtype = float_dtype()
    pos = as_array(target_pos, "target_pos", shape=(None, 3))
    # checked in float64, solved in the compute dtype: half its range keeps every distance to the arm finite
    limit, far = np.finfo(dtype).max / 2, np.linalg.norm(pos, axis=-1).max()
    if far > limit:
        raise ValueError(f"target_pos: expected positions within {limit:.3g} m of the origin (half the range of "
                         f"{np.dtype(dtype).name}), got one {far:.3g} m away")
    b = pos.shape[0]
    rot = _check_rotations(target_rot, b)
    lower, upper = np.asarray(chain.lower, float), np.asarray(chain.upper, float)
    q0 = np.broadcast_to((lower + upper) / 2, (b, k)) if q0 is None else as_array(q0, "q0", shape=(b, k))
    pos_tol = check_real(pos_tol, "pos_tol", min_value=0.0, exclusive_min=True)
    rot_tol = check_real(rot_tol, "rot_tol", min_value=0.0, exclusive_min=True)
    damping = check_real(damping, "damping", min_value=0.0, exclusive_min=True)
    iterations = check_int(iterations, "iterations", min_value=1, max_value=100_000)
    n_restarts = check_int(n_restarts, "n_restarts", min_value=1, max_value=1024)
    rounds = check_int(rounds, "rounds", min_value=1, max_value=100)
    key = jax.random.PRNGKey(0) if key is None else key
    q_ref = jnp.asarray(np.clip(q0, lower, upper), dtype)
    targets = (jnp.asarray(pos, dtype), jnp.asarray(rot, dtype))
    result = None
    for round_key in jax.random.split(key, rounds):
        randoms = jax.random.uniform(round_key, (b, n_restarts - 1, k), dtype, jnp.asarray(lower, dtype),
                                     jnp.asarray(upper, dtype))
        first = q_ref if result is None else result.q
        starts = jnp.concatenate([first[:, None], randoms], axis=1)
        new = _solve(chain, *targets, q_ref, starts, damping, pos_tol, rot_tol, iterations=iterations)
        result = new if result is None else _keep_reached(result, new)
        if bool(jnp.all(result.reachable)):
            break
    return result
