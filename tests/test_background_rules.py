"""hog_jax.background's rules for real video (warm-up, rho = alpha / w, the variance ceiling, the
"background_match" decision, shadows, the 3 x 3 median) against a float64 NumPy reference written
here, pixel by pixel; hypothesis properties of the shadow rule and the warm-up; the real-sequence
loader on a synthetic CDnet / SBI folder and its F1 counting by hand."""
import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from experiments.data.video import real_sequences as rs
from hog_jax.video import (BackgroundOptions, BackgroundState, BackgroundStructure, init_background, run_background,
                           update)

REAL = BackgroundOptions.real_video()


# ------------------------------------------------------------------- the reference, one pixel at a time
def _order(w, var):
    key = w / np.sqrt(var)
    return sorted(range(len(w)), key=lambda k: (-key[k], k))  # by w / sigma, ties: lower index first


def _background(w, var, ratio):
    """(K,) bool: the weight ranked strictly before k is <= T (the first B), and w_k > 0."""
    order = _order(w, var)
    out = np.zeros(len(w), bool)
    ahead = 0.0
    for k in order:
        out[k] = ahead <= ratio and w[k] > 0
        ahead += w[k]
    return out


def ref_step(w, mu, var, x, t, o: BackgroundOptions):
    """One pixel and frame t: w (K,), mu (K, C), var (K,), x (C,) -> new state and foreground."""
    K = len(w)
    w, mu, var = w.copy(), mu.copy(), var.copy()
    alpha = max(o.alpha, 1.0 / (t + 1)) if o.warmup else o.alpha
    d2 = np.sum((x - mu) ** 2, axis=1)
    matches = [k for k in _order(w, var) if w[k] > 0 and d2[k] < o.match_sigmas ** 2 * var[k]]
    best = matches[0] if matches else None
    if best is not None:
        w = (1 - alpha) * w + alpha * (np.arange(K) == best)
        w = w / w.sum()
        rho = min(alpha / w[best], 1.0) if o.rho == "alpha_over_weight" else alpha
        mu[best] = (1 - rho) * mu[best] + rho * x
        var[best] = min(max((1 - rho) * var[best] + rho * np.sum((x - mu[best]) ** 2), o.min_variance),
                        o.max_variance)
    else:
        key = w / np.sqrt(var)
        worst = min(range(K), key=lambda k: (key[k], k))
        w = (1 - alpha) * w
        w[worst], mu[worst], var[worst] = o.init_weight, x, o.init_variance
        w = w / w.sum()
    in_bg = _background(w, var, o.background_ratio)
    lam_d = o.match_sigmas if o.decision_sigmas is None else o.decision_sigmas
    if o.decision == "background_match":
        fg = not any(in_bg[k] and np.sum((x - mu[k]) ** 2) < lam_d ** 2 * var[k] for k in range(K))
    else:
        fg = best is None or not in_bg[best]
    if o.shadow_tau is not None:
        for k in range(K):
            a = x @ mu[k] / (mu[k] @ mu[k])
            if in_bg[k] and o.shadow_tau <= a <= 1 and np.sum((a * mu[k] - x) ** 2) < lam_d ** 2 * var[k] * a * a:
                fg = False
    return w, mu, var, fg


def ref_median3(masks):
    """The 3 x 3 median of (T, H, W) bool masks, edges replicated, by a loop."""
    T, H, W = masks.shape
    out = np.zeros_like(masks)
    for t in range(T):
        for i in range(H):
            for j in range(W):
                rows = np.clip(np.arange(i - 1, i + 2), 0, H - 1)
                cols = np.clip(np.arange(j - 1, j + 2), 0, W - 1)
                out[t, i, j] = masks[t][np.ix_(rows, cols)].sum() >= 5
    return out


def ref_video(frames, o: BackgroundOptions, K: int):
    T, H, W, C = frames.shape
    f = frames.astype(np.float64)
    w = np.zeros((H, W, K))
    w[..., 0] = 1.0
    mu = np.repeat(f[0][:, :, None, :], K, axis=2)
    var = np.full((H, W, K), o.init_variance)
    fg = np.zeros((T, H, W), bool)
    for t in range(T):
        for i in range(H):
            for j in range(W):
                w[i, j], mu[i, j], var[i, j], fg[t, i, j] = ref_step(w[i, j], mu[i, j], var[i, j], f[t, i, j], t, o)
    if o.cleanup == "median3":
        fg = ref_median3(fg)
    return (w, mu, var), fg


