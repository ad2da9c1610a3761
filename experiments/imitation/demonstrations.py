"""Demonstrations for the imitation loop (LfD 2009 §III-A, §V): a person at the
table with the three OAC objects at random places either points at one of them (the robot must fetch
it) or picks one up with one of the six grasps (`sim.human_grasps`, GRASP §II) and puts it down at a
new place (the robot must repeat the transfer).

Rendered by the video generator of `experiments.data.video` without changing it: a pointing
demonstration is its "pointing" primitive to the object with the actor's objects moved to the drawn
places; a transfer is its "reaching" primitive to the object, spliced at the hand's farthest point with
a carrying phase (the object rides with the hand, lifted on a minimum-jerk arc, to the new place), and
the way back shifted to start from there. Deterministic from the seeds; cached under
`cache_dir("imitation_video")` keyed by the settings, the demonstration and the generators' source.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from experiments.data import video
from experiments.data.oac.motion import min_jerk
from experiments.data.video import kinematics as kin
from experiments.data.video import render as vrender
from experiments.data.video.people import TABLE
from experiments.data.video.settings import SOURCE_PACKAGES
from lfd_common import Cache, check_int, check_real
from lfd_jax.imitation import KINDS
from sim.grasping import GRASP_CLASSES
from sim.hands import GRASP_POSTURES
from sim.hands import NEUTRAL_POSTURE_DEG, clip_posture

N_OBJECTS = len(video.OBJECTS)
# where objects may stand (world x, y of the grasped part): inside the table-top study's raster, in the
# right hand's half, clear of the left forearm
AREA_X, AREA_Y = (-0.45, 0.12), (-0.50, -0.24)
MIN_GAP_M = 0.17
_REACHING = video.ACTIONS.index("reaching")


class Demo(NamedTuple):
    """One demonstration: kind ("point" / "transfer"), person, seed, objects_xy (K, 2) where each object
    stands (world m), target (the object pointed at or moved), grasp (a `GRASP_CLASSES` class of the
    transfer; -1 for pointing), place_xy (2,) (where the transfer puts it; the hand-over spot for pointing)."""

    kind: str
    person: int
    seed: int
    objects_xy: np.ndarray
    target: int
    grasp: int
    place_xy: np.ndarray


def free(rng, taken: np.ndarray, gap: float) -> np.ndarray:
    """A random spot of the objects' area at least `gap` from every taken one (the gap shrinks by 10 %
    every 100 tries where the area is crowded)."""
    for i in range(1000):
        xy = np.array([rng.uniform(*AREA_X), rng.uniform(*AREA_Y)])
        if len(taken) == 0 or np.min(np.linalg.norm(taken - xy, axis=1)) > gap * 0.9 ** (i // 100):
            return xy
    return xy


def draw_demos(n: int, seed: int, n_persons: int, handover_xy=(-0.1, -0.30), kinds=KINDS) -> list[Demo]:
    """n random demonstrations (kinds alternate in a random order; persons, objects' places, target,
    grasp and new place random; objects and places clear of the hand-over spot), deterministic from
    `seed`."""
    check_int(n, "n", min_value=1)
    check_int(n_persons, "n_persons", min_value=1)
    rng = np.random.default_rng([seed, 21, 5])
    kind_of = rng.permutation(np.arange(n) % len(kinds))
    out = []
    for i in range(n):
        handover = np.asarray(handover_xy, float)[None]
        places = np.zeros((0, 2))
        for _ in range(N_OBJECTS):
            places = np.vstack([places, free(rng, np.vstack([handover, places]), MIN_GAP_M)])
        target = int(rng.integers(N_OBJECTS))
        kind = kinds[kind_of[i]]
        if kind == "transfer":
            grasp, place = int(rng.choice(GRASP_CLASSES)), free(rng, np.vstack([handover, places]), MIN_GAP_M)
        else:
            grasp, place = -1, np.asarray(handover_xy, float)
        out.append(Demo(kind, int(rng.integers(n_persons)), int(rng.integers(1 << 30)), places, target, grasp, place))
    return out


def check_demo(demo: Demo, settings: video.VideoSettings) -> Demo:
    """`demo` with its fields checked (ValueError naming the field)."""
    if not isinstance(demo, Demo):
        raise ValueError(f"demo: expected a Demo, got {type(demo).__name__}")
    if demo.kind not in KINDS:
        raise ValueError(f"demo.kind: expected one of {KINDS}, got {demo.kind!r}")
    check_int(demo.person, "demo.person", min_value=0, max_value=settings.n_persons - 1)
    check_int(demo.seed, "demo.seed")
    xy = np.asarray(demo.objects_xy, float)
    if xy.shape != (N_OBJECTS, 2) or not np.isfinite(xy).all():
        raise ValueError(f"demo.objects_xy: expected finite ({N_OBJECTS}, 2), got {xy.shape}")
    check_int(demo.target, "demo.target", min_value=0, max_value=N_OBJECTS - 1)
    if demo.kind == "transfer" and demo.grasp not in GRASP_CLASSES:
        raise ValueError(f"demo.grasp: expected one of {GRASP_CLASSES}, got {demo.grasp!r}")
    place = np.asarray(demo.place_xy, float)
    if place.shape != (2,) or not np.isfinite(place).all():
        raise ValueError(f"demo.place_xy: expected 2 finite values, got {place!r}")
    for v, name in ((xy[:, 0], "demo.objects_xy"), (place[:1], "demo.place_xy")):
        check_real(float(np.min(v)), name, min_value=-0.6)
        check_real(float(np.max(v)), name, max_value=0.6)
    return demo


def _demo_actor(scenes, demo: Demo):
    """The person with the objects standing at the demonstration's places (their heights and rotations
    as the actor has them)."""
    who = scenes.actor(demo.person)
    rest = who.rest_pos.copy()
    rest[:, :2] = np.asarray(demo.objects_xy, float)
    return who._replace(rest_pos=rest)


def _gesture_script(demo: Demo) -> video.Script:
    kind = "pointing" if demo.kind == "point" else "reaching"
    xy = tuple(float(v) for v in np.asarray(demo.objects_xy)[demo.target])
    return video.Script(person=demo.person, primitives=(video.Primitive(kind, target=xy),), seed=demo.seed)


def _take(pose, idx):
    return type(pose)(*(f[idx] for f in pose))


def _transfer(who, track: kin.Track, demo: Demo, settings: video.VideoSettings) -> kin.Track:
    """The reaching track spliced into a pick-carry-place (module docstring)."""
    pose, k = track.pose, demo.target
    moving = np.flatnonzero(track.action == _REACHING)
    a, b = int(moving[0]), int(moving[-1])
    wrist = pose.r_wrist
    dist = np.linalg.norm(wrist[a:b + 1] - wrist[a], axis=-1)
    p = np.zeros(len(wrist))
    p[a:b + 1] = dist / max(dist.max(), 1e-9)  # 0 at rest, 1 at the farthest point
    g = a + int(np.argmax(p[a:b + 1] >= 0.98))  # the grasp moment
    rng = np.random.default_rng([settings.seed, 21, demo.seed])
    n_carry = max(6, int(round(rng.uniform(1.3, 1.8) * settings.fps / who.person.speed)))
    start = pose.object_pos[g, k]
    goal = np.array([*np.asarray(demo.place_xy, float), start[2]])
    s = min_jerk(np.arange(1, n_carry + 1) / n_carry)
    shift = s[:, None] * (goal - start) + (0.10 * np.sin(np.pi * s))[:, None] * np.array([0.0, 0.0, 1.0])
    carry = _take(pose, np.full(n_carry, g))
    ref = np.repeat(kin.unit(pose.r_elbow[g] - pose.r_shoulder[g])[None], n_carry, 0)
    sh, el, wr = kin.arm(who, carry.r_shoulder, wrist[g] + shift, ref)
    obj = carry.object_pos.copy()
    obj[:, k] = start + (wr - wrist[g])
    carry = carry._replace(r_shoulder=sh, r_elbow=el, r_wrist=wr, object_pos=obj)
    after = _take(pose, np.arange(g + 1, len(wrist)))
    moved = obj[-1, k] - start
    w = p[g + 1:, None]
    sh, el, wr = kin.arm(who, after.r_shoulder, after.r_wrist + w * moved,
                          kin.unit(after.r_elbow - after.r_shoulder))
    obj_after = after.object_pos.copy()
    obj_after[:, k] = obj[-1, k]
    after = after._replace(r_shoulder=sh, r_elbow=el, r_wrist=wr, object_pos=obj_after)
    new = type(pose)(*(np.concatenate(parts) for parts in zip(_take(pose, np.arange(g + 1)), carry, after)))
    held = np.asarray(GRASP_POSTURES[demo.grasp].joints_deg)
    closing = np.concatenate([p[:g + 1], np.ones(n_carry), p[g + 1:]])
    fingers = np.radians(clip_posture(NEUTRAL_POSTURE_DEG + closing[:, None] * (held - NEUTRAL_POSTURE_DEG)))
    insert = lambda v, fill: np.concatenate([v[:g + 1], np.full(n_carry, fill, v.dtype), v[g + 1:]])  # noqa: E731
    obj_label = insert(np.full(len(wrist), -1, track.object.dtype), k)
    return kin.Track(pose=new._replace(fingers=fingers), action=insert(track.action, _REACHING), object=obj_label,
                     light=insert(track.light, track.light[g]), pickups=np.array([g + 1], np.int32),
                     putdowns=np.array([g + n_carry], np.int32), event_action=np.array([-1], np.int32),
                     event_object=np.array([k], np.int32), n_empty=track.n_empty)


def demo_track(who, demo: Demo, settings: video.VideoSettings) -> kin.Track:
    """The kinematics of `demo` performed by `who` (an actor with the objects at the demo's places)."""
    track = kin.script_track(who, _gesture_script(demo), settings)
    return _transfer(who, track, demo, settings) if demo.kind == "transfer" else track


# `experiments.plotting` comes in with the video package's `outputs`.
DEMO_PACKAGES: tuple[str, ...] = SOURCE_PACKAGES + ("experiments.imitation.demonstrations", "experiments.plotting")
_DEMOS = Cache("imitation_video", packages=DEMO_PACKAGES, compress=True)  # noise-free images compress well


def render_demo(settings: video.VideoSettings, demo: Demo, cache: bool = True, progress=None) -> video.Recording:
    """The demonstration rendered as a `experiments.data.video.Recording` (both views, labels, ground
    truth; a transfer's pick-up / put-down in `pickup_frames` / `putdown_frames`), camera noise added."""
    if not isinstance(settings, video.VideoSettings):
        raise ValueError(f"settings: expected a VideoSettings, got {type(settings).__name__}")
    demo = check_demo(demo, settings)
    script = _gesture_script(demo)

    def render() -> video.Recording:
        scenes = vrender.Scenes(settings)
        try:
            who = _demo_actor(scenes, demo)
            return vrender.render_track(scenes.scene(demo.person), who, demo_track(who, demo, settings), settings,
                                        script, progress)
        finally:
            scenes.close()

    rec = _DEMOS.get(render, enabled=cache, settings=settings, demo=demo)
    return vrender.camera_noise(rec, settings, script)


def table_z() -> float:
    """The table top's height (world m)."""
    return float(TABLE.top_z)


def table_xy() -> tuple[tuple[float, float], tuple[float, float]]:
    """The table top's extent ((x low, x high), (y low, y high)), world m."""
    return (-TABLE.half_width, TABLE.half_width), (TABLE.far_y, TABLE.near_y)
