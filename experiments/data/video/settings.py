"""Settings, labels, scripts and the in-memory format of the demonstration videos."""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from lfd_common import check_int, check_real
from experiments.data.oac.settings import ACTIONS as OAC_ACTIONS, OBJECTS

VERSION = "video-v1"
# The packages whose code renders a recording (the import closure of `render`), the key of its cache.
SOURCE_PACKAGES: tuple[str, ...] = ("experiments.data.video", "experiments.data.oac", "experiments.data.tabletop",
                                    "experiments.config", "sim", "hog_jax.video", "lfd_common")
ACTIONS: tuple[str, ...] = OAC_ACTIONS + ("pointing", "reaching")   # per-frame action codes; -1 none
LABELS: tuple[str, ...] = ("background", "person", "hand skin", "face skin") + OBJECTS  # label map values
TRACKED: tuple[str, ...] = ("hand", "face") + OBJECTS                # the J parts with ground-truth ellipses
PRIMITIVES: tuple[str, ...] = ("oac", "pointing", "reaching")
UNSEEN: tuple[tuple[int, int], ...] = ((1, 2), (2, 0))  # (action, object): drink from pitcher, pour from binoculars


@dataclasses.dataclass(frozen=True)
class VideoSettings:
    """Every setting of the video generator (all of them key the cache)."""

    seed: int = 0
    n_persons: int = 10              # 7 men and 3 women for 10 (the last 30 % are women)
    n_repetitions: int = 5           # clips per person and OAC
    width: int = 320                 # image size (4:3); focal length 525 px at 640 x 480, scaled
    height: int = 240
    fps: float = 25.0
    n_empty: int = 30                # empty-scene frames at the start (background training)
    entry_s: float = 1.5             # the person comes in from the side
    settle_s: float = 0.8            # then puts the left forearm on the table
    idle_s: float = 0.6              # mean rest between primitives
    oac_duration_s: float = 4.0      # mean pick-up to put-down at speed 1 (as the OAC generator)
    n_scripts: int = 2               # long unsegmented recordings
    script_oacs: int = 5             # OACs per script, the two unseen combinations among them
    script_pointing: int = 1         # pointing movements per script
    script_reaching: int = 1         # reaching movements per script
    n_distractors: int = 2           # static objects on the table (background)
    light_drift: float = 0.12        # relative amplitude of the slow change of the lights
    light_period_s: float = 20.0     # its main period
    pixel_noise: float = 2.0         # std of the camera noise, grey levels (0-255)
    shadows: bool = False            # the key light casts shadows (3-4x slower to render)

    def __post_init__(self):
        for name, low, high in _INT_RANGES:
            check_int(getattr(self, name), name, min_value=low, max_value=high)
        for name, low, high in _REAL_RANGES:
            check_real(getattr(self, name), name, min_value=low, max_value=high)
        if self.width % 4 or self.height * 4 != self.width * 3:
            raise ValueError(f"height: the image must be 4:3 with the width a multiple of 4, got "
                             f"{self.width} x {self.height}")
        if not isinstance(self.shadows, bool):
            raise ValueError(f"shadows: expected a bool, got {self.shadows!r}")


_INT_RANGES = (("seed", None, None), ("n_persons", 1, 100), ("n_repetitions", 1, 100), ("width", 32, 640),
               ("height", 24, 480), ("n_empty", 0, 10000), ("n_scripts", 0, 1000), ("script_oacs", len(UNSEEN), 100),
               ("script_pointing", 0, 100), ("script_reaching", 0, 100), ("n_distractors", 0, 2))
_REAL_RANGES = (("fps", 1.0, 60.0), ("entry_s", 0.0, 60.0), ("settle_s", 0.0, 60.0), ("idle_s", 0.0, 60.0),
                ("oac_duration_s", 1.0, 30.0), ("light_drift", 0.0, 0.5), ("light_period_s", 1.0, None),
                ("pixel_noise", 0.0, 50.0))


PRESETS: dict[str, dict] = {
    "quick": dict(n_persons=2, n_repetitions=1, width=160, height=120, fps=10.0, n_empty=10, entry_s=1.0,
                  settle_s=0.5, idle_s=0.3, n_scripts=1),
    "paper": {},
}


def preset(name: str, **overrides) -> VideoSettings:
    """`VideoSettings` of a named preset ("quick", "paper"), fields overridden by `overrides`."""
    if name not in PRESETS:
        raise ValueError(f"name: expected one of {sorted(PRESETS)}, got {name!r}")
    return VideoSettings(**{**PRESETS[name], **overrides})


class Primitive(NamedTuple):
    """One step of a script. kind "oac": pick up `object`, perform `action` with it, put it down
    (`ACTIONS[:3]`, `OBJECTS`; any pair, e.g. (1, 2) drink from the pitcher). kind "pointing" /
    "reaching": to `target` (x, y) on the table, world metres."""

    kind: str
    action: int = -1
    object: int = -1
    target: tuple[float, float] = (0.0, 0.0)


