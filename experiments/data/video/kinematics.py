"""The per-frame kinematics of a recording: a `Script` of primitives -> a `ScenePose` per frame.

One copy of each motion model: the arm's reaching and pointing movements (trunk lean, girdle, elbow
swivel, wrist posture, timing) are `experiments.data.tabletop.simulate_movement`; the held object's
path in an OAC (lift, transport, the action's scanning / tilting, put-down) is
`experiments.data.oac.object_trajectory`, the hand holding it with the grip of
`experiments.data.oac.grips` / `sim.human_grasps`; the elbow of every arm pose not given by a
movement is the table-top model's inverse kinematics from shoulder and wrist (`elbow_centres`).

An OAC = the outward half of a reaching movement to the object, blended over its last 60 % into the
grip's hand pose; the object trajectory (of the script's action, started from where the object stands:
an action's motion applied to another object gives the unseen combinations); the return half of the
same reaching movement, blended out of the grip over its first 60 %. Between primitives the arm rests
(hanging beside the hip) and moves smoothly from one primitive's last pose to the next one's first.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from experiments.data.oac.grips import grip_of
from experiments.data.oac.motion import min_jerk, object_trajectory
from experiments.data.tabletop.movement import elbow_centres, simulate_movement
from experiments.data.video.people import TABLE, Actor, to_tabletop, to_world
from experiments.data.video.settings import ACTIONS, Script, VideoSettings
from sim.hands import GRASP_POSTURES, posture
from sim.hands import NEUTRAL_POSTURE_DEG, clip_posture
from sim.scenes import body_points
from sim.scenes import ScenePose

# index extended, the other fingers curled, the thumb over the middle finger
_POINT_DEG = np.array([0.0, 40.0, 30.0, 20.0, 0.0, 0.0, 5.0, 0.0] + [0.0, 80.0, 95.0, 60.0] * 3)
_ELBOW_OUT = np.array([-1.0, 0.3, -0.6]) / np.linalg.norm([-1.0, 0.3, -0.6])  # holding: right elbow out, back, down
_THUMB_ANGLE = np.deg2rad(40.0)  # the tabletop thumb marker's angle from the hand's radial axis to the palm
_KEYS = ("R", "rs", "re", "rw", "rh", "fing", "obj_pos", "obj_rot", "action", "object")
_ROTATIONS = ("R", "rh", "obj_rot")


class Track(NamedTuple):
    """A recording's kinematics: pose (a `ScenePose` with T frames), action / object (T,) int (-1
    none), light (T,), pickups / putdowns (E,) frames with event_action / event_object (E,), n_empty."""

    pose: ScenePose
    action: np.ndarray
    object: np.ndarray
    light: np.ndarray
    pickups: np.ndarray
    putdowns: np.ndarray
    event_action: np.ndarray
    event_object: np.ndarray
    n_empty: int


def unit(v):
    """v (..., D) scaled to unit length along the last axis (zero vectors stay zero)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _blend(rot, w):
    """The rotation(s) `rot` (..., 3, 3) scaled to the fraction `w` (...,) of their angle."""
    vec = Rotation.from_matrix(np.reshape(rot, (-1, 3, 3))).as_rotvec().reshape(np.shape(rot)[:-2] + (3,))
    vec = vec * np.asarray(w)[..., None]
    return Rotation.from_rotvec(vec.reshape(-1, 3)).as_matrix().reshape(vec.shape[:-1] + (3, 3))


def _between(u0, u):
    """Smallest rotations (T, 3, 3) taking direction u0 (3,) to directions u (T, 3)."""
    u0, u = unit(u0), unit(u)
    axis = np.cross(u0, u)
    angle = np.arctan2(np.linalg.norm(axis, axis=-1), np.sum(u0 * u, -1))
    return Rotation.from_rotvec(unit(axis) * angle[:, None]).as_matrix()


def _ramp(n, start=0.0, width=1.0):
    """Minimum-jerk 0 -> 1 (n,) over the fraction [start, start + width] of n frames."""
    s = np.linspace(0.0, 1.0, n) if n > 1 else np.ones(n)
    return min_jerk((s - start) / width)


def _hand_frame(m: np.ndarray) -> np.ndarray:
    """The right hand's frame (T, 3, 3) (`sim.human_hand`: x to the fingers, y to the thumb, z the back
    of the hand) from table-top markers (T, 7, 3): wrist, knuckle and thumb tip."""
    wrist, knuckle, thumb = m[:, 3], m[:, 4], m[:, 6]
    d = unit(knuckle - wrist)
    t = thumb - wrist
    t = unit(t - np.sum(t * d, -1, keepdims=True) * d)
    # the thumb lies between the radial side and the palm side: turn it back onto the radial side
    side = t * np.cos(_THUMB_ANGLE) + np.cross(d, t) * np.sin(_THUMB_ANGLE)
    d = unit(knuckle - wrist - 0.015 * side)
    side = unit(side - np.sum(side * d, -1, keepdims=True) * d)
    return np.stack([d, side, np.cross(d, side)], axis=-1)


