"""Validation of the video front end's options on seed-1 clips (never the test persons): the full
pipeline's hand / face / person / object IoU per clip for `VideoOptions` overrides; skin from persons 1 and 3.

    python experiments/validation/hold_rule.py OUT 'p:c,p:c,...' '{"follow_light": true}' [render_only]

The follow-light choice in README came from
    ... OUT '0:0,0:2,9:0,9:2,2:0,5:1,8:2' '{"follow_light": true}'   (and false).
"""

import json, sys, time
import jax, numpy as np
import sim, hog_jax
from experiments.data import video
from experiments.video_segmentation.evaluate import evaluate_clip, TRACKED
from hog_jax.video import (BackgroundOptions, HandFaceOptions, TrackOptions, VideoOptions, fit_video_models,
                           pad_frames, segment_stereo, stereo_camera_from_matrices)
from lfd_common import enable_compilation_cache

out, pairs, over = sys.argv[1], [tuple(map(int, s.split(":"))) for s in sys.argv[2].split(",")], json.loads(sys.argv[3])
render_only = len(sys.argv) > 4
sim.setup_rendering()
enable_compilation_cache()
settings = video.preset("paper", seed=1)
SKIN_PERSONS = (1, 3)
recs = {}
for p, c, r, script in video.clip_scripts(settings):
    if r == 0 and ((p, c) in pairs or (p in SKIN_PERSONS and c == 0)):
        t = time.time()
        recs[p, c] = video.render_recording(settings, script)
        print("rendered", p, c, round(time.time() - t), flush=True)
if render_only:
    sys.exit()
rgb_skin = video.fit_skin_models(settings, SKIN_PERSONS, 1)[0]
options = VideoOptions(background=BackgroundOptions.for_fps(settings.fps))._replace(**over)
start = video.segmentation_start(settings)
res = {}
for n, (p, c) in enumerate(pairs):
    rec = recs[p, c]
    left, right, T = pad_frames(rec.left, 50), pad_frames(rec.right, 50), len(rec.left)
    camera = stereo_camera_from_matrices(rec.P_left, rec.P_right, *rec.left.shape[1:3])
    models, _ = fit_video_models(jax.random.key(1 + n), rgb_skin, left, start, options)
    seg = segment_stereo(models, left, right, start, camera, options,
                         HandFaceOptions(tracking=TrackOptions(min_init=3)))
    seg = jax.tree.map(lambda a: np.asarray(a)[:T] if np.ndim(a) and np.shape(a)[0] == left.shape[0] else a, seg)
    skin_mask = np.asarray(hog_jax.segment(rgb_skin, rec.left).skin)
    counts = evaluate_clip(rec, skin_mask, seg, start, camera)
    iou = {r: counts.inter[TRACKED, r] / max(counts.union[TRACKED, r], 1) for r in ("hand", "face", "person", "object")}
    res[f"{p}:{c}"] = iou
    np.save(f"{out}_{p}_{c}_labels.npy", np.asarray(seg.left.labels))
    print(p, c, {k: round(v, 3) for k, v in iou.items()}, flush=True)
print(
    "mean person", np.mean([v["person"] for v in res.values()]), "mean hand", np.mean([v["hand"] for v in res.values()])
)
json.dump(res, open(out + ".json", "w"), indent=1)