class Script(NamedTuple):
    """A recording: the person (index into the settings' persons), the primitives in order, and the
    recording's own seed (timing, motion jitter, lighting, camera noise)."""

    person: int
    primitives: tuple[Primitive, ...]
    seed: int


def check_script(script: Script, settings: VideoSettings) -> Script:
    """`script` with every field checked (ValueError naming the field)."""
    if not isinstance(script, Script):
        raise ValueError(f"script: expected a Script, got {type(script).__name__}")
    check_int(script.person, "script.person", min_value=0, max_value=settings.n_persons - 1)
    check_int(script.seed, "script.seed")
    if len(script.primitives) == 0:
        raise ValueError("script.primitives: need at least one primitive")
    for i, p in enumerate(script.primitives):
        name = f"script.primitives[{i}]"
        if not isinstance(p, Primitive) or p.kind not in PRIMITIVES:
            raise ValueError(f"{name}: expected a Primitive of kind {PRIMITIVES}, got {p!r}")
        if p.kind == "oac":
            check_int(p.action, f"{name}.action", min_value=0, max_value=len(OAC_ACTIONS) - 1)
            check_int(p.object, f"{name}.object", min_value=0, max_value=len(OBJECTS) - 1)
        else:
            x = check_real(p.target[0], f"{name}.target[0]", min_value=-0.6, max_value=0.6)
            y = check_real(p.target[1], f"{name}.target[1]", min_value=-0.65, max_value=-0.2)
            del x, y
    return script


class Recording(NamedTuple):
    """One rendered recording (T frames, H x W images, K = 3 objects, J = len(TRACKED) = 5 parts).

    left, right (T, H, W, 3) uint8: the rectified stereo pair.
    left_labels, right_labels (T, H, W) uint8: `LABELS` (0 background incl. distractors, 1 person,
        2 hand skin (both hands and bare forearms), 3 face skin (and neck), 4 + k object k while it is
        held, from its pick-up to its put-down frame; an object standing on the table is background).
    hand_xyz (T, 3), face_xyz (T, 3), object_xyz (T, K, 3) float32: world metres; the right hand's
        and each object's centre of volume, the face centre (the OAC motions' origin).
    hand_cam, face_cam (T, 3), object_cam (T, K, 3) float32: the same in the left camera's frame
        (x right, y down, z forward; what `experiments.data.oac.triangulate` returns).
    ellipse_centre (T, 2, J, 2) float32: per view (left, right) and tracked part (`TRACKED`: the right
        hand, face, objects) the mask centroid (x, y) px; ellipse_cov (T, 2, J, 2, 2) its second
        central moments px^2; ellipse_area (T, 2, J) int32 pixels; ellipse_found (T, 2, J) bool
        (area > 0; centre and cov are 0 where not found). Right-hand mask only (the left hand is not
        in these), the face mask includes the neck; an object's ellipse is of its pixels whether it is
        held or stands on the table.
    pickup_frames, putdown_frames, event_action, event_object (E,) int32: frame of each pick-up (the
        first frame the object is held) and put-down (the last), and that OAC's action and object.
    action (T,) int8: `ACTIONS` index (-1 none) of the frame: OAC actions from pick-up to put-down,
        pointing / reaching over their movement; object (T,) int8: the held object (-1 none).
    light (T,) float32: the lights' intensity relative to their modelled level.
    P_left, P_right (3, 4) float64: camera matrices, pixel centres at integer coordinates.
    n_empty: frames before the person enters; person: the person's index; fps: frames per second.
    """

    left: np.ndarray
    right: np.ndarray
    left_labels: np.ndarray
    right_labels: np.ndarray
    hand_xyz: np.ndarray
    face_xyz: np.ndarray
    object_xyz: np.ndarray
    hand_cam: np.ndarray
    face_cam: np.ndarray
    object_cam: np.ndarray
    ellipse_centre: np.ndarray
    ellipse_cov: np.ndarray
    ellipse_area: np.ndarray
    ellipse_found: np.ndarray
    pickup_frames: np.ndarray
    putdown_frames: np.ndarray
    event_action: np.ndarray
    event_object: np.ndarray
    action: np.ndarray
    object: np.ndarray
    light: np.ndarray
    P_left: np.ndarray
    P_right: np.ndarray
    n_empty: int
    person: int
    fps: float


class VideoSet(NamedTuple):
    """Several recordings with their metadata, all (N,) int: person, action and object (of a clip's
    single OAC; -1 for long scripts), repetition (clip repetition, or the script's index)."""

    recordings: tuple[Recording, ...]
    person: np.ndarray
    action: np.ndarray
    object: np.ndarray
    repetition: np.ndarray
