"""hog_jax.background: eqs. 9-10 (TR §3.5) against a float64 NumPy reference written here, frame by
frame; the batch against single videos; a moving square; the no-update mask; bad input."""
import chex
import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hog_jax.video import (BackgroundOptions, BackgroundState, BackgroundStructure, init_background,
    log_density, run_background, run_background_batch, update)

OPTS = BackgroundOptions()


# ------------------------------------------------------------------- the reference, one pixel at a time
def _key(w, var):
    return w / np.sqrt(var)


def ref_step(w, mu, var, x, learn, o: BackgroundOptions, log: dict):
    """Stauffer-Grimson / eqs. 9-10 for one pixel, literally: w (K,), mu (K, C), var (K,), x (C,)."""
    K = len(w)
    dist = np.linalg.norm(x - mu, axis=1)
    limit = o.match_sigmas * np.sqrt(var)
    log["margin"] = min(log.get("margin", np.inf), np.min(np.abs(dist - limit) / limit))
    key = _key(w, var)
    order = sorted(range(K), key=lambda k: (-key[k], k))  # by w / sigma, ties: lower index first
    matches = [k for k in order if w[k] > 0 and dist[k] < limit[k]]
    best = matches[0] if matches else None
    if learn:
        w, mu, var = w.copy(), mu.copy(), var.copy()
        if best is not None:
            log["match"] = log.get("match", 0) + 1
            M = np.zeros(K)
            M[best] = 1.0
            w = (1 - o.alpha) * w + o.alpha * M
            if o.rho == "alpha":
                rho = o.alpha
            else:
                C = len(x)
                eta = np.exp(-0.5 * dist[best] ** 2 / var[best]) / (2 * np.pi * var[best]) ** (C / 2)
                rho = min(o.alpha * eta, 1.0)
            mu[best] = (1 - rho) * mu[best] + rho * x
            var[best] = max((1 - rho) * var[best] + rho * np.sum((x - mu[best]) ** 2), o.min_variance)
        else:
            log["replace"] = log.get("replace", 0) + 1
            worst = min(range(K), key=lambda k: (key[k], k))  # least probable, ties: lower index
            w = (1 - o.alpha) * w
            w[worst], mu[worst], var[worst] = o.init_weight, x, o.init_variance
        w = w / w.sum()
    elif best is None or best != 0:
        log["frozen"] = log.get("frozen", 0) + 1
    if best is None:
        return w, mu, var, True
    if o.decision == "matched":
        return w, mu, var, False
    key = _key(w, var)
    order = sorted(range(K), key=lambda k: (-key[k], k))
    cum = np.cumsum(w[order])
    log["ratio_margin"] = min(log.get("ratio_margin", np.inf), np.min(np.abs(cum - o.background_ratio)))
    B = int(np.argmax(cum > o.background_ratio)) + 1
    return w, mu, var, best not in order[:B]


def ref_video(frames, masks, o: BackgroundOptions, K=3):
    """Frame-by-frame reference over a (T, H, W, C) video: the state after every frame and the
    foreground (T, H, W), plus counts of what happened."""
    T, H, W, C = frames.shape
    f = frames.astype(np.float64)
    w = np.zeros((H, W, K))
    w[..., 0] = 1.0
    mu = np.repeat(f[0][:, :, None, :], K, axis=2)
    var = np.full((H, W, K), o.init_variance)
    states, fg, log = [], np.zeros((T, H, W), bool), {}
    for t in range(T):
        for i in range(H):
            for j in range(W):
                learn = masks is None or not masks[t, i, j]
                w[i, j], mu[i, j], var[i, j], fg[t, i, j] = ref_step(w[i, j], mu[i, j], var[i, j], f[t, i, j], learn,
                                                                     o, log)
        states.append((w.copy(), mu.copy(), var.copy()))
    return states, fg, log