def _video(seed=0, T=20, H=6, W=5):
    """Pixels that stay near their colour, jump to a far colour (a person passing), come back, or turn
    darker by a factor in [0.4, 1] (a shadow); with a person in the first frame at some pixels."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(70, 200, (H, W, 3))
    person = np.clip(base + rng.choice([-1.0, 1.0], (H, W, 3)) * rng.uniform(60, 100, (H, W, 3)), 0, 255)
    frames = []
    for t in range(T):
        event = rng.integers(0, 4, (H, W))
        if t < 3:
            event = np.where(rng.random((H, W)) < 0.3, 1, 0)
        shade = rng.uniform(0.4, 1.0, (H, W, 1))
        frame = np.where((event == 1)[..., None], person, np.where((event == 3)[..., None], base * shade, base))
        frames.append(np.clip(frame + rng.uniform(-2, 2, frame.shape), 0, 255))
    return np.round(np.stack(frames)).astype(np.uint8)


OPTIONS = {
    "real_video": (REAL, BackgroundStructure.real_video().n_components),
    "tr_with_warmup": (BackgroundOptions(warmup=True), 3),
    "tr_with_shadows": (BackgroundOptions(shadow_tau=0.5, alpha=0.1), 3),
    "over_weight_ceiling_median": (BackgroundOptions(rho="alpha_over_weight", max_variance=300.0, init_weight=0.1,
                                                     init_variance=100.0,
                                                     cleanup="median3", match_sigmas=3.0), 4),
    "background_match": (BackgroundOptions(decision="background_match", decision_sigmas=3.5, background_ratio=0.8,
                                           alpha=0.1, init_variance=100.0), 3),
}


@pytest.mark.parametrize("name", sorted(OPTIONS))
def test_rules_against_reference(name):
    options, K = OPTIONS[name]
    frames = _video()
    (w, mu, var), want = ref_video(frames, options, K)
    state, got = run_background(frames, structure=BackgroundStructure(n_components=K), options=options, threads=1)
    np.testing.assert_allclose(np.asarray(state.weights, np.float64), w, rtol=2e-4, atol=2e-5)
    np.testing.assert_allclose(np.asarray(state.means, np.float64), mu, rtol=2e-4, atol=2e-3)
    np.testing.assert_allclose(np.asarray(state.variances, np.float64), var, rtol=2e-4, atol=2e-3)
    np.testing.assert_array_equal(np.asarray(got), want)
    assert want.any() and not want.all()


def test_shadow_rule_fires_and_median_cleans():
    frames = _video(seed=1)
    plain = REAL._replace(shadow_tau=None, cleanup="none")
    _, fg_plain = run_background(frames, structure=BackgroundStructure(5), options=plain, threads=1)
    _, fg_shadow = run_background(frames, structure=BackgroundStructure(5), options=plain._replace(shadow_tau=0.5),
                                  threads=1)
    fg_plain, fg_shadow = np.asarray(fg_plain), np.asarray(fg_shadow)
    assert (fg_shadow <= fg_plain).all() and fg_shadow.sum() < fg_plain.sum()  # shadows only remove foreground
    np.testing.assert_array_equal(np.asarray(run_background(frames, structure=BackgroundStructure(5),
        options=plain._replace(cleanup="median3"), threads=1)[1]), ref_median3(fg_plain))


def test_continuing_and_update_keep_the_warmup_clock():
    frames = _video(seed=2)
    structure = BackgroundStructure(5)
    state, whole = run_background(frames, structure=structure, options=REAL)
    first, fg1 = run_background(frames[:12], structure=structure, options=REAL)
    last, fg2 = run_background(frames[12:], structure=structure, options=REAL, initial_state=first, start_frame=12)
    np.testing.assert_array_equal(np.concatenate([fg1, fg2]), whole)  # the median is per frame
    np.testing.assert_allclose(last.means, state.means, rtol=1e-6)
    restarted = run_background(frames[12:], structure=structure, options=REAL, initial_state=first)[0]
    assert not np.allclose(restarted.means, state.means)  # the clock matters
    s = init_background(frames[0], structure, REAL)
    for t in range(len(frames)):
        s, fg = update(s, frames[t], options=REAL, frame_index=t)
        np.testing.assert_array_equal(np.asarray(fg), np.asarray(whole[t]), err_msg=f"frame {t}")


def test_threads_do_not_change_the_cleaned_masks():
    frames = _video(seed=3, H=9)
    a = run_background(frames, structure=BackgroundStructure(5), options=REAL, threads=1)[1]
    b = run_background(frames, structure=BackgroundStructure(5), options=REAL, threads=3)[1]
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def _one_pixel_state(mu, var=20.0):
    """A 1 x 1 state with one background component at `mu` (weight 1)."""
    K = 3
    w = np.zeros((1, 1, K), np.float32)
    w[..., 0] = 1.0
    means = np.broadcast_to(np.asarray(mu, np.float32), (1, 1, K, 3)).copy()
    return BackgroundState(w, means, np.full((1, 1, K), var, np.float32))


colour = st.lists(st.floats(20.0, 200.0), min_size=3, max_size=3)


@settings(max_examples=25, deadline=None)
@given(mu=colour, gain=st.floats(1.0, 1.3), offset=st.lists(st.floats(-30.0, 30.0), min_size=3, max_size=3))
def test_shadow_never_brighter_than_the_mode(mu, gain, offset):
    """A pixel brighter than its mode along it (x . mu >= |mu|^2) is never called shadow: the shadow
    rule leaves its label as without it."""
    mu = np.asarray(mu)
    x = np.clip(gain * mu + np.asarray(offset), 0, 255)
    if x @ mu < mu @ mu * (1 + 1e-4):
        x = np.clip(x + 0.01 * mu + 1.0, 0, 255)
    if x @ mu < mu @ mu * (1 + 1e-4):
        return
    frame = x.astype(np.float32)[None, None]
    options = REAL._replace(warmup=False)
    _, fg_with = update(_one_pixel_state(mu), frame, options=options)
    _, fg_without = update(_one_pixel_state(mu), frame, options=options._replace(shadow_tau=None))
    assert bool(fg_with[0, 0]) == bool(fg_without[0, 0])


@settings(max_examples=25, deadline=None)
@given(mu=colour, a=st.floats(0.55, 0.95))
def test_a_darker_copy_of_the_mode_is_shadow(mu, a):
    mu = np.asarray(mu)
    frame = (a * mu).astype(np.float32)[None, None]
    options = REAL._replace(warmup=False, shadow_tau=0.5)
    _, fg = update(_one_pixel_state(mu), frame, options=options)
    _, fg_plain = update(_one_pixel_state(mu), frame, options=options._replace(shadow_tau=None))
    assert not bool(fg[0, 0])
    if np.sum(((1 - a) * mu) ** 2) > 16 * 75:  # far beyond the match: foreground without the rule
        assert bool(fg_plain[0, 0])


@settings(max_examples=20, deadline=None)
@given(alpha=st.floats(1e-4, 0.5), t=st.integers(0, 3000))
def test_warmup_rate_is_max_of_alpha_and_running_mean(alpha, t):
    """A still pixel's weight after a jump to a far colour at frame t learns the new component at
    rate max(alpha, 1 / (t + 1)) (seen through rho = alpha: its mean moves by that fraction)."""
    from hog_jax.video._src.background import check_options
    from hog_jax.video._src.background_kernel import learning_rate

    o = check_options(BackgroundOptions(alpha=alpha, warmup=True))
    assert float(learning_rate(o, t)) == pytest.approx(max(alpha, 1.0 / (t + 1)), rel=1e-6)
    assert float(learning_rate(check_options(BackgroundOptions(alpha=alpha)), t)) == pytest.approx(alpha, rel=1e-6)


BAD = {
    "shadow_tau: must be < 1": dict(shadow_tau=1.0),
    "shadow_tau: must be > 0": dict(shadow_tau=0.0),
    "max_variance: expected a real >= init_variance": dict(max_variance=10.0),
    "warmup: expected a bool": dict(warmup=1),
    "cleanup: expected one of": dict(cleanup="open"),
    "decision_sigmas: must be > 0": dict(decision_sigmas=0.0),
    "rho: expected one of": dict(rho="x"),
}


@pytest.mark.parametrize("message", sorted(BAD))
def test_bad_options_name_the_field(message):
    with pytest.raises(ValueError, match=message):
        run_background(np.zeros((2, 2, 2, 3), np.uint8), options=BackgroundOptions(**BAD[message]))


def test_bad_clock_names_the_argument():
    frames = np.zeros((2, 2, 2, 3), np.uint8)
    with pytest.raises(ValueError, match="start_frame"):
        run_background(frames, start_frame=-1)
    with pytest.raises(ValueError, match="frame_index"):
        update(init_background(frames[0]), frames[0], frame_index=-2)


# --------------------------------------------------------------------------------- the loader
def _write_sequence(folder, first: int, labels: list, temporal=None, roi=None):
    (folder / "input").mkdir(parents=True)
    (folder / "groundtruth").mkdir()
    H, W = labels[0].shape
    for i, lab in enumerate(labels):
        frame = np.full((H, W, 3), (40 + 20 * i, 100, 200), np.uint8)  # RGB
        cv2.imwrite(str(folder / "input" / f"in{first + i:06d}.jpg"), frame[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 100])
        cv2.imwrite(str(folder / "groundtruth" / f"gt{first + i:06d}.png"), lab)
    if temporal is not None:
        (folder / "temporalROI.txt").write_text(f"{temporal[0]} {temporal[1]}\n")
    if roi is not None:
        cv2.imwrite(str(folder / "ROI.bmp"), roi.astype(np.uint8) * 255)


def test_loader_on_a_cdnet_shaped_folder(tmp_path):
    lab = np.array([[0, 50, 85], [170, 255, 255]], np.uint8)
    roi = np.array([[1, 1, 1], [1, 1, 0]], bool)
    _write_sequence(tmp_path / "cdnet_highway", 1, [np.full((2, 3), 85, np.uint8), lab, lab, lab], (2, 4), roi)
    got = list(rs.iter_sequence(tmp_path, "cdnet_highway", step=2))
    assert [g[0] for g in got] == [1, 2, 3, 4]
    assert got[0][1].shape == (2, 3, 3) and got[0][1].dtype == np.uint8
    np.testing.assert_allclose(got[1][1][0, 0], (60, 100, 200), atol=3)  # RGB order
    assert got[0][2] is None and got[2][2] is None  # before the temporal ROI; step 2 skips frame 3
    want = np.array([[0, 0, -1], [-1, 1, -1]], np.int8)  # 50 is background, 85 / 170 / outside the ROI ignored
    np.testing.assert_array_equal(got[1][2], want)
    np.testing.assert_array_equal(got[3][2], want)
    assert got[1][2].dtype == np.int8
    info = rs.sequence_info(tmp_path, "cdnet_highway")
    assert info.temporal_roi == (2, 4) and info.evaluated().tolist() == [False, True, True, True]
    assert len(list(rs.iter_sequence(tmp_path, "cdnet_highway", stop=2))) == 2


def test_loader_on_an_sbi_shaped_folder(tmp_path):
    zero_one = np.array([[0, 1], [1, 0]], np.uint8)  # one mask coded 0 / 1
    lab = np.array([[255, 170], [0, 0]], np.uint8)
    _write_sequence(tmp_path / "sbi_indoor" / "Board", 0, [zero_one, lab])
    got = list(rs.iter_sequence(tmp_path, "sbi_board"))
    assert [g[0] for g in got] == [0, 1]
    np.testing.assert_array_equal(got[0][2], [[0, 1], [1, 0]])
    np.testing.assert_array_equal(got[1][2], [[1, -1], [0, 0]])
    with pytest.raises(ValueError, match="name"):
        list(rs.iter_sequence(tmp_path, "nothing"))
    with pytest.raises(ValueError, match="step"):
        list(rs.iter_sequence(tmp_path, "sbi_board", step=0))
    with pytest.raises(ValueError, match="labels"):
        rs.read_truth(np.array([[7, 255]], np.uint8))
    with pytest.raises(FileNotFoundError):
        rs.sequence_info(tmp_path, "sbi_candela")


def test_f1_counts_by_hand():
    truth = np.array([[1, 1, 0, 0], [-1, 1, 0, -1]], np.int8)
    pred = np.array([[1, 0, 1, 0], [1, 1, 0, 0]], bool)
    # TP (0,0) (1,1) = 2; FP (0,2) = 1; FN (0,1) = 1; TN (0,3) (1,2) = 2; (1,0) (1,3) ignored
    c = rs.f1_counts(pred, truth)
    assert c == rs.Counts(2, 1, 1, 2)
    assert c.precision == pytest.approx(2 / 3) and c.recall == pytest.approx(2 / 3) and c.f1 == pytest.approx(2 / 3)
    assert (c + c) == rs.Counts(4, 2, 2, 4)
    assert rs.Counts().f1 == 0.0 and rs.Counts(tn=5).precision == 0.0
    with pytest.raises(ValueError, match="pred: shape"):
        rs.f1_counts(pred[0], truth)
    with pytest.raises(ValueError, match="truth"):
        rs.f1_counts(pred, truth * 2)
