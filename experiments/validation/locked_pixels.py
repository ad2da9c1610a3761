"""Why background pixels stay "person" to the end of a clip (issue 18), measured on one seed-1 validation
clip (never a test person): the default pipeline's left-view labels, the pixels that are truly
background but labelled person in each of the last 30 frames ("locked"), and at those pixels, over
the last frames, the share the background model sees move and the mean background-GMM, person-GMM and
skin-GMM log-densities. Skin from persons 1 and 3, as `hold_rule.py`.

    python experiments/validation/locked_pixels.py 9:0
"""

import sys

import jax
import jax.numpy as jnp
import numpy as np

import sim
from experiments.data import video
from experiments.video_segmentation.stages import _pad, background_options, segmentation_start
from hog_jax.video import VideoOptions, _colour_log_densities, fit_skin, fit_video_models, segment_recording
from lfd_common import enable_compilation_cache

SKIN_PERSONS = (1, 3)
sim.setup_rendering()
enable_compilation_cache()
person, oac = map(int, sys.argv[1].split(":"))
settings = video.preset("paper", seed=1)
start = segmentation_start(settings)
recs = {(p, c): video.render_recording(settings, s) for p, c, r, s in video.clip_scripts(settings)
        if r == 0 and ((p, c) == (person, oac) or (p in SKIN_PERSONS and c == 0))}
rng = np.random.default_rng(0)
skin = []
for p in SKIN_PERSONS:
    lab = recs[p, 0].left_labels[::3]
    is_skin = (lab == 2) | (lab == 3)
    skin.append(recs[p, 0].left[::3][is_skin][rng.random(is_skin.sum()) < 0.05])
options = VideoOptions(background=background_options(settings))
rec = recs[person, oac]
left, _, T = _pad(rec, 50)
models, _ = fit_video_models(jax.random.key(1), fit_skin(jax.random.key(1), np.concatenate(skin)), left, start, options)
seg = segment_recording(models, left, start, options)
labels, moving = np.asarray(seg.labels)[:T], np.asarray(seg.foreground)[:T]
false_person = (labels == 1) & (rec.left_labels == 0)
locked = false_person[-30:].all(0)
print(f"clip {person}:{oac}, {T} frames, segmented from {start}: {locked.sum()} locked pixels")
if locked.any():
    onset = T - np.argmax(~false_person[::-1][:, locked], axis=0)
    print("locked since frame (10 / 50 / 90 %):", np.percentile(onset, [10, 50, 90]).astype(int).tolist())
    densities = np.asarray(_colour_log_densities(models, jnp.asarray(left[:T])))
    for t in (T - 60, T - 30, T - 1):
        d = densities[t][:, locked].mean(axis=1)
        print(f"frame {t}: moving {moving[t][locked].mean():.2f}, log-density background GMM {d[0]:.2f}, "
              f"person {d[1]:.2f}, skin {d[2]:.2f}")
