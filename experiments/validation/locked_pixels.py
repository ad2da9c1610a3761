"""Why background pixels stay "person" to the end of a clip, measured on one seed-1 validation
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
from hog_jax.video import BackgroundOptions, VideoOptions, fit_video_models, pad_frames, segment_recording
from hog_jax.video._src.pipeline import colour_log_densities
from lfd_common import enable_compilation_cache

SKIN_PERSONS = (1, 3)
sim.setup_rendering()
enable_compilation_cache()
person, oac = map(int, sys.argv[1].split(":"))
settings = video.preset("paper", seed=1)
start = video.segmentation_start(settings)
recs = {(p, c): video.render_recording(settings, s) for p, c, r, s in video.clip_scripts(settings)
        if r == 0 and ((p, c) == (person, oac) or (p in SKIN_PERSONS and c == 0))}
options = VideoOptions(background=BackgroundOptions.for_fps(settings.fps))
rec = recs[person, oac]
left, T = pad_frames(rec.left, 50), len(rec.left)
models, _ = fit_video_models(jax.random.key(1), video.fit_skin_models(settings, SKIN_PERSONS, 1)[0], left, start, options)
seg = segment_recording(models, left, start, options)
labels, moving = np.asarray(seg.labels)[:T], np.asarray(seg.foreground)[:T]
false_person = (labels == 1) & (rec.left_labels == 0)
locked = false_person[-30:].all(0)
print(f"clip {person}:{oac}, {T} frames, segmented from {start}: {locked.sum()} locked pixels")
if locked.any():
    onset = T - np.argmax(~false_person[::-1][:, locked], axis=0)
    print("locked since frame (10 / 50 / 90 %):", np.percentile(onset, [10, 50, 90]).astype(int).tolist())
    densities = np.asarray(colour_log_densities(models, jnp.asarray(left[:T])))
    for t in (T - 60, T - 30, T - 1):
        d = densities[t][:, locked].mean(axis=1)
        print(f"frame {t}: moving {moving[t][locked].mean():.2f}, log-density background GMM {d[0]:.2f}, "
              f"person {d[1]:.2f}, skin {d[2]:.2f}")
    # Replay the background model of `_segment_one` from the labels (the hold rule is a function of the
    # previous frame's labels and this frame's colours) to read the pixel's own-mixture density and the
    # background score the level sets saw.
    from hog_jax.video._src import background_kernel as bgk
    from hog_jax.video import BackgroundStructure, check_options
    from hog_jax.video._src.pipeline import person_coloured
    from hog_jax.video import follow_light as hog_jax_follow
    bo = check_options(options.background)
    H, W = labels.shape[1:]
    xs = np.moveaxis(left[:T].reshape(T, H * W, 3), 2, 1).astype(np.float32)
    state = bgk.pixels_last(bgk.init_state(jnp.asarray(left[0]), BackgroundStructure().n_components, bo))
    held = np.zeros(H * W, bool)
    step = jax.jit(lambda s, x, learn: bgk.step_pixels_last(*s, x, learn, bo))
    own_log = jax.jit(lambda s, x: bgk.log_density_pixels_last(*s, x))
    watch = {T - 60, T - 30, T - 1}
    flat_locked = locked.reshape(-1)
    for t in range(T):
        x = jnp.asarray(xs[t])
        if t >= start:
            held = (labels[t - 1].reshape(-1) != 0) & np.asarray(person_coloured(densities[t])).reshape(-1)
        if t in watch:
            own = np.asarray(own_log(state, x))[flat_locked]
            bg = np.logaddexp(densities[t][0].reshape(-1)[flat_locked], own) - np.log(2.0)
            print(f"frame {t}: own-mixture log-density median {np.median(own):.2f} (10 % {np.percentile(own, 10):.2f}), "
                  f"background score median {np.median(bg):.2f}, held {held[flat_locked].mean():.2f}")
        before = state[1]
        w, mu, var, fg = step(state, x, jnp.asarray(~held))
        if t >= start:
            mu = hog_jax_follow(before, mu, x, jnp.asarray(~held) & ~fg, jnp.asarray(held))
        state = (w, mu, var)
        if t < start:
            held = np.asarray(fg)
