"""Kinematics of one simulated movement: trunk, arm, hand, the reaching and pointing profiles."""
from __future__ import annotations


import numpy as np

from lfd_common import check_choice
from experiments.data.tabletop.subjects import ACTIONS, FRAME_RATE_HZ, Subject, TABLE_EDGE_Y, TABLE_HEIGHT_M, HIP


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _trunk_rotation(pitch, yaw):
    """Rotation matrices (..., 3, 3): forward lean `pitch` about x, then turn `yaw` about z (rad)."""
    cp, sp, cy, sy = np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    zero, one = np.zeros_like(pitch), np.ones_like(pitch)
    lean = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, cp, sp], -1),
                     np.stack([zero, -sp, cp], -1)], -2)  # z axis tilts towards +y
    turn = np.stack([np.stack([cy, sy, zero], -1), np.stack([-sy, cy, zero], -1),
                     np.stack([zero, zero, one], -1)], -2)  # positive yaw turns +y towards -x (left)
    return turn @ lean


def _body_point(rotation, point):
    """Where a trunk-fixed point (3,) (given with the trunk upright) is under rotation(s) (..., 3, 3)."""
    return HIP + rotation @ (point - HIP)


def _min_jerk(s):
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def elbow_centres(shoulder, wrist, a, b, reference):
    """Elbow joint centres (T, 3) for shoulder and wrist (T, 3), upper arm a, forearm b, the elbow on
    the side of `reference` (T, 3) off the shoulder-wrist line. Wrists out of reach are pulled onto
    the sphere of full extension. Returns (elbow, wrist)."""
    d = wrist - shoulder
    c = np.linalg.norm(d, axis=-1, keepdims=True)
    c_ok = np.clip(c, abs(a - b) + 1e-3, (a + b) * (1.0 - 1e-4))
    w1 = d / c
    wrist = shoulder + w1 * c_ok
    cos_beta = (a**2 + c_ok**2 - b**2) / (2.0 * a * c_ok)
    w2 = _unit(reference - np.sum(reference * w1, -1, keepdims=True) * w1)
    elbow = shoulder + a * (cos_beta * w1 + np.sqrt(1.0 - cos_beta**2) * w2)
    return elbow, wrist


def _rotate_about(v, axis, angle):
    """Rodrigues rotation of vectors v (..., 3) about unit axes (..., 3) by angle (...,)."""
    angle = np.asarray(angle)[..., None]
    return (v * np.cos(angle) + np.cross(axis, v) * np.sin(angle)
            + axis * np.sum(axis * v, -1, keepdims=True) * (1.0 - np.cos(angle)))


def _elbow_lift(shoulder, wrist, subject: Subject, reference, axis, clearance: float = 0.03):
    """Extra swivel (T,) that keeps the elbow `clearance` above the table top once it is over the
    table (people lift the elbow when they reach across a table): per frame the smallest of 0-90 deg
    (in the direction that raises the elbow) that clears, then spread and smoothed in time."""
    angles = np.deg2rad(np.arange(0.0, 91.0, 5.0))
    up = elbow_centres(shoulder, wrist, subject.upper_arm, subject.forearm,
                _rotate_about(reference, axis, np.full(len(axis), 0.3)))[0][:, 2]
    down = elbow_centres(shoulder, wrist, subject.upper_arm, subject.forearm,
                  _rotate_about(reference, axis, np.full(len(axis), -0.3)))[0][:, 2]
    sign = 1.0 if np.sum(up - down) > 0 else -1.0
    clear = np.stack([
        elbow_centres(shoulder, wrist, subject.upper_arm, subject.forearm,
               _rotate_about(reference, axis, np.full(len(axis), sign * a)))[0] for a in angles])  # (A, T, 3)
    ok = (clear[..., 1] < TABLE_EDGE_Y - 0.03) | (clear[..., 2] > TABLE_HEIGHT_M + clearance)
    need = angles[np.argmax(np.vstack([ok, np.ones((1, ok.shape[1]), bool)]), axis=0).clip(max=len(angles) - 1)]
    width = 15
    padded = np.pad(need, width, mode="edge")
    spread = np.max(np.lib.stride_tricks.sliding_window_view(padded, 2 * width + 1), axis=1)
    kernel = np.hanning(2 * width + 3)[1:-1]
    smooth = np.convolve(np.pad(spread, width, mode="edge"), kernel / kernel.sum(), mode="valid")
    return sign * smooth


