"""Validation sweep of the object in the hand on the two seed-1 long recordings (never the test
recordings), the video front end computed once and kept under
`lfd_common.cache_dir("validation")`.

    python experiments/validation/object_in_hand.py '[{}, {"remove_person": true}, {"threshold": 1.0}, {"motion": 4.0}]'

Each variant: pooled object IoU, the found rate where the hand moved with and without a held object (per
recording), matched / missed / spurious events and the median errors (frames).
"""

import json, os, sys, itertools
import jax, numpy as np
import sim, hog_jax
from experiments.data import video
from experiments.lfd_demonstration.config import Config
from experiments.lfd_demonstration.evaluate import hand_width, match_events, pooled_iou, truth_windows
from experiments.peers.object_peer import peer_object_masks
from hog_jax.video import (HAND, BackgroundOptions, HandFaceOptions, TrackOptions, VideoOptions, front_end,
                           stereo_camera_from_matrices)
from hog_jax.video import SKIN, PERSON, OBJECT
from lfd_common import cache_dir, enable_compilation_cache

sim.setup_rendering()
enable_compilation_cache()
cfg = Config(seed=1, n_scripts=2)
settings = cfg.video_settings()
scripts = video.long_scripts(settings)
data = []
for i, script in enumerate(scripts):
    path = str(cache_dir("validation") / f"object_in_hand_front_{i}.npz")
    rec = video.render_recording(settings, script, progress=None)
    if not os.path.exists(path):
        skin_model, _ = video.fit_skin_models(settings, range(8, 10), cfg.seed)
        start = video.segmentation_start(settings)
        camera = stereo_camera_from_matrices(rec.P_left, rec.P_right, *rec.left.shape[1:3])
        out = front_end(jax.random.key(cfg.seed + i), skin_model, rec.left, rec.right, start, camera,
                        VideoOptions(background=BackgroundOptions.for_fps(settings.fps)),
                        HandFaceOptions(tracking=TrackOptions(min_init=3)), pad_multiple=50)
        labels, positions, hl, hr, tracked = out.labels, out.positions, out.hand_left, out.hand_right, out.tracked
        obs = np.asarray(positions.skin_left.observed)[:, HAND] & tracked
        np.savez(
            path,
            labels=labels,
            hl=hl,
            hr=hr,
            tracked=tracked,
            obs=obs,
            cov=np.asarray(positions.skin_left.cov)[:, HAND],
            start=start,
        )
    z = np.load(path)
    data.append((rec, dict(z)))
print("front end cached", flush=True)
half = (20, 20)


def run(variant):
    out = {
        "inter": 0,
        "union": 0,
        "pick": [],
        "put": [],
        "missed": 0,
        "spurious": 0,
        "found_rate_held": [],
        "found_rate_free": [],
    }
    for i, (rec, z) in enumerate(data):
        tracked = z["tracked"]
        sigma = hand_width(z["cov"], z["obs"]) * variant.get("sigma_scale", 1.0)
        gl, gr = video.grey(rec.left), video.grey(rec.right)
        lab = z["labels"]
        remove = lab == SKIN
        if variant.get("remove_person"):
            remove = remove | (lab == PERSON)
        seg = hog_jax.video.segment_objects(
            jax.random.key(1000 + i),
            gl,
            gr,
            z["hl"],
            z["hr"],
            remove,
            hog_jax.video.ObjectOptions(
                half,
                sigma,
                max_offset=20,
                threshold=variant.get("threshold", 0.01),
                min_hand_motion=variant.get("motion", 2.0),
            ),
        )
        masks, found = np.asarray(seg.masks) & tracked[:, None, None], np.asarray(seg.found) & tracked
        truth = truth_windows(rec.left_labels, z["hl"], half)
        a, b = pooled_iou(masks, truth)
        out["inter"] += a
        out["union"] += b
        decided = np.asarray(seg.hand_moved) & tracked
        held = truth.any((1, 2))
        out["found_rate_held"].append(float(found[decided & held].mean()))
        out["found_rate_free"].append(float(found[decided & ~held].mean()))
        periods = hog_jax.video.periods_in_hand(found, settings.fps, 1, 1.0, decided)
        m = match_events(rec.pickup_frames, rec.putdown_frames, periods.pickup, periods.putdown)
        out["pick"] += list(np.abs(m.pickup_error))
        out["put"] += list(np.abs(m.putdown_error))
        out["missed"] += m.missed
        out["spurious"] += m.spurious
    return {
        "iou": round(out["inter"] / max(out["union"], 1), 3),
        "held": np.round(out["found_rate_held"], 2).tolist(),
        "free": np.round(out["found_rate_free"], 2).tolist(),
        "matched": len(out["pick"]),
        "missed": out["missed"],
        "spurious": out["spurious"],
        "pick_med": float(np.median(out["pick"])) if out["pick"] else None,
        "put_med": float(np.median(out["put"])) if out["put"] else None,
    }


variants = json.loads(sys.argv[1]) if len(sys.argv) > 1 else [{}]
for v in variants:
    print(v, run(v), flush=True)
