"""Human arm movement -> joint angles of a HOAP-3-like robot arm (Humanoids 2008 §IV-B, eqs. 10-24).

Shapes: T frames (any leading batch axes allowed before T), markers in the papers' order
`MARKER_ORDER` (sternum, shoulder, elbow, wrist, index knuckle, index tip, thumb tip), metres.

The human elbow q and hand r (mean of index knuckle, index tip and thumb tip) are taken relative to
the shoulder p and scaled to the robot's arm length a + b. The robot's hand is placed on the scaled
hand (when within reach; otherwise as far as it gets along the shoulder-hand line) with its elbow q'
in the plane of p, q, r:

    gamma = arccos((a² + b² - c²) / 2ab)    (10)   elbow angle, c = |r|
    beta  = arccos((a² + c² - b²) / 2ac)    (11)   angle between the upper arm and p->r
    u1 = cos(beta) w1 + sin(beta) w2        (12)   upper-arm direction; w1 = r/|r| (13);
    w2 = unit(q - <q, w1> w1)               (14, 15)
    u2 = unit(-w2 - <-w2, u1> u1), u3 = u1 x u2      (20-22, see below for beta > 90 deg)
    R = [u1|u2|u3]^T [v1|v2|v3] = Rz(psi) Ry(theta) Rx(phi)    (19; Cardan angles 16-18)

Eq. 21 takes -w2 (projected off u1) as the direction the forearm bends to. That holds while beta
< 90 deg; when the hand comes close to the shoulder of an arm whose forearm is longer than its upper
arm (b² > a² + c², as for HOAP-3 near the rest pose), -w2 points away from the hand and the elbow
would bend the wrong way. We use the direction from the elbow to the hand, projected off u1, which
equals eq. 21 whenever beta < 90 deg and stays right beyond.

{v_i} is the robot's fixed shoulder frame (default: v1 down, v2 forward, v3 to the right, i.e. the
arm hanging), so the upper-arm frame is U = V Rx(-phi) Ry(-theta) Rz(-psi): a robot whose shoulder
joints rotate about -x, -y, -z (in that nested order) by phi, theta, psi, whose upper arm lies along
its local x, and whose elbow flexes by delta = pi - gamma about the local z (u3) reproduces it.

Wrist twist (eqs. 23-24): the finger->thumb direction o projected on the plane perpendicular to the
forearm b, o' = o - <o, b> b / |b|², and alpha = angle(b_perp, o') signed by <o', b x b_perp>, with
b_perp = u3 (the elbow axis, the twist's zero). Eq. 24 as printed subtracts the b_perp component
instead of the b component; that would make o' perpendicular to b_perp and alpha always ±90°, so we
project out b, as the text ("the projection ... onto the rotation plane of the wrist") says. The
arccos-times-sign of eq. 23 is evaluated as the equivalent, better conditioned atan2.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from lfd_common import as_array, check_real, float_dtype

MARKER_ORDER = ("sternum", "shoulder", "elbow", "wrist", "index_knuckle", "index_tip", "thumb_tip")
"""The order of the 7 markers `retarget` reads (the papers' marker set, Humanoids 2008 §I)."""
_SHOULDER, _ELBOW, _KNUCKLE, _TIP, _THUMB = 1, 2, 4, 5, 6
# Columns v1 (down), v2 (forward), v3 (right) of the robot's fixed shoulder frame, world x right,
# y forward, z up.
DEFAULT_BASE_FRAME = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
"""(3, 3) the robot's fixed shoulder frame {v_i} (Humanoids 2008 Fig. 5): v1 down, v2 forward, v3 right."""


class ArmAngles(NamedTuple):
    """The result of `retarget` (Humanoids 2008 §IV-B): robot joint angles and the points solved for.

    Angles in radians; points in robot scale (metres, relative to the robot's shoulder, world axes).

    Attributes:
        shoulder: (..., T, 3) Cardan angles (phi, theta, psi) (eqs. 16-18).
        elbow: (..., T) flexion delta = pi - gamma (eq. 10).
        wrist: (..., T) twist alpha (eq. 23).
        hand: (..., T, 3) the scaled human hand.
        elbow_point: (..., T, 3) the scaled human elbow.
        robot_elbow: (..., T, 3) the robot's elbow q' = a u1.
        scale: (...,) robot / human arm length.
        singular: (..., T) bool, a frame whose arm plane or wrist twist the markers leave undefined
            (see `solve_arm`); its angles come from the documented fallback, never NaN.
    """

    shoulder: jax.Array
    elbow: jax.Array
    wrist: jax.Array
    hand: jax.Array
    elbow_point: jax.Array
    robot_elbow: jax.Array
    scale: jax.Array
    singular: jax.Array


class ArmSolution(NamedTuple):
    """The result of `solve_arm` (Humanoids 2008 §IV-B, eqs. 10-24).

    Attributes:
        shoulder: (..., 3) Cardan angles (phi, theta, psi).
        elbow: (...,) flexion delta = pi - gamma.
        wrist: (...,) twist alpha.
        robot_elbow: (..., 3) the robot's elbow q' = a u1.
        singular: (...,) bool, a fallback direction was used.
    """

    shoulder: jax.Array
    elbow: jax.Array
    wrist: jax.Array
    robot_elbow: jax.Array
    singular: jax.Array


# Below this fraction of its reference length a vector has no usable direction (float32 rounding
# of a projection leaves ~1e-7 of it, pointing anywhere).
_DEGENERATE = 1e-4


def _dot(a, b):
    return jnp.sum(a * b, axis=-1, keepdims=True)


def _unit_or(v, reference_length, fallback):
    """(unit(v), True) where |v| > _DEGENERATE * reference_length, else (fallback, False); the
    double `where` keeps gradients finite on the fallback side."""
    ok = jnp.linalg.norm(v, axis=-1) > _DEGENERATE * reference_length
    safe = jnp.where(ok[..., None], v, fallback)
    return safe / jnp.linalg.norm(safe, axis=-1, keepdims=True), ok


def _off_axis(v, axis):
    return v - _dot(v, axis) * axis


def solve_arm(q: Float[Array, "*batch 3"], r: Float[Array, "*batch 3"], o: Float[Array, "*batch 3"],
              upper_arm: float, forearm: float, base_frame: Float[ArrayLike, "3 3"] = DEFAULT_BASE_FRAME
              ) -> ArmSolution:
    """Robot arm joint angles for given elbow, hand and thumb direction (Humanoids 2008 §IV-B, eqs. 10-24).

    Pure jnp, no input checks, finite values and gradients everywhere. Singular poses, where the
    markers leave a direction undefined, take a fallback and are flagged in `singular`: the hand at
    the shoulder (w1 of eq. 13 undefined: the base frame's v1, the arm hanging); the elbow on the
    shoulder-hand line, a straight arm (w2 of eq. 15 undefined: the base frame's v2, forward, off
    w1, or v3 where w1 is along v2); o along the forearm (twist of eq. 23 undefined: alpha = 0).

    Args:
        q: (..., 3) the elbow, relative to the shoulder, in robot scale.
        r: (..., 3) the hand, relative to the shoulder, in robot scale.
        o: (..., 3) the finger->thumb direction.
        upper_arm: The robot's a (shoulder-elbow), metres.
        forearm: The robot's b (elbow-grasp point), metres.
        base_frame: (3, 3) columns v1, v2, v3 of the robot's fixed shoulder frame in world
            coordinates.

    Returns:
        `ArmSolution`: shoulder (..., 3), elbow (...,), wrist (...,), robot_elbow (..., 3),
        singular (...,).
    """
    a, b = upper_arm, forearm
    base = jnp.asarray(base_frame, jnp.result_type(q))
    reach = a + b
    r_sq = jnp.sum(r * r, axis=-1)
    r_norm = jnp.where(r_sq > 0, jnp.sqrt(jnp.where(r_sq > 0, r_sq, 1.0)), 0.0)  # |r|, finite gradient at 0
    c = jnp.clip(r_norm, abs(a - b) * (1 + 1e-6) + 1e-9, reach * (1 - 1e-6))
    gamma = jnp.arccos(jnp.clip((a**2 + b**2 - c**2) / (2 * a * b), -1.0, 1.0))  # (10)
    beta = jnp.arccos(jnp.clip((a**2 + c**2 - b**2) / (2 * a * c), -1.0, 1.0))  # (11)
    w1, hand_ok = _unit_or(r, reach, jnp.broadcast_to(base[:, 0], r.shape))  # (13)
    forward, _ = _unit_or(_off_axis(jnp.broadcast_to(base[:, 1], w1.shape), w1), 1.0,
                                   _off_axis(jnp.broadcast_to(base[:, 2], w1.shape), w1))
    w2, plane_ok = _unit_or(_off_axis(q, w1), jnp.linalg.norm(q, axis=-1) + _DEGENERATE * reach, forward)  # (14, 15)
    u1 = jnp.cos(beta)[..., None] * w1 + jnp.sin(beta)[..., None] * w2  # (12)
    # (20, 21): elbow -> hand (c w1 - a u1) off u1 is -c sin(beta) (cos(beta) w2 - sin(beta) w1), so its
    # direction in closed form, well conditioned also when the arm is folded (beta near 180 deg).
    u2 = jnp.sin(beta)[..., None] * w1 - jnp.cos(beta)[..., None] * w2
    u3 = jnp.cross(u1, u2)  # (22)
    U = jnp.stack([u1, u2, u3], axis=-1)  # columns u_i
    R = jnp.swapaxes(U, -1, -2) @ base  # (19)
    phi = jnp.arctan2(R[..., 2, 1], R[..., 2, 2])  # (16)
    theta = -jnp.arcsin(jnp.clip(R[..., 2, 0], -1.0, 1.0))  # (17)
    psi = jnp.arctan2(R[..., 1, 0], R[..., 0, 0])  # (18)
    delta = jnp.pi - gamma
    forearm_dir = jnp.cos(delta)[..., None] * u1 + jnp.sin(delta)[..., None] * u2
    o_proj = _off_axis(o, forearm_dir)  # (24), projecting out the forearm direction
    twist_ok = jnp.linalg.norm(o_proj, axis=-1) > _DEGENERATE * jnp.linalg.norm(o, axis=-1)
    across = jnp.where(twist_ok, _dot(o_proj, jnp.cross(forearm_dir, u3))[..., 0], 0.0)
    along = jnp.where(twist_ok, _dot(o_proj, u3)[..., 0], 1.0)
    alpha = jnp.arctan2(across, along)  # (23)
    singular = ~(hand_ok & plane_ok & twist_ok)
    return ArmSolution(jnp.stack([phi, theta, psi], axis=-1), delta, alpha, a * u1, singular)


@jax.jit
def _retarget(markers, shoulder_ref, upper_arm, forearm, scale, base_frame):
    p = markers[..., _SHOULDER, :]
    q = markers[..., _ELBOW, :]
    r = (markers[..., _KNUCKLE, :] + markers[..., _TIP, :] + markers[..., _THUMB, :]) / 3.0
    o = markers[..., _THUMB, :] - markers[..., _TIP, :]
    human = jnp.median(jnp.linalg.norm(q - p, axis=-1) + jnp.linalg.norm(r - q, axis=-1), axis=-1)
    scale = jnp.where(scale > 0, scale, (upper_arm + forearm) / human)
    shoulder_ref = shoulder_ref[..., None, :]
    origin = jnp.where(jnp.isnan(shoulder_ref), p, shoulder_ref)
    q_s = scale[..., None, None] * (q - origin)
    r_s = scale[..., None, None] * (r - origin)
    arm = solve_arm(q_s, r_s, o, upper_arm, forearm, base_frame)
    return ArmAngles(arm.shoulder, arm.elbow, arm.wrist, r_s, q_s, arm.robot_elbow, scale, arm.singular)


def retarget(markers: Float[ArrayLike, "*batch T 7 3"] | Float[ArrayLike, "*batch T 21"], upper_arm: float = 0.105,
             forearm: float = 0.145, shoulder: Float[ArrayLike, "*batch 3"] | None = None,
             scale: Float[ArrayLike, "*batch"] | None = None,
             base_frame: Float[ArrayLike, "3 3"] = DEFAULT_BASE_FRAME) -> ArmAngles:
    """Map a human arm movement to the joint angles of a HOAP-3-like robot arm (Humanoids 2008 §IV-B).

    The elbow and hand (mean of index knuckle, index tip and thumb tip) are taken relative to the
    shoulder, scaled to the robot's arm length and solved by `solve_arm` (eqs. 10-24).

    Args:
        markers: (..., T, 7, 3) or (..., T, 21) marker positions in `MARKER_ORDER`, metres.
        upper_arm: The robot's a (shoulder-elbow), metres.
        forearm: The robot's b (elbow-grasp point), metres.
        shoulder: The reference shoulder position (3,) or (..., 3) — the papers use the mean
            shoulder position over the training movements (§IV-A); None uses each frame's shoulder
            marker.
        scale: Robot / human arm length (scalar or (...,)); None uses (a + b) / the median over
            frames of the human |shoulder-elbow| + |elbow-hand|.
        base_frame: (3, 3) columns v1, v2, v3 of the robot's fixed shoulder frame in world
            coordinates.

    Returns:
        `ArmAngles`: shoulder (..., T, 3), elbow and wrist (..., T), the points solved for, scale
        (...,) and singular (..., T).

    Raises:
        ValueError: Naming the argument: `markers` of the wrong shape, NaN/inf, or without an arm
            length to scale by (shoulder, elbow and hand coincide: pass `scale`); `upper_arm` /
            `forearm` not > 0; `base_frame` not a rotation matrix; `shoulder` or `scale` malformed.
    """
    markers = as_array(markers, "markers", ndim=range(2, 8))
    if markers.shape[-1] == 3 * len(MARKER_ORDER) and markers.shape[-2:] != (len(MARKER_ORDER), 3):
        markers = markers.reshape(markers.shape[:-1] + (len(MARKER_ORDER), 3))
    if markers.ndim < 3 or markers.shape[-2:] != (len(MARKER_ORDER), 3):
        raise ValueError(f"markers: expected (..., T, {len(MARKER_ORDER)}, 3) or (..., T, "
                         f"{3 * len(MARKER_ORDER)}), got {markers.shape}")
    batch = markers.shape[:-3]
    upper_arm = check_real(upper_arm, "upper_arm", min_value=1e-6)
    forearm = check_real(forearm, "forearm", min_value=1e-6)
    base_frame = as_array(base_frame, "base_frame", shape=(3, 3))
    if not np.allclose(base_frame.T @ base_frame, np.eye(3), atol=1e-6) or np.linalg.det(base_frame) < 0:
        raise ValueError("base_frame: expected a rotation matrix (orthonormal columns, det +1)")
    if shoulder is None:
        shoulder = np.full(batch + (3,), np.nan)
    else:
        shoulder = np.broadcast_to(as_array(shoulder, "shoulder", ndim=range(1, 8)), batch + (3,))
    if scale is None:
        hand = markers[..., [_KNUCKLE, _TIP, _THUMB], :].mean(-2)
        elbow = markers[..., _ELBOW, :]
        length = np.linalg.norm(elbow - markers[..., _SHOULDER, :], axis=-1) + np.linalg.norm(hand - elbow, axis=-1)
        if np.any(np.median(length, axis=-1) < 1e-6):
            raise ValueError("markers: a movement whose shoulder, elbow and hand coincide has no arm length "
                             "to scale by; pass scale=")
        scale = np.zeros(batch)
    else:
        scale = np.broadcast_to(as_array(scale, "scale", ndim=range(0, 7), min_value=1e-9), batch)
    dtype = float_dtype()
    return _retarget(jnp.asarray(markers, dtype), jnp.asarray(shoulder, dtype), upper_arm, forearm,
                     jnp.asarray(scale, dtype), jnp.asarray(base_frame, dtype))

