"""hog_jax.video: the background model, colour models and level sets put together, on a tiny synthetic
recording whose regions are known (an empty textured scene, then a 'person' block with a 'skin' patch
that moves), and its boundary checks."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import hog_jax
from hog_jax import gmm_log_prob
from hog_jax.video import BACKGROUND, OBJECT, PERSON, SKIN, follow_light
from tests.video_scene import PERSON_RGB, SKIN_RGB, toy_skin_model

H, W, T, START = 24, 32, 16, 10


def _scene(seed=0, leaves=False):
    """frames (T, H, W, 3) uint8 and the true labels (T, H, W): background texture; from frame 4 a
    person block entering from the right, with a skin patch that moves down; `leaves`: the block
    goes on moving left from START on (the pixels it leaves are background again)."""
    rng = np.random.default_rng(seed)
    base = np.where((np.add.outer(np.arange(H) // 4, np.arange(W) // 4) % 2)[..., None] == 1, 150.0, 100.0)
    base = np.broadcast_to(base, (H, W, 3))
    frames, labels = [], []
    for t in range(T):
        img, lab = base.copy(), np.zeros((H, W), np.int8)
        if t >= 4:
            left = max(W - 4 * (t - 3), 12) - (2 * (t - START) if leaves and t >= START else 0)
            img[4:22, left:left + 12] = PERSON_RGB
            lab[4:22, left:left + 12] = PERSON
            top = 6 + (t - START) // 2 if t >= START else 6
            img[top:top + 5, left + 3:left + 8] = SKIN_RGB
            lab[top:top + 5, left + 3:left + 8] = SKIN
        frames.append(np.clip(img + rng.normal(0, 3, img.shape), 0, 255).astype(np.uint8))
        labels.append(lab)
    return np.stack(frames), np.stack(labels)


@pytest.fixture(scope="module")
def fitted():
    frames, labels = _scene()
    skin = toy_skin_model()
    models, fit = hog_jax.video.fit_video_models(jax.random.key(1), skin, frames, START,
                                           hog_jax.video.VideoOptions(person_frames=4), candidates=(1, 2))
    return frames, labels, models, fit


def test_segment_recording_recovers_person_and_skin(fitted):
    frames, labels, models, _ = fitted
    seg = hog_jax.video.segment_recording(models, frames, START, hog_jax.video.VideoOptions(person_frames=4))
    assert seg.labels.shape == (T, H, W) and seg.foreground.shape == (T, H, W)
    ours = np.asarray(seg.labels)[START:]
    truth = labels[START:]
    for region in (BACKGROUND, PERSON, SKIN):
        inter = ((ours == region) & (truth == region)).sum()
        union = ((ours == region) | (truth == region)).sum()
        assert inter / union > 0.8, (hog_jax.video.REGIONS[region], inter / union)
    assert not (ours == OBJECT).any()  # nothing moves that the models do not explain
    assert np.all(np.asarray(seg.iterations)[:START] == 0) and np.all(np.asarray(seg.iterations)[START:] >= 1)


def test_background_is_not_learnt_where_the_previous_frame_is_not_background(fitted):
    """TR §3.5's no-update mask: before START what moved in the previous frame; from START the previous
    frame's regions other than the background (for the first segmented frame: the training phase's
    motion or the person's colours), where the frame's colour is the person's or the skin's. The same
    background model run alone with that mask gives the same foreground (held models frozen, as the
    TR: `follow_light` off)."""
    _, _, models, _ = fitted
    frames, _ = _scene(leaves=True)  # the same frames before START, so the same colour models
    options = hog_jax.video.VideoOptions(person_frames=4, follow_light=False)
    seg = hog_jax.video.segment_recording(models, frames, START, options)
    labels, fg = np.asarray(seg.labels), np.asarray(seg.foreground)
    unit = jnp.asarray(frames, jnp.float32) / 255.0
    density = [np.asarray(gmm_log_prob(g, unit)) for g in (models.background, models.person)]
    density.append(np.asarray(hog_jax.video.skin_log_density(models, [unit[..., c] for c in range(3)])))
    coloured = np.maximum(density[1], density[2]) > density[0]
    claimed = np.zeros((T, H, W), bool)
    claimed[START] = fg[START - 1] | coloured[START]
    claimed[START + 1:] = labels[START:-1] != BACKGROUND
    held = claimed & coloured
    held[0], held[1:START] = False, fg[:START - 1]  # before START: what moved in the previous frame
    assert held[START + 1:].any() and (claimed & ~held)[START + 1:].any()
    _, alone = hog_jax.video.run_background(frames, held, options=options.background)
    np.testing.assert_array_equal(np.asarray(alone), fg)


def _follow_light_float64(mu_before, mu_after, x, followed, held):
    moved = (mu_after - mu_before).sum(0)[:, followed].sum(-1)
    level = x[:, followed].sum(-1)
    s = np.divide(moved, level, out=np.zeros_like(moved), where=level > 0)
    return np.where(held, mu_after * (1.0 + s[None, :, None]), mu_after)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(-0.05, 0.05))
def test_follow_light_scales_held_models_by_the_learnt_pixels_change(seed, gain):
    """Against float64 NumPy; and where every followed pixel's mean moved by gain * X, the held
    pixels' means are scaled by 1 + gain and the others are untouched."""
    rng = np.random.default_rng(seed)
    K, C, N = 3, 3, 40
    before = rng.uniform(20, 230, (K, C, N))
    x = rng.uniform(20, 230, (C, N))
    followed, held = rng.random(N) < 0.5, rng.random(N) < 0.3
    held &= ~followed
    after = before + rng.normal(0, 2, before.shape) * followed
    ours = follow_light(*(jnp.asarray(a, jnp.float32) for a in (before, after, x)), jnp.asarray(followed),
                        jnp.asarray(held))
    np.testing.assert_allclose(ours, _follow_light_float64(before, after, x, followed, held), rtol=1e-4, atol=1e-3)
    uniform = before.copy()
    uniform[0] += gain * x * followed  # one component per pixel moves, as a learnt, matched pixel's does
    ours = np.asarray(follow_light(*(jnp.asarray(a, jnp.float32) for a in (before, uniform, x)),
                                   jnp.asarray(followed), jnp.asarray(held)))
    np.testing.assert_allclose(ours[..., held], before[..., held] * (1 + gain), rtol=1e-4)
    np.testing.assert_array_equal(ours[..., ~held], uniform[..., ~held].astype(np.float32))
    nothing = follow_light(*(jnp.asarray(a, jnp.float32) for a in (before, after, x)), jnp.zeros(N, bool),
                           jnp.asarray(held))
    np.testing.assert_allclose(nothing, after.astype(np.float32))