def _hand_frames(m: np.ndarray, progress: np.ndarray) -> np.ndarray:
    """Hand frames (T, 3, 3) of a movement: the rest frame turned towards the goal frame (at the
    farthest point) by `progress` (T,) in [0, 1]. The table-top markers' palm normal is a normalised
    blend of rest and goal normals that can flip within a frame; a rotation blend cannot."""
    rest, goal = _hand_frame(m[[0]])[0], _hand_frame(m[[int(np.argmax(progress))]])[0]
    return _blend(goal @ rest.T, progress) @ rest


def arm(actor: Actor, shoulder, wrist, reference):
    """Shoulder (the girdle protracts up to 6 cm towards a far wrist), elbow and the reachable wrist."""
    a, b = actor.look.upper_arm_m, actor.look.forearm_m
    d = wrist - shoulder
    extra = np.clip(np.linalg.norm(d, axis=-1, keepdims=True) - 0.985 * (a + b), 0.0, 0.06)
    shoulder = shoulder + extra * unit(d)
    elbow, reach = elbow_centres(shoulder, wrist, a, b, reference)
    return shoulder, elbow, reach


def _movement(actor: Actor, rng, target, kind: str, fps: float) -> np.ndarray:
    """A table-top movement (T, 7, 3) in the world to `target` (3,) on the table, without marker noise."""
    m = simulate_movement(rng, actor.subject, to_tabletop(target), kind, frame_rate=fps, marker_noise_m=0.0,
                          drop_rate=0.0)
    return to_world(m)


def _rest(rest, n: int) -> dict:
    """n frames of objects standing at `rest` (pos (K, 3), rot (K, 3, 3)); nothing held."""
    return {"obj_pos": np.repeat(rest[0][None], n, 0), "obj_rot": np.repeat(rest[1][None], n, 0),
            "action": np.full(n, -1), "object": np.full(n, -1)}


def _gesture(actor: Actor, rng, kind: str, target_xy, rest, fps: float) -> dict:
    """A pointing or reaching movement to a table position, all from the table-top model."""
    m = _movement(actor, rng, np.array([target_xy[0], target_xy[1], TABLE.top_z]), kind, fps)
    n = len(m)
    wrist = m[:, 3]
    p = np.linalg.norm(wrist - wrist[0], axis=-1)
    p = p / max(p.max(), 1e-9)
    goal = _POINT_DEG if kind == "pointing" else posture(4, 0.7)
    seg = _rest(rest, n)
    seg.update(R=_between(m[0, 0] - actor.hip, m[:, 0] - actor.hip), rs=m[:, 1], re=m[:, 2], rw=wrist,
               rh=_hand_frames(m, p), fing=NEUTRAL_POSTURE_DEG + p[:, None] * (goal - NEUTRAL_POSTURE_DEG))
    seg["action"] = np.where(p > 0.02, ACTIONS.index(kind), -1)
    return seg