def _hand_markers(wrist, d, n, weight, shape, subject: Subject):
    """Knuckle, index tip and thumb tip (T, 3) from the wrist (T, 3), the hand direction d (wrist to
    knuckle) and palm normal n (T, 3), blending by `weight` (T,) in [0, 1] between the relaxed hand
    (0) and the action's hand `shape` (1) = (index flexion (rad), thumb offsets to the thumb side and
    to the palm side (m))."""
    flex_goal, thumb_l_goal, thumb_n_goal = shape
    side = np.cross(d, n)  # thumb side of a right hand
    knuckle = wrist + subject.hand * d + 0.015 * side
    flex = (1 - weight) * np.deg2rad(35.0) + weight * flex_goal
    tip = knuckle + subject.finger * (np.cos(flex)[:, None] * d + np.sin(flex)[:, None] * n)
    thumb_l = (1 - weight) * 0.03 + weight * thumb_l_goal
    thumb_n = (1 - weight) * 0.025 + weight * thumb_n_goal
    thumb = wrist + 0.6 * subject.hand * d + thumb_l[:, None] * side + thumb_n[:, None] * n
    return knuckle, tip, thumb


def _phase_profile(n_frames_parts, asymmetry):
    """Out-and-back phase (T,) in [0, 1]: rest, minimum-jerk out (with asymmetry exponent), hold,
    minimum-jerk back, rest."""
    rest0, out, hold, back, rest1 = n_frames_parts
    tau_out = np.linspace(0.0, 1.0, out, endpoint=False)
    tau_back = np.linspace(0.0, 1.0, back, endpoint=False)
    return np.concatenate([np.zeros(rest0), _min_jerk(tau_out ** asymmetry[0]), np.ones(hold),
                           1.0 - _min_jerk(tau_back ** asymmetry[1]), np.zeros(rest1)])


def _lean_for_reach(subject: Subject, goal_wrist, yaw, reach):
    """Smallest forward lean (rad, up to 40 deg) that brings the shoulder within `reach` of the goal."""
    pitches = np.linspace(0.0, np.deg2rad(40.0), 81)
    shoulders = _body_point(_trunk_rotation(pitches, np.full_like(pitches, yaw)), subject.shoulder)
    shoulders = shoulders + np.array([0.0, 0.03, 0.015])  # full girdle protraction and elevation
    ok = np.linalg.norm(goal_wrist - shoulders, axis=-1) <= reach
    return pitches[np.argmax(ok)] if ok.any() else pitches[-1]


