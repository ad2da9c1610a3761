"""Rendering recordings (both views, RGB and labels, per-frame ground truth), caching, the data sets."""
from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from lfd_common import Cache
from experiments.config import progress as _progress_bar
from experiments.data.oac.settings import N_CLASSES, OBJECTS
from experiments.data.video.kinematics import Track, script_track
from experiments.data.video.people import Actor, actor
from experiments.data.video.settings import (SOURCE_PACKAGES, TRACKED, UNSEEN, VERSION, Primitive, Recording,
                                             Script, VideoSet, VideoSettings, check_script)
from sim.scenes import PART_LABELS, PART_NAMES, PersonScene, ScenePose

_TRACKED_PARTS = np.array([PART_NAMES.index("hand"), PART_NAMES.index("face")]
                          + [PART_NAMES.index(f"object{k}") for k in range(len(OBJECTS))])
_STANDING = np.where(np.arange(len(PART_LABELS)) >= PART_NAMES.index("object0"), 0, PART_LABELS).astype(np.uint8)
RENDERS = Cache("video", packages=SOURCE_PACKAGES, version=VERSION, compress=True)  # noise-free images compress well


def ellipses(parts: np.ndarray, ids: np.ndarray = _TRACKED_PARTS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mask moments of each part id in `ids` (J,) in integer part maps (..., H, W): centroid (..., J, 2)
    (x, y) px (pixel centres at integers), second central moments (..., J, 2, 2) px^2, area (..., J)
    pixels; centroid and moments are 0 where a part has no pixel."""
    parts = np.asarray(parts)
    if parts.ndim < 2 or not np.issubdtype(parts.dtype, np.integer) or parts.size == 0:
        raise ValueError(f"parts: expected a non-empty integer array (..., H, W), got {parts.dtype} {parts.shape}")
    ids = np.asarray(ids, int)
    lead, (h, w), j = parts.shape[:-2], parts.shape[-2:], len(ids)
    flat = parts.reshape(-1, h * w)
    lookup = np.full(max(int(flat.max()), int(ids.max())) + 1, -1)
    lookup[ids] = np.arange(j)
    slot = lookup[np.maximum(flat, 0)]
    image, pixel = np.nonzero(slot >= 0)
    key = image * j + slot[image, pixel]
    y, x = np.divmod(pixel.astype(np.float64), w)

    def moment(weights=None):
        return np.bincount(key, weights=weights, minlength=len(flat) * j).reshape(len(flat), j)

    area = moment()
    safe = np.maximum(area, 1.0)
    mx, my = moment(x) / safe, moment(y) / safe
    cxx, cyy, cxy = moment(x * x) / safe - mx**2, moment(y * y) / safe - my**2, moment(x * y) / safe - mx * my
    found = area > 0
    centre = np.where(found[..., None], np.stack([mx, my], -1), 0.0)
    cov = np.where(found[..., None, None], np.stack([np.stack([cxx, cxy], -1), np.stack([cxy, cyy], -1)], -2), 0.0)
    return (centre.reshape(lead + (j, 2)), cov.reshape(lead + (j, 2, 2)), area.reshape(lead + (j,)).astype(np.int32))


def _frame(pose: ScenePose, t: int) -> ScenePose:
    return ScenePose(*(f[t] for f in pose))


def camera_noise(rec: Recording, settings: VideoSettings, script: Script) -> Recording:
    """The recording with the camera noise of `settings.pixel_noise` (deterministic from the seeds;
    added after the cache, which keeps the noise-free images: they compress several times better)."""
    if settings.pixel_noise == 0:
        return rec
    rng = np.random.default_rng([settings.seed, 13, script.person, script.seed])
    views = []
    for images in (rec.left, rec.right):
        out = np.empty_like(images)
        for t in range(len(images)):  # frame by frame: a float copy of the whole video would be large
            noisy = images[t] + settings.pixel_noise * rng.standard_normal(images.shape[1:], dtype=np.float32)
            out[t] = np.clip(np.rint(noisy), 0, 255)
        views.append(out)
    return rec._replace(left=views[0], right=views[1])


def render_track(scene: PersonScene, who: Actor, track: Track, settings: VideoSettings, script: Script,
                 progress=None) -> Recording:
    """Render every frame of `track` in `scene` (its renderers reused across frames), noise-free."""
    n, h, w, k = len(track.action), settings.height, settings.width, len(OBJECTS)
    rgb = np.empty((n, 2, h, w, 3), np.uint8)
    labels = np.empty((n, 2, h, w), np.uint8)
    hand, objects = np.empty((n, 3)), np.empty((n, k, 3))
    centre, cov = np.empty((n, 2, len(TRACKED), 2)), np.empty((n, 2, len(TRACKED), 2, 2))
    area = np.empty((n, 2, len(TRACKED)), np.int32)
    frames = range(n) if progress is None else progress(range(n), desc=f"rendering person {script.person}")
    for t in frames:
        scene.set_lighting(float(track.light[t]))
        scene.set_pose(_frame(track.pose, t))
        image, parts = scene.render()
        hand[t], objects[t] = scene.centres()
        lut = _STANDING.copy()  # objects are labelled only while held (they move); standing, background
        if track.object[t] >= 0:
            lut[_TRACKED_PARTS[2 + track.object[t]]] = PART_LABELS[_TRACKED_PARTS[2 + track.object[t]]]
        labels[t] = lut[parts]
        centre[t], cov[t], area[t] = ellipses(parts)
        rgb[t] = image
    rig = who.rig
    face = track.pose.trunk_pos
    p = rig.projection_matrices()
    f32 = np.float32
    return Recording(
        left=rgb[:, 0], right=rgb[:, 1], left_labels=labels[:, 0], right_labels=labels[:, 1],
        hand_xyz=hand.astype(f32), face_xyz=face.astype(f32), object_xyz=objects.astype(f32),
        hand_cam=rig.to_camera(hand).astype(f32), face_cam=rig.to_camera(face).astype(f32),
        object_cam=rig.to_camera(objects).astype(f32), ellipse_centre=centre.astype(f32), ellipse_cov=cov.astype(f32),
        ellipse_area=area, ellipse_found=area > 0, pickup_frames=track.pickups, putdown_frames=track.putdowns,
        event_action=track.event_action, event_object=track.event_object, action=track.action, object=track.object,
        light=track.light, P_left=p[0], P_right=p[1], n_empty=track.n_empty, person=script.person, fps=settings.fps)


class Scenes:
    """One compiled scene (and its renderers) per person, made when first needed."""

    def __init__(self, settings: VideoSettings):
        self.settings, self.actors, self.scenes = settings, {}, {}

    def actor(self, person: int) -> Actor:
        if person not in self.actors:
            self.actors[person] = actor(self.settings, person)
        return self.actors[person]

    def scene(self, person: int) -> PersonScene:
        if person not in self.scenes:
            for old in self.scenes.values():  # one person at a time holds GL contexts
                old.close()
            self.scenes = {person: PersonScene(self.actor(person).xml, self.actor(person).rig)}
        return self.scenes[person]

    def close(self):
        for scene in self.scenes.values():
            scene.close()
        self.scenes = {}


def _recording(scenes: Scenes, script: Script, cache: bool, progress) -> Recording:
    settings = scenes.settings
    script = check_script(script, settings)

    def render() -> Recording:
        who = scenes.actor(script.person)
        return render_track(scenes.scene(script.person), who, script_track(who, script, settings), settings, script,
                            progress)

    return camera_noise(RENDERS.get(render, enabled=cache, settings=settings, script=script), settings, script)


def _check_settings(settings) -> None:
    if not isinstance(settings, VideoSettings):
        raise ValueError(f"settings: expected a VideoSettings, got {type(settings).__name__}")


def render_recording(settings: VideoSettings, script: Script, cache: bool = True,
                     progress=_progress_bar) -> Recording:
    """Render `script` (deterministic from the settings' and the script's seeds); cached under
    `cache_dir("video")` keyed by every setting, the script and the generator's source.
    `progress`: a wrapper of an iterable for a progress bar over the frames (tqdm by default, silent when
    `LFD_NO_PROGRESS` is set; None for none)."""
    _check_settings(settings)
    scenes = Scenes(settings)
    try:
        return _recording(scenes, script, cache, progress)
    finally:
        scenes.close()


def clip_scripts(settings: VideoSettings) -> list[tuple[int, int, int, Script]]:
    """(person, OAC class, repetition, script) of every pre-segmented clip: one OAC each."""
    return [(p, c, r, Script(person=p, primitives=(Primitive("oac", c, c),), seed=1000 * c + r))
            for p in range(settings.n_persons) for c in range(N_CLASSES) for r in range(settings.n_repetitions)]


def _free_spot(rng: np.random.Generator, who: Actor) -> tuple[float, float]:
    """A table position away from the objects and the left hand, in the right hand's half."""
    taken = np.vstack([who.rest_pos[:, :2], who.left_wrist[None, :2], [[0.5, -0.4]]])
    for _ in range(100):
        xy = np.array([rng.uniform(-0.5, 0.2), rng.uniform(-0.55, -0.22)])
        if np.min(np.linalg.norm(taken - xy, axis=1)) > 0.14:
            break
    return float(xy[0]), float(xy[1])


def long_scripts(settings: VideoSettings) -> list[Script]:
    """The long unsegmented recordings: `script_oacs` OACs (every class once, the unseen combinations
    `UNSEEN`, then random classes), pointing and reaching movements, in a random order; script i is by
    person i mod n_persons."""
    out = []
    for i in range(settings.n_scripts):
        rng = np.random.default_rng([settings.seed, 17, i])
        person = i % settings.n_persons
        who = actor(settings, person)
        oacs = [(c, c) for c in range(N_CLASSES)][: settings.script_oacs - len(UNSEEN)] + list(UNSEEN)
        oacs += [(c, c) for c in rng.integers(N_CLASSES, size=settings.script_oacs - len(oacs))]
        steps = [Primitive("oac", int(a), int(o)) for a, o in oacs]
        steps += [Primitive(kind, target=_free_spot(rng, who)) for kind, count in
                  (("pointing", settings.script_pointing), ("reaching", settings.script_reaching)) for _ in range(count)]
        order = rng.permutation(len(steps))
        out.append(Script(person=person, primitives=tuple(steps[j] for j in order), seed=100_000 + i))
    return out


def _video_set(settings: VideoSettings, items, cache: bool, progress) -> VideoSet:
    scenes = Scenes(settings)
    try:
        recs = [_recording(scenes, s, cache, progress) for *_, s in items]
    finally:
        scenes.close()
    meta = np.array([m for *m, _ in items], int).reshape(len(items), 4)
    return VideoSet(recordings=tuple(recs), person=meta[:, 0], action=meta[:, 1], object=meta[:, 2],
                    repetition=meta[:, 3])


def clips(settings: VideoSettings = VideoSettings(), cache: bool = True, progress=_progress_bar) -> VideoSet:
    """persons x 3 OACs x repetitions pre-segmented clips (each: empty frames, the entry, one OAC)."""
    _check_settings(settings)
    items = [(p, c, c, r, s) for p, c, r, s in clip_scripts(settings)]
    return _video_set(settings, items, cache, progress)


def scripts(settings: VideoSettings = VideoSettings(), cache: bool = True, progress=_progress_bar) -> VideoSet:
    """The long unsegmented recordings of `long_scripts(settings)` (action, object -1; repetition: the
    script's index)."""
    _check_settings(settings)
    items = [(s.person, -1, -1, i, s) for i, s in enumerate(long_scripts(settings))]
    return _video_set(settings, items, cache, progress)


def iter_clips(settings: VideoSettings = VideoSettings(), cache: bool = True,
               progress=_progress_bar) -> Iterator[tuple[int, int, int, Recording]]:
    """(person, class, repetition, Recording) of every clip, one at a time (the full set at 320 x 240
    does not fit in memory)."""
    _check_settings(settings)

    def generate():
        scenes = Scenes(settings)
        try:
            for p, c, r, s in clip_scripts(settings):
                yield p, c, r, _recording(scenes, s, cache, progress)
        finally:
            scenes.close()

    return generate()