def _oac(actor: Actor, rng, action: int, obj: int, rest, settings: VideoSettings) -> tuple[dict, dict]:
    """Reach to the object, its OAC trajectory, return. Returns (frames, {"pickup", "putdown"} offsets)."""
    person, fps = actor.person, settings.fps
    hand_pos, hand_rot = actor.grips[obj]
    duration = settings.oac_duration_s / person.speed * (1.0 + 0.08 * rng.standard_normal())
    n = max(int(round(duration * fps)), 8)
    pos, rots = object_trajectory(action, person, rng, n)
    away = np.linalg.norm(pos - pos[0], axis=-1)
    stay = 1.0 - away / max(away.max(), 1e-9)  # 1 on the table, 0 at the action's target
    pos = pos + stay[:, None] * (rest[0][obj] - pos[0])
    rots = _blend(rest[1][obj] @ rots[0].T, stay) @ rots
    grasp = grip_of(obj, person).grasp
    held = clip_posture(np.asarray(GRASP_POSTURES[grasp].joints_deg) + 4.0 * rng.standard_normal(20))
    wrist_h, hand_h = pos + rots @ hand_pos, rots @ hand_rot
    centre = wrist_h[0] + hand_h[0] @ np.array([0.5 * actor.look.hand.palm_length, 0.0, -0.015])
    m = _movement(actor, rng, centre - np.array([0.0, 0.0, 0.05]), "reaching", fps)
    w = m[:, 3]
    far = np.linalg.norm(w - w[np.argmax(np.linalg.norm(w - w[0], axis=-1))], axis=-1) < 0.01
    h0, h1 = int(np.argmax(far)), len(far) - 1 - int(np.argmax(far[::-1]))
    home = actor.face + body_points(actor.look)["r_shoulder"]
    trunk = _between(m[0, 0] - actor.hip, m[:, 0] - actor.hip)
    out = np.linalg.norm(w - w[0], axis=-1)
    hands = _hand_frames(m, out / max(out.max(), 1e-9))

    def blended(idx, k, b, wrist_goal, hand_goal):
        # the movement's frames idx, pulled (weight b) onto the grip's pose at movement frame k
        shoulder = m[idx, 1] + b[:, None] * (home - m[k, 1])
        wrist = w[idx] + b[:, None] * (wrist_goal - w[k])
        seg = {"R": _blend(trunk[k].T, b) @ trunk[idx], "rh": _blend(hand_goal @ hands[k].T, b) @ hands[idx]}
        reference = (1 - b[:, None]) * unit(m[idx, 2] - m[idx, 1]) + b[:, None] * _ELBOW_OUT
        seg["rs"], seg["re"], seg["rw"] = arm(actor, shoulder, wrist, reference)
        return seg

    b_in = _ramp(h0 + 1, 0.4, 0.6)[:-1]
    approach = blended(np.arange(h0), h0, b_in, wrist_h[0], hand_h[0])
    approach["fing"] = NEUTRAL_POSTURE_DEG + _ramp(h0 + 1)[:-1, None] * (held - NEUTRAL_POSTURE_DEG)
    back = np.arange(h1 + 1, len(m))
    b_out = 1.0 - _ramp(len(back) + 1, 0.0, 0.6)[1:]
    withdraw = blended(back, h1, b_out, wrist_h[-1], hand_h[-1])
    withdraw["fing"] = held + _ramp(len(back) + 1)[1:, None] * (NEUTRAL_POSTURE_DEG - held)
    shoulder, elbow, _ = arm(actor, np.repeat(home[None], n, 0), wrist_h, np.repeat(_ELBOW_OUT[None], n, 0))
    transport = {"R": np.repeat(np.eye(3)[None], n, 0), "rs": shoulder, "re": elbow, "rw": wrist_h, "rh": hand_h,
                 "fing": np.repeat(held[None], n, 0)}
    segs = []
    for seg, length in ((approach, h0), (transport, n), (withdraw, len(back))):
        seg.update(_rest(rest, length))
        segs.append(seg)
    transport["obj_pos"][:, obj], transport["obj_rot"][:, obj] = pos, rots
    transport["action"][:], transport["object"][:] = action, obj
    withdraw["obj_pos"][:, obj], withdraw["obj_rot"][:, obj] = pos[-1], rots[-1]
    rest[0][obj], rest[1][obj] = pos[-1], rots[-1]
    return _concat(segs), {"pickup": h0, "putdown": h0 + n - 1}


def _concat(segs: list[dict]) -> dict:
    return {k: np.concatenate([s[k] for s in segs]) for k in _KEYS}


def _frame(seg: dict, i: int, n: int) -> dict:
    """Frame i of a segment repeated n times."""
    return {k: np.repeat(seg[k][[i]], n, 0) for k in _KEYS}


def _idle(before: dict, after: dict, n: int) -> dict:
    """n frames resting: the arm holds `before`'s last pose, then moves to `after`'s first."""
    a, b = _frame(before, -1, n), _frame(after, 0, n)
    w = _ramp(n, 0.4, 0.6) if n > 1 else np.zeros(n)
    out = dict(a)
    for k in ("rs", "re", "rw", "fing"):
        out[k] = a[k] + w.reshape((n,) + (1,) * (a[k].ndim - 1)) * (b[k] - a[k])
    for k in ("R", "rh"):
        out[k] = _blend(b[k] @ np.swapaxes(a[k], -1, -2), w) @ a[k]
    return out


def _left_arm(actor: Actor, trunk_rot, offset, settle0: int, settle1: int):
    """Left shoulder, elbow, wrist (T, 3) and hand frame (T, 3, 3): hanging until frame settle0, moving
    onto the table (vertical first) until settle1, then resting there; the shoulder follows the trunk."""
    t_total = len(trunk_rot)
    look = actor.look
    home = actor.face + body_points(look)["l_shoulder"]
    shoulder = actor.hip + (home - actor.hip) @ np.swapaxes(trunk_rot, -1, -2) + offset
    hang = shoulder + np.array([0.05, 0.0, -0.95 * (look.upper_arm_m + look.forearm_m)])
    s = np.clip((np.arange(t_total) - settle0) / max(settle1 - settle0, 1), 0.0, 1.0)[:, None]
    up, out = 1.0 - (1.0 - s) ** 3, s ** 3
    delta = actor.left_wrist - hang
    wrist = hang + np.concatenate([out * delta[:, :2], up * delta[:, 2:]], axis=1)
    reference = (1 - s) * np.array([0.3, 0.3, -1.0]) + s * np.array([1.0, 0.2, -0.3])
    shoulder, elbow, wrist = arm(actor, shoulder, wrist, reference)
    along = elbow - wrist
    flat = unit(np.concatenate([-along[:, :2], np.zeros((t_total, 1))], axis=1))
    on_table = np.stack([flat, np.cross(np.array([0.0, 0.0, 1.0]), flat), np.broadcast_to([0.0, 0.0, 1.0], flat.shape)], -1)
    hanging = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # fingers down, palm to the thigh
    hand = _blend(on_table @ hanging.T, s[:, 0]) @ hanging
    return shoulder, elbow, wrist, hand