def simulate_movement(rng: np.random.Generator, subject: Subject, target, action: str,
                      frame_rate: float = FRAME_RATE_HZ, endpoint_sd_m: float = 0.012,
                      marker_noise_m: float = 0.002, drop_rate: float = 0.3) -> np.ndarray:
    """One movement (T, 7, 3) in metres towards `target` (3,) on the table; action "reaching" or
    "pointing". T varies with the sampled timing (about 2-4 s)."""
    action = check_choice(action, "action", ACTIONS)
    target = np.asarray(target, float)
    pointing = action == "pointing"
    reach = subject.upper_arm + subject.forearm

    # Timing: per-repetition durations around the subject's speed, overall +-20 %. Grasping ends in
    # a longer, precise deceleration (Fitts), pointing is quicker; the out and back profiles get
    # random asymmetry exponents (peak velocity earlier or later).
    overall = subject.speed * rng.uniform(0.8, 1.2)
    out = rng.uniform(0.65, 0.9) if pointing else rng.uniform(0.8, 1.05)
    seconds = np.array([rng.uniform(0.1, 0.3), out, rng.uniform(0.25, 0.7),
                        rng.uniform(0.8, 1.1), rng.uniform(0.1, 0.3)]) * overall
    parts = np.maximum(2, np.round(seconds * frame_rate).astype(int))
    asymmetry = np.array([rng.uniform(0.85, 1.2) if pointing else rng.uniform(0.7, 1.0), rng.uniform(0.8, 1.25)])
    phase = _phase_profile(parts, asymmetry)
    n = phase.size
    # The hand hangs below the table top at rest: it rises first and moves out over the table edge
    # later (and comes back before it drops): vertical progress 1 - (1 - phase)^k, horizontal phase^k.
    k = rng.uniform(3.0, 4.0)
    phase_v, phase_h = 1.0 - (1.0 - phase) ** k, phase**k

    # Goal: trunk posture, wrist position and hand orientation at the end of the outward movement.
    aim = target + endpoint_sd_m * rng.standard_normal(3)
    yaw_full = np.arctan2(-(aim[0] - subject.shoulder[0]), aim[1] - subject.shoulder[1])
    yaw = rng.uniform(0.2, 0.4) * yaw_full
    if pointing:
        rotation = _trunk_rotation(np.deg2rad(rng.uniform(0.0, 6.0)), yaw)
        shoulder_goal = _body_point(rotation, subject.shoulder) + np.array([0.0, 0.02, 0.015])
        # The knuckle lies on the line from the target to a sighting point between the shoulder
        # (a low, arm-line point) and the eye (a raised, eye-line point): the subject's habit, varied
        # per repetition.
        sight = np.clip(subject.pointing_sight + 0.15 * rng.standard_normal(), 0.0, 1.0)
        eye = sight * _body_point(rotation, subject.eye) + (1.0 - sight) * shoulder_goal
        back = _unit(eye - aim)
        radius = (subject.pointing_extension + 0.04 * rng.standard_normal()) * (reach + subject.hand)
        d0 = aim - shoulder_goal
        proj = back @ d0
        s = -proj - np.sqrt(max(proj**2 - d0 @ d0 + radius**2, 0.0))
        knuckle_goal = aim + max(s, subject.pointing_standoff + 0.03 * rng.standard_normal()) * back
        d_goal = _unit(aim - knuckle_goal)
        wrist_dev = np.deg2rad(8.0) * rng.standard_normal(2)
        n_goal = _unit(np.cross(d_goal, np.array([0.0, 0.0, 1.0])) * np.sin(np.deg2rad(10.0))
                       + np.array([0.0, 0.0, -1.0]))  # palm down, slightly turned in
        n_goal = _unit(n_goal - (n_goal @ d_goal) * d_goal)
        d_hand = _unit(_rotate_about(d_goal, n_goal, wrist_dev[0]) + wrist_dev[1] * n_goal)
        wrist_goal = knuckle_goal - subject.hand * d_hand - 0.015 * np.cross(d_hand, n_goal)
        shape = (rng.uniform(-0.05, 0.1), rng.uniform(0.015, 0.03), rng.uniform(0.025, 0.04))  # index extended
        pitch = np.deg2rad(rng.uniform(0.0, 6.0))
    else:
        obj_height = rng.uniform(0.03, 0.07)  # hand centre above the table at the grasp
        centre = aim + np.array([0.0, 0.0, obj_height])
        horizontal = _unit(np.array([centre[0] - subject.shoulder[0], centre[1] - subject.shoulder[1], 0.0]))
        tilt = np.deg2rad(rng.uniform(25.0, 50.0))
        d_hand = np.cos(tilt) * horizontal + np.array([0.0, 0.0, -np.sin(tilt)])
        n_down = _unit(np.array([0.0, 0.0, -1.0]) - (-np.sin(tilt)) * d_hand)
        n_goal = _rotate_about(n_down, d_hand, -np.deg2rad(rng.uniform(20.0, 70.0)))  # pronation
        flex = np.deg2rad(rng.uniform(40.0, 70.0))
        shape = (flex, rng.uniform(0.04, 0.055), rng.uniform(0.03, 0.045))  # grasp
        # Hand centre (mean of knuckle, tip, thumb) relative to the wrist in the goal hand frame.
        side = np.cross(d_hand, n_goal)
        knuckle_rel = subject.hand * d_hand + 0.015 * side
        tip_rel = knuckle_rel + subject.finger * (np.cos(flex) * d_hand + np.sin(flex) * n_goal)
        thumb_rel = 0.6 * subject.hand * d_hand + shape[1] * side + shape[2] * n_goal
        wrist_goal = centre - (knuckle_rel + tip_rel + thumb_rel) / 3.0
        # Fingers wrap the object but stay 1 cm above the table top: lift the hand if needed.
        lowest = min(knuckle_rel[2], tip_rel[2], thumb_rel[2]) + wrist_goal[2]
        wrist_goal[2] += max(0.0, TABLE_HEIGHT_M + 0.01 - lowest)
        pitch = _lean_for_reach(subject, wrist_goal, yaw, 0.97 * reach) + np.deg2rad(rng.uniform(0.0, 4.0))

    # Trunk and girdle over time.
    rotations = _trunk_rotation(phase_h * pitch, phase * yaw)  # (T, 3, 3): lean as the hand goes out
    girdle = phase[:, None] * np.array([0.0, 0.03, 0.015]) * (1.0 if not pointing else 0.7)
    shoulder = _body_point(rotations, subject.shoulder) + girdle
    sternum = _body_point(rotations, subject.sternum)

    # Wrist path: from the rest pose (in the trunk frame) to the goal (world), vertical first.
    wrist_rest = _body_point(rotations, subject.shoulder + np.array([0.05, 0.0, -0.95 * reach]))
    wrist_rest_w = wrist_rest[0]
    delta = wrist_goal - wrist_rest_w
    wrist = wrist_rest + np.stack([phase_h * delta[0], phase_h * delta[1], phase_v * delta[2]], -1)
    wrist = wrist + (wrist_rest_w - wrist_rest) * phase[:, None]  # the goal is world-fixed
    if not pointing:  # the hand arcs over the table (over other objects) on its way out and back
        wrist[:, 2] += rng.uniform(0.0, 0.15) * np.sin(np.pi * phase_h) ** 2
    hold = (phase >= 1.0)[:, None]
    wrist = wrist + hold * 0.002 * np.cumsum(rng.standard_normal((n, 3)), 0) / np.sqrt(max(parts[2], 1))

    # Hand orientation: relaxed (fingers down, palm to the thigh) to the goal frame.
    d_rest = _unit(np.array([0.0, 0.05, -1.0]))
    n_rest = np.array([-1.0, 0.0, 0.0])
    turn = phase_v  # the fingers turn forward as the hand rises, and back as it drops
    d = _unit((1 - turn)[:, None] * d_rest + turn[:, None] * d_hand)
    n_mix = (1 - turn)[:, None] * n_rest + turn[:, None] * n_goal
    n_vec = _unit(n_mix - np.sum(n_mix * d, -1, keepdims=True) * d)

    # Elbow: swivel reference (down and out, behind the arm at rest) turned by the subject's and the
    # repetition's swivel.
    swivel = subject.swivel + np.deg2rad(6.0) * rng.standard_normal() + phase * np.deg2rad(15.0) * rng.standard_normal()
    reference = rotations @ _unit(np.array([0.4, -0.2, -1.0]))
    axis = _unit(wrist - shoulder)
    swivel = swivel + _elbow_lift(shoulder, wrist, subject, _rotate_about(reference, axis, swivel), axis)
    reference = _rotate_about(reference, axis, swivel)
    elbow, wrist = elbow_centres(shoulder, wrist, subject.upper_arm, subject.forearm, reference)
    knuckle, tip, thumb = _hand_markers(wrist, d, n_vec, phase, shape, subject)

    markers = np.stack([sternum, shoulder, elbow, wrist, knuckle, tip, thumb], axis=1)
    markers = markers + marker_noise_m * rng.standard_normal(markers.shape)
    return fill_gaps(_drop_frames(rng, markers, drop_rate))


def _drop_frames(rng, markers, drop_rate):
    """Occlusions: with probability `drop_rate` per marker, a gap of 1-6 frames becomes NaN."""
    markers = markers.copy()
    n = markers.shape[0]
    for m in np.flatnonzero(rng.random(markers.shape[1]) < drop_rate):
        width = rng.integers(1, 7)
        start = rng.integers(1, max(2, n - width - 1))
        markers[start:start + width, m] = np.nan
    return markers


def fill_gaps(markers) -> np.ndarray:
    """Fill NaN frames (occlusions) of markers (T, M, 3) by linear interpolation in time per marker
    (constant beyond the first/last seen frame). A marker never seen raises ValueError."""
    markers = np.array(markers, dtype=float)
    t = np.arange(markers.shape[0])
    seen = np.all(np.isfinite(markers), axis=-1)  # (T, M)
    for m in range(markers.shape[1]):
        if not seen[:, m].any():
            raise ValueError(f"markers: marker {m} has no valid frame")
        if not seen[:, m].all():
            for k in range(3):
                markers[:, m, k] = np.interp(t, t[seen[:, m]], markers[seen[:, m], m, k])
    return markers
