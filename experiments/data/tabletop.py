"""Simulated motion capture of table-top reaching and pointing (PHMM papers, Humanoids 2008 §V, BMVC §5).

A seated person's kinematic upper body: a trunk that leans and turns about the hip (so that far targets
can be reached, with the sternum and shoulder moving), a shoulder girdle that protracts and elevates
with the arm, a 3-DoF shoulder and 1-DoF elbow solved from the wrist path with a random elbow swivel,
a wrist whose posture varies, and a hand with index finger and thumb. Seven markers, in the papers'
order (`MARKERS`): sternum, shoulder, elbow, wrist, index knuckle, index tip, thumb tip; 60 Hz; metres.

Frame: x to the subject's right, y forward (away from the body), z up; origin on the floor below the
middle of the hips. The 80 x 30 cm target raster lies on the table in front of the subject.

Actions (both start and end with the arm hanging beside the hip):
* reaching: the hand centre goes to the object on the table (grasp posture: fingers flexed around it,
  forearm pronated by a random amount), holds (grasp), withdraws;
* pointing: the arm extends and the index finger points at the target along the eye-finger line,
  from a distance that depends on the person's habitual arm extension; holds, withdraws.
The hand rises before it moves out over the table edge (and goes back before it drops), along a
minimum-jerk profile with random duration, peak-velocity asymmetry and hold time.

Variability: per-subject anthropometry (stature 1.55-1.95 m, segment proportions +-3 %) and style
(pointing extension, elbow swivel, speed); per repetition: timing (+-20 % overall), asymmetry, hold,
end-point scatter (`endpoint_sd_m`), wrist posture, swivel, object height; marker noise
(`marker_noise_m`); occasionally dropped marker frames, filled by linear interpolation (`fill_gaps`,
which the loader of real recordings uses too).

In-memory format (`Recordings`, also produced by `load_recording` from `.npz` / `.csv` files):
markers (B, T, M, 3) padded by repeating the last frame, lengths (B,), action (B,) index into
`ACTIONS`, target (B, 3), frame_rate (Hz), marker_names (M,).
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import NamedTuple

import numpy as np

from lfd_common import as_array, cache_dir, check_choice, check_int, check_real, write_npz

MARKERS = ("sternum", "shoulder", "elbow", "wrist", "index_knuckle", "index_tip", "thumb_tip")
ACTIONS = ("reaching", "pointing")
FRAME_RATE_HZ = 60.0
TABLE_HEIGHT_M = 0.73
RASTER_ORIGIN = np.array([-0.30, 0.25, TABLE_HEIGHT_M])  # near-left corner of the raster (x, y, z)
RASTER_SIZE_M = np.array([0.80, 0.30])  # width (x) x depth (y)
TABLE_EDGE_Y = 0.20  # the table's near edge (the chest surface is at about y = 0.12)
_HIP = np.array([0.0, -0.05, 0.55])  # trunk pivot (between the hip joints, seated)
_SEAT_HEIGHT = 0.45


class Recordings(NamedTuple):
    """A batch of marker recordings. markers (B, T, M, 3) in metres, padded with the last frame;
    lengths (B,) frames; action (B,) index into ACTIONS; target (B, 3) metres; frame_rate in Hz;
    marker_names (M,)."""

    markers: np.ndarray
    lengths: np.ndarray
    action: np.ndarray
    target: np.ndarray
    frame_rate: float
    marker_names: tuple


class Subject(NamedTuple):
    """Anthropometry (metres) and movement style of one simulated person."""

    shoulder: np.ndarray  # (3,) shoulder joint centre, trunk upright
    sternum: np.ndarray  # (3,) sternum marker, trunk upright
    eye: np.ndarray  # (3,) cyclopean eye, trunk upright
    upper_arm: float
    forearm: float
    hand: float  # wrist to index knuckle
    finger: float  # index knuckle to tip
    pointing_extension: float  # habitual shoulder-knuckle distance when pointing, fraction of full reach
    pointing_standoff: float  # least knuckle-target distance when pointing (m)
    pointing_sight: float  # habitual sighting point, 0 = along the arm (shoulder), 1 = eye line
    swivel: float  # habitual elbow swivel (rad)
    speed: float  # duration factor (1 = average)


def raster_targets(rows: int, cols: int) -> np.ndarray:
    """Target points (rows, cols, 3) of a regular raster over the 80 x 30 cm table area; rows run in
    depth (y, away from the body), columns in width (x, left to right)."""
    rows = check_int(rows, "rows", min_value=1)
    cols = check_int(cols, "cols", min_value=1)
    v = np.linspace(0.0, 1.0, rows) if rows > 1 else np.zeros(1)
    u = np.linspace(0.0, 1.0, cols) if cols > 1 else np.zeros(1)
    vv, uu = np.meshgrid(v, u, indexing="ij")
    x = RASTER_ORIGIN[0] + uu * RASTER_SIZE_M[0]
    y = RASTER_ORIGIN[1] + vv * RASTER_SIZE_M[1]
    return np.stack([x, y, np.full_like(x, RASTER_ORIGIN[2])], axis=-1)


def sample_subject(rng: np.random.Generator) -> Subject:
    """A person drawn from realistic adult ranges (stature 1.55-1.95 m; segment lengths as fractions
    of stature, after Drillis & Contini, each scaled by its own +-3 % factor)."""
    stature = rng.uniform(1.55, 1.95)
    f = 1.0 + 0.03 * rng.standard_normal(6)
    shoulder_height = _SEAT_HEIGHT + 0.34 * stature * f[0]  # seated acromion height
    shoulder = np.array([0.098 * stature * f[1], 0.0, shoulder_height - 0.04])
    return Subject(
        shoulder=shoulder,
        sternum=np.array([0.0, 0.09, shoulder_height - 0.07]),
        eye=np.array([0.0, 0.07, shoulder_height + 0.19 * stature / 1.75]),
        upper_arm=0.172 * stature * f[2],
        forearm=0.157 * stature * f[3],
        hand=0.054 * stature * f[4],
        finger=0.05 * stature * f[5],
        pointing_extension=rng.uniform(0.72, 0.9),
        pointing_standoff=rng.uniform(0.15, 0.3),
        pointing_sight=rng.uniform(0.2, 0.8),
        swivel=np.deg2rad(10.0) * rng.standard_normal(),
        speed=rng.uniform(0.85, 1.15),
    )


# --------------------------------------------------------------------------------------------------
# Kinematics (vectorised over frames)

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
    return _HIP + rotation @ (point - _HIP)


def _min_jerk(s):
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def _elbow(shoulder, wrist, a, b, reference):
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
    up = _elbow(shoulder, wrist, subject.upper_arm, subject.forearm,
                _rotate_about(reference, axis, np.full(len(axis), 0.3)))[0][:, 2]
    down = _elbow(shoulder, wrist, subject.upper_arm, subject.forearm,
                  _rotate_about(reference, axis, np.full(len(axis), -0.3)))[0][:, 2]
    sign = 1.0 if np.sum(up - down) > 0 else -1.0
    clear = np.stack([
        _elbow(shoulder, wrist, subject.upper_arm, subject.forearm,
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
    elbow, wrist = _elbow(shoulder, wrist, subject.upper_arm, subject.forearm, reference)
    knuckle, tip, thumb = _hand_markers(wrist, d, n_vec, phase, shape, subject)

    markers = np.stack([sternum, shoulder, elbow, wrist, knuckle, tip, thumb], axis=1)
    markers = markers + marker_noise_m * rng.standard_normal(markers.shape)
    return fill_gaps(_drop_frames(rng, markers, drop_rate))


def table_penetration(recordings: Recordings) -> np.ndarray:
    """Deepest point (B,) in metres of any arm or hand marker (elbow to thumb) inside the table
    (beyond its near edge, below its top); 0 when the movement stays clear."""
    arm = recordings.markers[:, :, 2:]
    valid = (np.arange(arm.shape[1]) < recordings.lengths[:, None])[:, :, None]
    depth = np.where(valid & (arm[..., 1] > TABLE_EDGE_Y), TABLE_HEIGHT_M - arm[..., 2], 0.0)
    return np.maximum(depth.reshape(len(depth), -1).max(1), 0.0)


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


def stack_recordings(movements, action, target, frame_rate=FRAME_RATE_HZ, marker_names=MARKERS) -> Recordings:
    """A `Recordings` batch from a list of (T_b, M, 3) movements, action indices (B,), targets (B, 3)."""
    if len(movements) == 0:
        raise ValueError("movements: need at least one movement")
    lengths = np.array([len(m) for m in movements])
    padded = np.stack([np.concatenate([m, np.repeat(m[-1:], lengths.max() - len(m), 0)]) for m in movements])
    return Recordings(padded, lengths, np.asarray(action, int), np.asarray(target, float).reshape(-1, 3),
                      float(frame_rate), tuple(marker_names))


def simulate(rng: np.random.Generator, subjects, targets, repetitions: int, action: str,
             **settings) -> Recordings:
    """`repetitions` movements to every target (K, 3) by each of the subjects, in order target-major:
    index = (k * repetitions + r); repetition r is by subject r % len(subjects). `settings` go to
    `simulate_movement`."""
    targets = as_array(targets, "targets").reshape(-1, 3)
    repetitions = check_int(repetitions, "repetitions", min_value=1)
    moves = [simulate_movement(rng, subjects[r % len(subjects)], t, action, **settings)
             for t in targets for r in range(repetitions)]
    return stack_recordings(moves, np.full(len(moves), ACTIONS.index(action)),
                            np.repeat(targets, repetitions, axis=0))


def concatenate(recordings) -> Recordings:
    """One `Recordings` from several (same frame rate and markers)."""
    recordings = list(recordings)
    moves = [r.markers[b, :r.lengths[b]] for r in recordings for b in range(len(r.lengths))]
    return stack_recordings(moves, np.concatenate([r.action for r in recordings]),
                            np.concatenate([r.target for r in recordings]), recordings[0].frame_rate,
                            recordings[0].marker_names)


def resample(recordings: Recordings, n_samples: int = 100) -> np.ndarray:
    """Every movement linearly resampled in time to `n_samples` frames: (B, n_samples, 3 M) features
    (the markers stacked, PHMM papers: "sequences normalised to 100 samples")."""
    n_samples = check_int(n_samples, "n_samples", min_value=2)
    markers, lengths = recordings.markers, recordings.lengths
    pos = np.linspace(0.0, 1.0, n_samples)[None, :] * (lengths[:, None] - 1)  # (B, S)
    lo = np.floor(pos).astype(int)
    hi = np.minimum(lo + 1, lengths[:, None] - 1)
    frac = (pos - lo)[..., None, None]
    rows = np.arange(len(lengths))[:, None]
    out = (1 - frac) * markers[rows, lo] + frac * markers[rows, hi]
    return out.reshape(len(lengths), n_samples, -1)


# --------------------------------------------------------------------------------------------------
# Data sets for the protocol, cached

def protocol_data(seed: int, train_raster=(3, 3), train_repetitions: int = 10, test_raster=(5, 7),
                  test_repetitions: int = 4, n_subjects: int = 1, endpoint_sd_m: float = 0.012,
                  marker_noise_m: float = 0.002, drop_rate: float = 0.3, use_cache: bool = True):
    """Training and test recordings of both actions (train, test), each a `Recordings` with the
    actions concatenated (reaching first), target-major within an action. Cached under
    `cache_dir("phmm_tabletop")` keyed by every argument and the simulator's source."""
    settings = dict(seed=seed, train_raster=list(train_raster), train_repetitions=train_repetitions,
                    test_raster=list(test_raster), test_repetitions=test_repetitions, n_subjects=n_subjects,
                    endpoint_sd_m=endpoint_sd_m, marker_noise_m=marker_noise_m, drop_rate=drop_rate,
                    code=hashlib.sha256(Path(__file__).read_bytes()).hexdigest())  # a simulator change invalidates
    key = hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]
    path = cache_dir("phmm_tabletop") / f"data_{key}.npz"
    if use_cache and path.exists():
        with np.load(path) as f:
            return tuple(Recordings(f[f"{s}_markers"], f[f"{s}_lengths"], f[f"{s}_action"], f[f"{s}_target"],
                                    FRAME_RATE_HZ, MARKERS) for s in ("train", "test"))
    rng = np.random.default_rng(seed)
    subjects = [sample_subject(rng) for _ in range(check_int(n_subjects, "n_subjects", min_value=1))]
    kw = dict(endpoint_sd_m=endpoint_sd_m, marker_noise_m=marker_noise_m, drop_rate=drop_rate)
    out = []
    for raster, reps in ((train_raster, train_repetitions), (test_raster, test_repetitions)):
        targets = raster_targets(*raster)
        out.append(concatenate([simulate(rng, subjects, targets, reps, a, **kw) for a in ACTIONS]))
    if use_cache:
        write_npz(path, **{f"{s}_{k}": getattr(r, k) for s, r in zip(("train", "test"), out)
                          for k in ("markers", "lengths", "action", "target")})
    return tuple(out)