def _events_video(seed=0, T=16, H=12, W=16):
    """A small video whose pixels stay near their value (match), jump far (no match: replacement),
    or return to an earlier jump colour (a match of a second component); a random no-update mask."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(60, 190, (H, W, 3))
    colours = [base]
    frames = [base]
    for t in range(1, T):
        event = rng.integers(0, 3, (H, W))
        jump = np.clip(base + rng.choice([-1.0, 1.0], (H, W, 3)) * rng.uniform(90, 120, (H, W, 3)), 0, 255)
        back = colours[max(0, t - 2)]
        frame = np.where((event == 1)[..., None], jump, np.where((event == 2)[..., None], back, base))
        frame = np.clip(frame + rng.uniform(-1, 1, frame.shape), 0, 255)
        colours.append(frame)
        frames.append(frame)
    frames = np.round(np.stack(frames)).astype(np.uint8)
    masks = rng.random((T, H, W)) < 0.2
    return frames, masks


@pytest.fixture(scope="module")
def events():
    frames, masks = _events_video()
    return frames, masks, ref_video(frames, masks, OPTS)


def _assert_state(state: BackgroundState, ref, tol=2e-4):
    for got, want in zip(state, ref):
        np.testing.assert_allclose(np.asarray(got, np.float64), want, rtol=tol, atol=tol)


def test_update_matches_reference_frame_by_frame(events):
    frames, masks, (states, fg, log) = events
    assert log["match"] > 50 and log["replace"] > 20 and log["frozen"] > 5  # every branch is exercised
    assert log["margin"] > 1e-3 and log["ratio_margin"] > 1e-4  # no decision is decided by rounding
    state = init_background(frames[0])
    for t in range(len(frames)):
        state, fg_t = update(state, frames[t], masks[t])
        chex.assert_shape(fg_t, frames.shape[1:3])
        _assert_state(state, states[t])
        np.testing.assert_array_equal(np.asarray(fg_t), fg[t], err_msg=f"frame {t}")
    assert fg.any() and not fg.all()


def test_run_background_equals_reference(events):
    frames, masks, (states, fg, _) = events
    state, got = run_background(frames, masks)
    chex.assert_shape(got, frames.shape[:3])
    _assert_state(state, states[-1])
    np.testing.assert_array_equal(np.asarray(got), fg)


@pytest.mark.parametrize("options", [BackgroundOptions(decision="matched"),
                                     BackgroundOptions(rho="alpha_eta", alpha=0.2, min_variance=0.5)])
def test_options_against_reference(events, options):
    """The TR's decision rule and eq. 10's rho = alpha eta, through the same compiled scan."""
    frames, masks, _ = events
    states, fg, _ = ref_video(frames, masks, options)
    state, got = run_background(frames, masks, options=options)
    _assert_state(state, states[-1])
    np.testing.assert_array_equal(np.asarray(got), fg)


def test_initial_state_continues_a_video(events):
    frames, masks, _ = events
    more, _ = _square_video([(5, 6)] * 16)
    states, fg, _ = ref_video(np.concatenate([frames, more]), np.concatenate([masks, np.zeros_like(masks)]), OPTS)
    first, _ = run_background(frames, masks)
    state, got = run_background(more, initial_state=first)
    _assert_state(state, states[-1])
    np.testing.assert_array_equal(np.asarray(got), fg[len(frames):])


def test_batch_equals_single_videos(events):
    frames, masks, _ = events
    videos = np.stack([frames[:, ::-1], 255 - frames])
    all_masks = np.stack([masks[:, ::-1], np.zeros_like(masks)])
    states, fg = run_background_batch(videos, all_masks)
    chex.assert_shape(fg, videos.shape[:4])
    chex.assert_shape(states.means, (2, *frames.shape[1:3], 3, 3))
    for b in range(2):
        s, f = run_background(videos[b], all_masks[b])
        np.testing.assert_array_equal(np.asarray(fg[b]), np.asarray(f))
        for got, want in zip(states, s):
            np.testing.assert_allclose(np.asarray(got[b]), np.asarray(want), rtol=1e-6, atol=1e-6)


def test_threads_do_not_change_the_result(events):
    """Stripes of rows (uneven: 12 rows in 5) and groups of videos on host threads give what one call
    gives, a continued video included."""
    frames, masks, _ = events
    first, _ = run_background(frames[:8], masks[:8], threads=1)
    whole = run_background(frames[8:], masks[8:], initial_state=first, threads=1)
    striped = run_background(frames[8:], masks[8:], initial_state=first, threads=5)
    for got, want in zip(jax.tree.leaves(striped), jax.tree.leaves(whole)):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    videos = np.stack([frames, 255 - frames])
    one = run_background_batch(videos, threads=1)
    for got, want in zip(jax.tree.leaves(run_background_batch(videos, threads=2)), jax.tree.leaves(one)):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))


def test_log_density_is_eq9_in_float64(events):
    """Eq. 9's mixture density of a frame under a learnt state, against float64 NumPy: isotropic
    components of per-channel variance sigma^2 / C in the unit colour cube; empty components skipped."""
    frames, masks, _ = events
    state, _ = run_background(frames[:8], masks[:8])
    frame = frames[8]
    got = np.asarray(log_density(state, frame))
    w, mu, var = (np.asarray(a, np.float64) for a in state)
    x = frame.astype(np.float64)[:, :, None, :] / 255.0
    v = var / (3 * 255.0 ** 2)
    comp = np.exp(-0.5 * ((x - mu / 255.0) ** 2).sum(-1) / v) / (2 * np.pi * v) ** 1.5
    want = np.log((w * comp).sum(-1))
    assert (w == 0).any() and np.isfinite(want).all()
    np.testing.assert_allclose(got, want, rtol=1e-4, atol=1e-3)


def _square_video(positions, T=16, H=12, W=16, side=4, seed=1):
    rng = np.random.default_rng(seed)
    scene = rng.uniform(40, 200, (H, W, 3))
    frames = np.clip(scene + rng.normal(0, 1.5, (T, H, W, 3)), 0, 255)
    truth = np.zeros((T, H, W), bool)
    for t, (r, c) in enumerate(positions):
        if r >= 0:
            frames[t, r:r + side, c:c + side] = (230.0, 20.0, 230.0)
            truth[t, r:r + side, c:c + side] = True
    return frames.astype(np.uint8), truth


def test_moving_square_is_foreground():
    """(Every test video has the events' shape, so that one compilation serves all.)"""
    positions = [(-1, -1)] * 4 + [(1 + 7 * (i // 6 % 2), 3 * (i % 6)) for i in range(12)]  # 3 px a frame
    frames, truth = _square_video(positions)
    _, fg = run_background(frames)
    np.testing.assert_array_equal(np.asarray(fg), truth)


def test_no_update_mask_keeps_a_still_person_foreground():
    """TR §3.5: a square that stops is absorbed by the background unless its pixels are not learned."""
    positions = [(-1, -1)] * 4 + [(5, 6)] * 12
    frames, truth = _square_video(positions)
    _, learned = run_background(frames)
    _, masked = run_background(frames, no_update_masks=truth)
    last = truth[-1]
    assert np.asarray(learned)[-1][last].mean() == 0.0  # absorbed after (1 - alpha)^t < T
    np.testing.assert_array_equal(np.asarray(masked)[-1], last)


# ----------------------------------------------------------------------------- the public promise
@settings(max_examples=5, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from(["stauffer_grimson", "matched"]), st.floats(0.01, 1.0))
def test_valid_video_gives_finite_state(seed, decision, alpha):
    frames = np.random.default_rng(seed).integers(0, 256, (16, 12, 16, 3)).astype(np.uint8)  # the events' shape
    state, fg = run_background(frames, options=BackgroundOptions(alpha=alpha, decision=decision))
    chex.assert_shape((state.weights, state.means, state.variances, fg), [(12, 16, 3), (12, 16, 3, 3),
                                                                       (12, 16, 3), (16, 12, 16)])
    assert fg.dtype == bool
    chex.assert_tree_all_finite(state)
    np.testing.assert_allclose(np.asarray(state.weights).sum(-1), 1.0, rtol=1e-5)
    assert float(np.min(state.variances)) >= BackgroundOptions().min_variance


GOOD = np.full((3, 4, 5, 3), 100, np.uint8)
NAN = GOOD.astype(np.float32)
NAN[1, 2, 3, 0] = np.nan
BAD_CALLS = {
    "frames: expected a 4-D": lambda: run_background(GOOD[0]),
    "frames: expected 3 colour": lambda: run_background(GOOD[..., :2]),
    "frames: contains 1 NaN": lambda: run_background(NAN),
    "frames: values must be <= 255": lambda: run_background(GOOD.astype(np.float32) + 200),
    "frames: must not be empty": lambda: run_background(GOOD[:0]),
    "frames: expected uint8": lambda: run_background(GOOD > 0),
    "no_update_masks: expected shape": lambda: run_background(GOOD, np.zeros((3, 4, 4), bool)),
    "no_update_masks: expected a boolean": lambda: run_background(GOOD, np.full((3, 4, 5), 2)),
    "n_components: must be >= 1": lambda: BackgroundStructure(n_components=0),
    "alpha: must be > 0": lambda: run_background(GOOD, options=BackgroundOptions(alpha=0.0)),
    "alpha: must be <= 1": lambda: run_background(GOOD, options=BackgroundOptions(alpha=1.5)),
    "decision: expected one of": lambda: run_background(GOOD, options=BackgroundOptions(decision="x")),
    "frames: expected a 5-D": lambda: run_background_batch(GOOD),
    "frame: expected a 3-D": lambda: update(init_background(GOOD[0]), GOOD),
    "state: expected weights": lambda: update(init_background(GOOD[0]), GOOD[0, :3]),
    "no_update_mask: expected shape": lambda: update(init_background(GOOD[0]), GOOD[0], np.zeros((5, 4), bool)),
    "first_frame: expected a 3-D": lambda: init_background(GOOD),
    "initial_state: expected weights": lambda: run_background(GOOD, initial_state=init_background(GOOD[0, :2])),
    "threads: must be >= 1": lambda: run_background(GOOD, threads=0),
    "scale: must be > 0": lambda: log_density(init_background(GOOD[0]), GOOD[0], scale=0.0),
    "videos_per_step: must be <= 1": lambda: run_background_batch(GOOD[None], videos_per_step=2),
    "init_variance: must be >= min_variance": lambda: run_background(GOOD,
                                                                     options=BackgroundOptions(init_variance=1.0)),
}


@pytest.mark.parametrize("message", sorted(BAD_CALLS))
def test_bad_input_names_the_argument(message):
    with pytest.raises(ValueError, match=message):
        BAD_CALLS[message]()


def test_options_are_traced(events):
    """Changing alpha, rho or the decision rule reuses the compiled scan."""
    from hog_jax.video._src import background as background
    frames = events[0]
    run_background(frames, options=BackgroundOptions(alpha=0.3))
    before = background._run_jit._cache_size()
    jax.block_until_ready(run_background(frames, options=BackgroundOptions(alpha=0.1, decision="matched",
                                                                           rho="alpha_eta"))[1])
    assert background._run_jit._cache_size() == before