def test_held_pixels_follow_the_light(fitted):
    """A scene whose light dims by 0.5 % a frame; a 'person' block stands still over part of it for 24
    frames, then leaves. With `follow_light` the pixels it leaves match their models at once; frozen
    (the TR's hold alone) the light has moved beyond their 2.5 sigma match and they are foreground."""
    _, _, models, _ = fitted
    rng = np.random.default_rng(3)
    base = np.where((np.add.outer(np.arange(H) // 4, np.arange(W) // 4) % 2)[..., None] == 1, 200.0, 140.0)
    n, leave = 44, START + 24
    frames = np.repeat(np.broadcast_to(base, (H, W, 3))[None], n, axis=0) * (1 - 0.005 * np.arange(n))[:, None, None, None]
    frames[START:leave, 4:22, 12:24] = PERSON_RGB
    frames = np.clip(frames + rng.normal(0, 2, frames.shape), 0, 255).astype(np.uint8)
    background = hog_jax.video.BackgroundOptions(alpha=0.2)
    left = {}
    for follow in (True, False):
        seg = hog_jax.video.segment_recording(models, frames, START, hog_jax.video.VideoOptions(follow_light=follow,
                                                                                    background=background))
        left[follow] = np.asarray(seg.foreground)[leave, 4:22, 12:24].mean()
        still = np.asarray(seg.foreground)[leave, :, :10].mean()  # never covered: learnt all along
        assert still < 0.05, (follow, still)
    assert left[True] < 0.05 and left[False] > 0.9, left


def test_region_scores_and_bad_input(fitted):
    frames, _, models, _ = fitted
    fg = np.zeros(frames.shape[:3], bool)
    fg[:, :4, :4] = True
    scores = np.asarray(hog_jax.video.region_scores(models, frames, fg))
    assert scores.shape == (T, 4, H, W) and np.all(np.isfinite(scores))
    # a moving pixel loses motion_penalty of its background score and may become an object
    still = np.asarray(hog_jax.video.region_scores(models, frames, np.zeros_like(fg)))
    np.testing.assert_allclose(still[:, BACKGROUND] - scores[:, BACKGROUND], 4.0 * fg, atol=1e-4)
    assert np.all(scores[:, OBJECT][fg] == 0.0) and np.all(scores[:, OBJECT][~fg] < -1e3)
    with pytest.raises(ValueError, match="frames"):
        hog_jax.video.segment_recording(models, frames[..., :2], START)
    with pytest.raises(ValueError, match="frames"):
        hog_jax.video.segment_recording(models, np.full_like(frames, np.nan, dtype=float), START)
    with pytest.raises(ValueError, match="start"):
        hog_jax.video.segment_recording(models, frames, T)
    with pytest.raises(ValueError, match="follow_light"):
        hog_jax.video.segment_recording(models, frames, START, hog_jax.video.VideoOptions(follow_light=1))
    with pytest.raises(ValueError, match="coarse_scale"):
        hog_jax.video.segment_recording(models, frames, START, hog_jax.video.VideoOptions(coarse_scale="no"))
    with pytest.raises(ValueError, match="foreground"):
        hog_jax.video.region_scores(models, frames, fg[:-1])
    with pytest.raises(ValueError, match="right"):
        hog_jax.video.segment_stereo(models, frames, frames[:, :-1], START, hog_jax.video.StereoCamera(30.0, 0.12, W, H))
    with pytest.raises(ValueError, match="start"):
        hog_jax.video.fit_video_models(jax.random.key(0), models.skin, frames, 3, hog_jax.video.VideoOptions(person_frames=4))
