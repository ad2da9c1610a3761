"""Simulated demonstration videos (LfD 2009 §III-A, §V; LEVELSET TR §3): a person at a table,
filmed by a rectified stereo pair, picks up, uses and puts down the OAC objects (look through the
binoculars, drink from the cup, pour from the pitcher, and combinations never in training such as
drinking from the pitcher), points and reaches to table positions; rendered with MuJoCo
(`sim.person_scene`), with the ground truth of every frame.

A recording (`render_recording(settings, script)` -> `Recording`, shapes in its docstring):
- `n_empty` frames of the empty scene (the background model's training, TR §3.5), the person comes
  in from one side (`entry_s`) and puts the left forearm on the table (`settle_s`), then the script's
  primitives with rests between them (`idle_s`); the lights drift slowly all along (`light_drift`,
  `light_period_s`); camera noise `pixel_noise`.
- Persons: `experiments.data.oac.draw_persons` (10 by default: 7 men, 3 women; size, speed, reach,
  style), each with a look (clothing colour and pattern, hair, skin tone, sleeves) and a stereo rig
  (the OAC generator's camera pose; 12 cm baseline; focal 525 px at 640 x 480, scaled to `width`).
- Motions: one copy of each model (`kinematics`): the table-top reaching / pointing movements of
  `experiments.data.tabletop` for the arm, `experiments.data.oac.object_trajectory` for the held
  object, the table-top inverse kinematics for the elbow.
- Ground truth: label maps of both views (`LABELS`: background, person, hand skin, face skin, object
  k while it is held), 3-D centres of the right hand, face and objects (world and left camera),
  mask ellipses of hand, face and objects in both views (`TRACKED`), pick-up / put-down frames,
  per-frame action and object, the camera matrices.

Data sets: `clips(settings)` persons x 3 OACs x repetitions pre-segmented clips (`iter_clips` one at a
time), `scripts(settings)` long recordings of `script_oacs` OACs (the `UNSEEN` combinations among
them), `script_pointing` pointings and `script_reaching` reachings. Deterministic from the seeds;
each recording cached (np.savez_compressed) under `lfd_common.cache_dir("video")` keyed by every
setting, its script and the generator's source. `PRESETS` "quick" (2 persons x 3 x 1 at 160 x 120,
10 fps) and "paper". Pictures: `contact_sheet`, `overlay`, `write_video`, `grey`;
`python -m experiments.data.video --preset quick --out DIR` renders one long recording and writes both.
The front end's training on them: `segmentation_start` (the end of a recording's training phase),
`fit_skin_models` (skin models from the clips of some persons), `selected_clips`.
"""
from experiments.data.video.settings import (ACTIONS, LABELS, OBJECTS, PRESETS, PRIMITIVES, TRACKED, UNSEEN,
                                             Primitive, Recording, Script, VideoSet, VideoSettings, check_script,
                                             preset)
from experiments.data.video.people import actor, persons
from experiments.data.video.render import (clip_scripts, clips, ellipses, iter_clips, long_scripts,
                                           render_recording, scripts)
from experiments.data.video.outputs import contact_sheet
from experiments.data.video.training import fit_skin_models, segmentation_start, selected_clips
from lfd_jax import LABEL_COLOURS, grey, overlay, write_video

__all__ = ["ACTIONS", "LABELS", "LABEL_COLOURS", "OBJECTS", "PRESETS", "PRIMITIVES", "Primitive", "Recording",
           "Script", "TRACKED", "UNSEEN", "VideoSet", "VideoSettings", "actor", "check_script", "clip_scripts",
           "clips", "contact_sheet", "ellipses", "fit_skin_models", "grey", "iter_clips", "long_scripts", "overlay",
           "persons", "preset", "render_recording", "scripts", "segmentation_start", "selected_clips", "write_video"]