def script_track(actor: Actor, script: Script, settings: VideoSettings) -> Track:
    """The kinematics of `script` performed by `actor` (see the module docstring)."""
    rng = np.random.default_rng([settings.seed, 11, script.person, script.seed])
    fps = settings.fps
    rest = (actor.rest_pos.copy(), actor.rest_rot.copy())
    prims = []
    for p in script.primitives:
        if p.kind == "oac":
            seg, ev = _oac(actor, rng, p.action, p.object, rest, settings)
            ev = (ev, p.action, p.object)
        else:
            seg, ev = _gesture(actor, rng, p.kind, p.target, rest, fps), None
        prims.append((seg, ev))
    n_entry, n_settle = int(round(settings.entry_s * fps)), int(round(settings.settle_s * fps))
    first = prims[0][0]
    start = _frame(first, 0, settings.n_empty + n_entry + n_settle)
    start.update(_rest((actor.rest_pos, actor.rest_rot), len(start["action"])))
    segs, pickups, putdowns, ev_act, ev_obj = [start], [], [], [], []
    t = len(start["action"])
    prev = start
    for seg, ev in prims:
        n_idle = max(1, int(round(settings.idle_s * fps * rng.uniform(0.5, 1.5))))
        segs.append(_idle(prev, seg, n_idle))
        t += n_idle
        if ev is not None:
            pickups.append(t + ev[0]["pickup"])
            putdowns.append(t + ev[0]["putdown"])
            ev_act.append(ev[1])
            ev_obj.append(ev[2])
        segs.append(seg)
        t += len(seg["action"])
        prev = seg
    segs.append(_idle(prev, prev, max(1, int(round(settings.idle_s * fps)))))
    track = _concat(segs)
    n = len(track["action"])
    # entering from one side, out of view during the empty frames
    side = 1.0 if rng.uniform() < 0.5 else -1.0
    x0 = side * (1.3 + 0.8 * (actor.face[1] - actor.rig.centre[1]) + abs(actor.rig.centre[0]))
    go = np.ones(n)
    go[:settings.n_empty] = 0.0
    go[settings.n_empty:settings.n_empty + n_entry] = _ramp(n_entry + 2)[1:-1] if n_entry else []
    offset = np.zeros((n, 3))
    offset[:, 0] = x0 * (1.0 - go)
    offset[:, 2] = 0.015 * np.abs(np.sin(np.pi * 3.0 * go)) * (go < 1)
    trunk_rot = track["R"]
    face = actor.hip + (actor.face - actor.hip) @ np.swapaxes(trunk_rot, -1, -2) + offset
    settle0 = settings.n_empty + n_entry
    left = _left_arm(actor, trunk_rot, offset, settle0, settle0 + n_settle)
    pose = ScenePose(trunk_pos=face, trunk_rot=trunk_rot, r_shoulder=track["rs"] + offset,
                     r_elbow=track["re"] + offset, r_wrist=track["rw"] + offset, r_hand_rot=track["rh"],
                     fingers=np.radians(clip_posture(track["fing"])), l_shoulder=left[0], l_elbow=left[1],
                     l_wrist=left[2], l_hand_rot=left[3], object_pos=track["obj_pos"], object_rot=track["obj_rot"])
    secs = np.arange(n) / fps
    phase = rng.uniform(0, 2 * np.pi, 2)
    light = 1.0 + settings.light_drift * (0.7 * np.sin(2 * np.pi * secs / settings.light_period_s + phase[0])
                                          + 0.3 * np.sin(2 * np.pi * secs / (0.37 * settings.light_period_s) + phase[1]))
    as_int = lambda v: np.asarray(v, np.int32)  # noqa: E731
    return Track(pose=pose, action=track["action"].astype(np.int8), object=track["object"].astype(np.int8),
                 light=light.astype(np.float32), pickups=as_int(pickups), putdowns=as_int(putdowns),
                 event_action=as_int(ev_act), event_object=as_int(ev_obj), n_empty=settings.n_empty)