# --------------------------------------------------------------------------------------------------
# Real recordings

def load_recording(path) -> Recordings:
    """Read one recorded movement into a `Recordings` of batch 1 (markers reordered to `MARKERS`).

    `.npz`: arrays `markers` (T, M, 3) in metres, `marker_names` (M,), `frame_rate` (Hz), `action`
    ("reaching" | "pointing"), `target` (3,). `.csv`: header lines `# frame_rate: 60`,
    `# action: pointing`, `# target: x, y, z`, then a column header `sternum_x, sternum_y, ...` and one
    row per frame. Missing (NaN or empty) samples are occlusions and are filled by `fill_gaps`.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(path)
    if path.suffix == ".npz":
        with np.load(path, allow_pickle=False) as f:
            missing = {"markers", "marker_names", "frame_rate", "action", "target"} - set(f.files)
            if missing:
                raise ValueError(f"path: {path} lacks the array(s) {sorted(missing)}")
            markers = as_array(f["markers"], "markers", ndim=3, finite=False)
            names = [str(s) for s in f["marker_names"]]
            frame_rate, action, target = float(f["frame_rate"]), str(f["action"]), f["target"]
    elif path.suffix == ".csv":
        meta, header, rows = {}, None, []
        for line in path.read_text().splitlines():
            if line.startswith("#"):
                key, _, value = line[1:].partition(":")
                meta[key.strip()] = value.strip()
            elif line.strip() and header is None:
                header = [h.strip() for h in line.split(",")]
            elif line.strip():
                rows.append([float(v) if v.strip() else np.nan for v in line.split(",")])
        for key in ("frame_rate", "action", "target"):
            if key not in meta:
                raise ValueError(f"path: {path} lacks the header line '# {key}: ...'")
        if header is None or not rows or any(len(r) != len(header) for r in rows):
            raise ValueError(f"path: {path} needs a column header and rows of {len(header or [])} values")
        if len(header) % 3 or any(not h.endswith(("_x", "_y", "_z")) for h in header):
            raise ValueError(f"path: {path} columns must be <marker>_x, <marker>_y, <marker>_z")
        names = [h[:-2] for h in header[::3]]
        markers = np.asarray(rows).reshape(len(rows), len(names), 3)
        frame_rate, action = float(meta["frame_rate"]), meta["action"]
        target = [float(v) for v in meta["target"].split(",")]
    else:
        raise ValueError(f"path: expected a .npz or .csv file, got {path.name}")
    check_real(frame_rate, "frame_rate", min_value=1e-6)
    action = check_choice(action, "action", ACTIONS)
    target = as_array(target, "target", shape=(3,))
    if markers.shape[1:] != (len(names), 3):
        raise ValueError(f"markers: expected shape (T, {len(names)}, 3), got {markers.shape}")
    missing = [m for m in MARKERS if m not in names]
    if missing:
        raise ValueError(f"marker_names: missing {missing} (need {list(MARKERS)})")
    markers = fill_gaps(markers[:, [names.index(m) for m in MARKERS]])
    return stack_recordings([markers], [ACTIONS.index(action)], target[None], frame_rate)


def save_recording(path, markers, action: str, target, frame_rate: float = FRAME_RATE_HZ) -> Path:
    """Write one movement (T, 7, 3) in `MARKERS` order as `.npz` or `.csv` (the loader's formats)."""
    path = Path(path)
    markers = as_array(markers, "markers", shape=(None, len(MARKERS), 3), finite=False)
    action = check_choice(action, "action", ACTIONS)
    target = as_array(target, "target", shape=(3,))
    if path.suffix == ".npz":
        np.savez(path, markers=markers, marker_names=np.array(MARKERS), frame_rate=frame_rate,
                 action=action, target=target)
    elif path.suffix == ".csv":
        header = ",".join(f"{m}_{k}" for m in MARKERS for k in "xyz")
        lines = [f"# frame_rate: {frame_rate}", f"# action: {action}", f"# target: {', '.join(map(str, target))}",
                 header] + [",".join("" if np.isnan(v) else repr(float(v)) for v in row)
                            for row in markers.reshape(len(markers), -1)]
        path.write_text("\n".join(lines) + "\n")
    else:
        raise ValueError(f"path: expected a .npz or .csv file, got {path.name}")
    return path
