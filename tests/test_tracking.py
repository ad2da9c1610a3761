"""hog_jax.stereo, .blobs, .tracking, .tracks: moments against NumPy and OpenCV, stereo against OpenCV's
camera matrices, the α-β tracker against a float64 NumPy filter, on a constant-velocity target, a
merge-and-split, a target that disappears, and the stereo hand-minus-face pipeline.

Every tracked batch is (4, T, H, W) with K blob slots and M = 3 targets, so the tracker compiles once.
"""
import chex
import cv2
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from hog_jax.video import connected_blobs, ellipse_axes, mask_ellipse
from hog_jax.video import StereoCamera, camera_matrices, project, triangulate
from hog_jax.video import TrackOptions, alpha_beta_gains, track
from hog_jax.video import FACE, HAND, HandFaceOptions, hand_face_positions

PROP = settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
T, H, W, K, R = 24, 48, 64, 4, 5
ROWS, COLS = np.mgrid[:H, :W]
ALPHA, BETA = 0.75, 0.5


def disc(centre, radius=R):
    return (COLS - centre[0]) ** 2 + (ROWS - centre[1]) ** 2 <= radius**2


def centroid_cv(mask):
    m = cv2.moments(mask.astype(np.uint8), binaryImage=True)
    return np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]])


def alpha_beta_numpy(z, alpha, beta, dt=1.0):
    """Reference filter in float64: initialised at z[0] with zero velocity."""
    x, v = np.array(z[0], float), np.zeros(2)
    xs, vs = [x.copy()], [v.copy()]
    for zt in z[1:]:
        pred = x + v * dt
        r = zt - pred
        x, v = pred + alpha * r, v + beta * r / dt
        xs.append(x.copy())
        vs.append(v.copy())
    return np.array(xs), np.array(vs)


t = np.arange(T, dtype=float)
CROSS_A = np.stack([6 + 2.0 * t, 20 + 0.1 * t], -1)  # 0: two discs that cross (merged ~ frames 11-15) and part
CROSS_B = np.stack([58 - 2.0 * t, 26 - 0.1 * t], -1)
LINE = np.stack([8 + 2.0 * t, 10 + 1.0 * t], -1)  # 1: one disc at constant velocity, gone from frame GONE on
# (integer centres: the rasterised disc is symmetric about them, its centroid is exact)
GONE = 16
FACE_XY = np.array([36.0, 14.0])  # 2: a "hand" that comes to rest overlapping a "face" (r = 9), as when drinking
_s = np.clip((t - 2) / 10, 0, 1)
REACH = np.array([12.0, 40.0]) + (3 * _s**2 - 2 * _s**3)[:, None] * np.array([16.0, -14.0])
BACK = 16  # 3: a disc that leaves for 8 frames (lost) and comes back elsewhere (acquired again)


@pytest.fixture(scope="module")
def videos():
    """Four videos in one batch (one compiled tracker for the module; the pipeline's batch is also 4)."""
    masks = np.zeros((4, T, H, W), bool)
    for i in range(T):
        masks[0, i] = disc(CROSS_A[i]) | disc(CROSS_B[i])
        masks[1, i] = disc(LINE[i]) if i < GONE else False
        masks[2, i] = disc(FACE_XY, 9) | disc(REACH[i])
        masks[3, i] = disc([10 + 1.5 * i, 10]) if i < 8 else disc([40, 30]) if i >= BACK else False
    blobs = connected_blobs(masks, max_blobs=K)
    tracks = track(blobs, ("left", "right", "top"), TrackOptions(alpha=ALPHA, beta=BETA, n_lost=5, min_init=1))
    return masks, blobs, host(blobs), host(tracks)


def host(tree):
    """NumPy copies: indexing jax arrays would compile a small program per distinct slice."""
    return jax.tree.map(np.asarray, tree)


def test_gains_follow_kalatas_relations():
    for lam in (0.1, 1.0, 7.0):
        a, b = alpha_beta_gains(lam)
        assert 0 < a < 1 and 0 < b < 4 - 2 * a
        assert lam**2 == pytest.approx(b**2 / (1 - a))  # Kalata 1984: Λ² = β² / (1 - α)
        assert b == pytest.approx(2 * (2 - a) - 4 * np.sqrt(1 - a))
    assert alpha_beta_gains(1.0) == pytest.approx((ALPHA, BETA))  # the documented defaults


def kalata_decimal(lam: float) -> tuple[float, float]:
    """Kalata's closed form as printed, in 80-digit decimal arithmetic: its cancellation costs at most
    the ~35 digits that Λ up to 1e8 (Λ² ~ 1e16 against a result ~1) take away, far from 80."""
    from decimal import Decimal, localcontext

    with localcontext() as ctx:
        ctx.prec = 80
        x = Decimal(lam)  # exact: every float is a finite decimal
        root = (x * x + 8 * x).sqrt()
        return float((-x * x - 8 * x + (x + 4) * root) / 8), float((x * x + 4 * x - x * root) / 4)


TRACKING_INDEX = st.floats(min_value=0.0, max_value=1e8, exclude_min=True)


@settings(max_examples=300, deadline=None)
@given(lam=TRACKING_INDEX)
def test_gains_are_kalatas_to_float64_precision_and_stable_for_every_tracking_index(lam):
    a, b = alpha_beta_gains(lam)
    assert 0 < a < 1 and 0 < b < 2 * (2 - a)  # the α-β stability region
    if lam >= 1e-300:  # normal β (a subnormal Λ gives a subnormal β ≈ Λ of few digits)
        assert (a, b) == pytest.approx(kalata_decimal(lam), rel=2e-15)


@settings(max_examples=300, deadline=None)
@given(lam=TRACKING_INDEX, factor=st.floats(1.5, 1e6))
def test_gains_grow_with_the_tracking_index(lam, factor):
    """For tracking indices at least 1.5 times apart: nearer ones may differ by a rounding of the last
    bit either way, and up to 1e8 α comes within a few units in the last place of 1."""
    assume(lam * factor <= 1e8)
    (a, b), (a2, b2) = alpha_beta_gains(lam), alpha_beta_gains(lam * factor)
    assert a < a2 and b < b2


def test_gains_at_large_tracking_indices_and_beyond_the_valid_range():
    a, b = alpha_beta_gains(1e7)
    assert a == pytest.approx(1 - 4e-14, abs=1e-16) and b == pytest.approx(2 - 8e-7, rel=1e-12)  # 1 - 4/Λ², 2 - 8/Λ
    for bad in (1e9, 0.0, -1.0, float("inf"), float("nan")):
        with pytest.raises(ValueError, match="^tracking_index: "):
            alpha_beta_gains(bad)


def test_tracks_are_shaped(videos):
    _, blobs, _, tr = videos
    chex.assert_shape([tr.position, tr.velocity], (4, T, 3, 2))
    chex.assert_shape(tr.cov, (4, T, 3, 2, 2))
    chex.assert_shape([tr.observed, tr.merged, tr.lost, tr.area, tr.blob], (4, T, 3))
    chex.assert_tree_all_finite((tr.position, tr.velocity, tr.cov, tr.area))
    chex.assert_shape(blobs.labels, (4, T, H, W))


def test_alpha_beta_update_matches_float64_numpy(videos):
    """Unmerged frames: the measurement is the blob's centroid (here cv2.moments) and the state follows
    the α-β recursion exactly, velocity included."""
    masks, _, _, tr = videos
    z = np.array([centroid_cv(masks[1, i]) for i in range(GONE)])
    xs, vs = alpha_beta_numpy(z, ALPHA, BETA)
    np.testing.assert_allclose(tr.position[1, :GONE, 0], xs, atol=2e-4)
    np.testing.assert_allclose(tr.velocity[1, :GONE, 0], vs, atol=2e-4)
    za = np.array([centroid_cv(disc(CROSS_A[i])) for i in range(9)])  # before the discs meet
    np.testing.assert_allclose(tr.position[0, :9, 0], alpha_beta_numpy(za, ALPHA, BETA)[0], atol=2e-4)


def test_constant_velocity_target_is_tracked_with_vanishing_error(videos):
    _, _, _, tr = videos
    err = np.linalg.norm(tr.position[1, :GONE, 0] - LINE[:GONE], axis=-1)
    assert err[1] > 0.5  # the filter starts with zero velocity ...
    assert err[12:].max() < 2e-3 and np.all(np.diff(err[4:]) < 0.01)  # ... and converges
    np.testing.assert_allclose(tr.velocity[1, 12:GONE, 0], np.broadcast_to([2.0, 1.0], (GONE - 12, 2)),
                               atol=2e-3)
    assert tr.observed[1, :GONE, 0].all() and not tr.lost[1, :GONE, 0].any()
    assert tr.lost[1, :, 1].all() and not tr.observed[1, :, 1].any()  # nothing to acquire


def test_merge_and_split_keeps_identities(videos):
    masks, _, blobs, tr = videos
    merged = tr.merged[0]
    one_blob = blobs.valid[0].sum(-1) == 1
    assert one_blob.sum() >= 4 and np.array_equal(merged[:, 0], one_blob) and np.array_equal(merged[:, 1], one_blob)
    pos = tr.position[0]
    err_a = np.linalg.norm(pos[:, 0] - CROSS_A, axis=-1)
    err_b = np.linalg.norm(pos[:, 1] - CROSS_B, axis=-1)
    # the prediction separates them; where one disc all but covers the other it is concealed, and its
    # damped velocity (merge_damping 0.5) lags by up to 1 px a frame
    assert err_a[one_blob].max() < 2.0 and err_b[one_blob].max() < 2.0
    after = np.arange(T) > np.flatnonzero(one_blob).max()
    assert after.sum() >= 6 and err_a[after].max() < 0.5 and err_b[after].max() < 0.5  # no swap after the split
    observed = tr.observed[0, :, :2]
    assert observed[~one_blob].all() and observed[one_blob].sum() >= 6  # heavy overlap: a frame may coast


def test_disappearing_target_coasts_then_is_lost(videos):
    _, _, _, tr = videos
    pos, observed, lost = tr.position[1, :, 0], tr.observed[1, :, 0], tr.lost[1, :, 0]
    assert not observed[GONE:].any()
    coast = slice(GONE, GONE + 4)  # n_lost = 5: frames GONE .. GONE + 3 coast, GONE + 4 on it is lost
    assert not lost[coast].any() and lost[GONE + 4:].all()
    assert np.linalg.norm(pos[coast] - LINE[coast], axis=-1).max() < 0.3  # the prediction, on the true line
    np.testing.assert_array_equal(tr.velocity[1, GONE + 4:, 0], 0.0)  # lost: stops
    assert np.all(pos[GONE + 4:] == pos[GONE + 4])


def test_hand_resting_on_the_face_is_located_by_its_visible_part(videos):
    """The hand blob overlaps the face blob for half the video: the hand's position is where its visible
    part (what the face's ellipse does not explain) fits, not the centroid of its window."""
    _, _, blobs, tr = videos
    hand, face = tr.position[2, :, 0], tr.position[2, :, 1]  # "left": the hand starts left of the face
    merged = tr.merged[2, :, 0]
    assert merged.sum() >= 10 and (blobs.valid[2].sum(-1)[merged] == 1).all()
    assert np.linalg.norm(hand - REACH, axis=-1).max() < 1.5 and np.linalg.norm(face - FACE_XY, axis=-1).max() < 0.5
    assert tr.observed[2, :, :2].all()  # enough of the hand shows: a measurement, not a coasting prediction
    held = tr.cov[2, np.argmax(merged) - 1, 0]  # the ellipse before the merge
    np.testing.assert_allclose(tr.cov[2, merged, 0], np.broadcast_to(held, (merged.sum(), 2, 2)))


def test_a_lost_target_is_acquired_again(videos):
    _, _, _, tr = videos
    lost, observed = tr.lost[3, :, 0], tr.observed[3, :, 0]
    assert not lost[:8].any() and lost[12:BACK].all() and not observed[8:BACK].any()
    assert observed[BACK:].all() and not lost[BACK:].any()
    np.testing.assert_allclose(tr.position[3, BACK:, 0], np.broadcast_to([40.0, 30.0], (T - BACK, 2)), atol=1e-4)


def test_mask_ellipse_matches_numpy_and_opencv():
    rng = np.random.default_rng(0)
    masks = np.zeros((3, 24, 32), bool)
    rows, cols = np.mgrid[:24, :32]
    u, v = cols - 15.3, rows - 11.6  # pixel centres inside an ellipse: semi-axes 9 and 4, major axis at 30 deg
    c30, s30 = np.cos(np.deg2rad(30)), np.sin(np.deg2rad(30))
    masks[0] = ((c30 * u + s30 * v) / 9) ** 2 + ((-s30 * u + c30 * v) / 4) ** 2 <= 1
    masks[1] = rng.random((24, 32)) > 0.6  # scattered pixels: a whole-mask ellipse, not a component's
    weights = rng.random((3, 24, 32)).astype(np.float32)
    e = host(mask_ellipse(masks))
    ew = host(mask_ellipse(masks, weights))
    chex.assert_shape([e.centroid, ew.centroid], (3, 2))
    chex.assert_shape(e.cov, (3, 2, 2))
    for i in range(2):
        m = cv2.moments(masks[i].astype(np.uint8), binaryImage=True)
        np.testing.assert_allclose(e.centroid[i], [m["m10"] / m["m00"], m["m01"] / m["m00"]], rtol=1e-5)
        cv_cov = np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / m["m00"]
        np.testing.assert_allclose(e.cov[i], cv_cov, rtol=1e-4, atol=1e-4)
        w = masks[i] * weights[i].astype(np.float64)
        c = np.array([(w * cols).sum(), (w * rows).sum()]) / w.sum()
        d = np.stack([cols - c[0], rows - c[1]], -1)
        np.testing.assert_allclose(ew.centroid[i], c, rtol=1e-5)
        np.testing.assert_allclose(ew.cov[i], np.einsum("hw,hwi,hwj->ij", w, d, d) / w.sum(), rtol=1e-4,
                                   atol=1e-4)
    assert list(e.found) == [True, True, False]  # the empty mask: flagged, zeros, no NaN
    assert float(e.area[2]) == 0 and not e.centroid[2].any() and not e.cov[2].any()
    axes = host(ellipse_axes(e.cov[:1]))
    np.testing.assert_allclose(axes.semi_axes[0], [9, 4], atol=0.2)  # a filled ellipse: 2 sqrt(eig)
    assert float(axes.angle[0]) == pytest.approx(np.deg2rad(30), abs=0.03)


def test_connected_blobs_agree_with_opencv(monkeypatch):
    frame = np.zeros((24, 32), bool)
    frame[2:6, 2:12] = True  # 40 px
    frame[10:20, 20:25] = True  # 50 px
    frame[15:17, 3:5] = True  # 4 px
    frame[22, 30] = True  # 1 px: dropped by min_area
    masks = np.stack([frame, np.zeros_like(frame)])
    b = host(connected_blobs(masks, max_blobs=2, min_area=2))
    n, _, stats, centroids = cv2.connectedComponentsWithStats(frame.astype(np.uint8), connectivity=8)
    order = np.argsort(-stats[1:, cv2.CC_STAT_AREA])[:2] + 1
    np.testing.assert_allclose(b.area[0], stats[order, cv2.CC_STAT_AREA])
    np.testing.assert_allclose(b.centroid[0], centroids[order], atol=1e-5)
    cols, rows = np.arange(20, 25) - 22.0, np.arange(10, 20) - 14.5  # the 10 x 5 rectangle: separable moments
    np.testing.assert_allclose(b.cov[0, 0], np.diag([np.mean(cols**2), np.mean(rows**2)]), atol=1e-4)
    assert list(b.n_components) == [n - 1, 0] and not b.valid[1].any()
    assert b.labels[0].max() == 2 and (b.labels[0] == 1).sum() == 50
    monkeypatch.setattr("hog_jax.video._src.blobs._CHUNK_PIXELS", 24 * 32)  # one frame per OpenCV call: the same blobs
    chunked = host(connected_blobs(masks, max_blobs=2, min_area=2))
    for got, want in zip(chunked, b):
        np.testing.assert_array_equal(got, want)


def test_stereo_round_trip_opencv_matrices_and_invalid_disparity():
    cam = StereoCamera(525.0, 0.12, 640, 480)
    assert (cam.cx, cam.cy) == (319.5, 239.5)
    pts = np.random.default_rng(1).uniform([-0.5, -0.4, 0.6], [0.5, 0.4, 3.0], (20, 3))
    proj = project(cam, pts)
    back = triangulate(cam, proj.left, proj.right)
    np.testing.assert_allclose(back.xyz, pts, atol=1e-9)
    assert back.valid.all() and proj.in_front.all()
    P1, P2 = camera_matrices(cam)
    hom = np.hstack([pts, np.ones((20, 1))])
    for P, px in ((P1, proj.left), (P2, proj.right)):
        q = hom @ P.T
        np.testing.assert_allclose(q[:, :2] / q[:, 2:], px, atol=1e-9)
    X = cv2.triangulatePoints(P1, P2, proj.left.T.copy(), proj.right.T.copy())
    np.testing.assert_allclose((X[:3] / X[3]).T, pts, atol=1e-6)
    jitted = jax.jit(lambda p: triangulate(cam, *project(cam, p)[:2]))(jnp.asarray(pts, jnp.float32))
    np.testing.assert_allclose(np.asarray(jitted.xyz), pts, rtol=1e-4)
    left = np.array([[100.0, 50.0], [100.0, 50.0]])
    bad = triangulate(cam, left, np.array([[100.0, 50.0], [103.0, 50.0]]))  # disparity 0 and -3
    assert not bad.valid.any() and np.all(bad.xyz == 0)  # flagged, not clamped, not inf
    behind = project(cam, np.array([[0.0, 0.0, -1.0]]))
    assert not behind.in_front[0] and np.all(behind.left == 0)


def _stereo_scene(cam, shift, gone):
    """Labels (2 views, T, H, W) of a person with a fixed face, a hand moving at constant velocity in 3-D
    (shifted by `shift` m) with an object, the hand gone from frame `gone` on; the true 3-D hand, face."""
    face = np.array([0.0, -0.12, 1.0])
    hand = np.array([-0.15 + shift, 0.15, 1.1]) + np.array([0.012, -0.004, -0.006]) * t[:, None]
    labels = np.zeros((2, T, H, W), np.int8)
    labels[:, :, 12:, 16:48] = 1  # the person
    for i in range(T):
        for v, view in enumerate(("left", "right")):
            f, h = (getattr(project(cam, p), view) for p in (face, hand[i]))
            labels[v, i][disc(f, 7)] = 2
            if i < gone:
                labels[v, i][disc(h + [-8, 0], 3)] = 3  # a held object left of the hand
                labels[v, i][disc(h, 4)] = 2
    return labels, hand, face


def test_hand_face_positions_from_stereo_labels():
    cam = StereoCamera(50.0, 0.12, W, H)
    (first, hand, face), (second, hand2, _) = _stereo_scene(cam, 0.0, T - 7), _stereo_scene(cam, 0.02, T)
    left, right = np.stack([first[0], second[0]]), np.stack([first[1], second[1]])  # a batch of two videos
    # the hand starts within the face's horizontal extent, where the default side rules wait for it to
    # leave (test_side_rules_...): acquired here by the plain "left" rule, the merge being what is tested
    options = HandFaceOptions(init=("top", "left", "right"), max_blobs=K, min_area=2, n_objects=3,
                              tracking=TrackOptions(n_hidden=5, min_init=2))
    out = host(hand_face_positions(left, right, cam, options=options))
    chex.assert_shape(out.xy_left, (2, T, 2))
    chex.assert_shape(out.xyz, (2, T, 3))
    chex.assert_shape([out.found, out.found_3d, out.observed], (2, T))
    chex.assert_shape(out.skin_right.position, (2, T, 3, 2))
    err = np.linalg.norm(out.xy_left - (project(cam, np.stack([hand, hand2])).left - project(cam, face).left), axis=-1)
    merged = out.skin_left.merged[..., HAND]
    alone, there = np.arange(T) >= 4, np.stack([np.arange(T) < T - 7, np.ones(T, bool)])  # converged; hand seen
    assert merged[there].sum() >= 10 and not merged[:, :4].any()  # the hand touches the face from frame ~9 on
    assert err[alone & there & ~merged].max() < 0.3 and err[there & merged].max() < 1.0  # pixels
    err3 = np.abs(out.xyz - (np.stack([hand, hand2]) - face))[alone & there]  # metres; 1 px of disparity is ~20 cm
    assert err3[:, :2].max() < 0.02 and err3[:, 2].max() < 0.05  # (X, Y scale with the depth)
    assert out.found[there].all() and out.found_3d[there].all()
    assert not out.found[0, T - 2:].any() and not out.xy_left[0, T - 2:].any()  # the hand is lost: not found
    assert not out.skin_left.lost[..., FACE].any()
    beside = out.skin_left.position[:, 5, HAND] - out.objects_left.position[:, 5, 0]
    assert np.linalg.norm(beside - [8.0, 0.0], axis=-1).max() < 0.5  # the held object is tracked, left of the hand
    with pytest.raises(ValueError, match="right"):
        hand_face_positions(left, right[..., :-1], cam)
    with pytest.raises(ValueError, match="camera"):
        hand_face_positions(left, right, StereoCamera(50.0, 0.12, W + 1, H))


# ------------------------------------------------------------------------------- properties
@PROP
@given(arrays(bool, (3, 24, 32)))
def test_mask_ellipse_any_mask(masks):
    e = host(mask_ellipse(masks))
    chex.assert_tree_all_finite(e)
    np.testing.assert_array_equal(e.found, masks.any(axis=(1, 2)))
    np.testing.assert_allclose(e.area, masks.sum(axis=(1, 2)))


@PROP
@given(*[arrays(np.float64, (5, 2), elements=st.floats(-1e4, 1e4))] * 2)
def test_triangulate_any_pixels(left, right):
    out = triangulate(StereoCamera(300.0, 0.1, 320, 240), left, right)
    assert np.all(np.isfinite(out.xyz)) and out.xyz.shape == (5, 3)
    d = left[:, 0] - right[:, 0]
    assert np.all(d[out.valid] > 0) and np.all(out.valid[d > 1e-250])  # tinier ones may overflow: flagged
    assert np.all(out.xyz[~out.valid] == 0) and np.all(out.xyz[out.valid, 2] > 0)


@PROP
@given(st.integers(0, 2**31 - 1))
def test_track_any_blob_video(seed):
    masks = np.random.default_rng(seed).random((4, T, H, W)) > 0.97  # speckle: many blobs, merges, losses
    tr = host(track(connected_blobs(masks, max_blobs=K), ("top", "largest", "bottom")))
    chex.assert_tree_all_finite(tr)
    assert np.all(tr.observed <= ~tr.lost)


BAD_TRACK = [({"alpha": 0.0}, "alpha"), ({"alpha": 1.5}, "alpha"), ({"beta": 2.6}, "beta"), ({"gate": -1.0}, "gate"),
             ({"n_lost": 0}, "n_lost"), ({"init": ("top", "middle")}, "init"), ({"min_init": K + 1}, "min_init"),
             ({"dt": float("nan")}, "dt"), ({"init": ()}, "init")]


@settings(max_examples=10, deadline=None)
@given(st.sampled_from(BAD_TRACK))
def test_bad_tracker_options_name_the_argument(videos, case):
    kwargs, name = case
    with pytest.raises(ValueError, match=name):
        options = {k: v for k, v in kwargs.items() if k != "init"}
        track(videos[1], kwargs.get("init", ("top", "left", "right")), TrackOptions(**options))


@settings(max_examples=10, deadline=None)
@given(st.sampled_from([
    (lambda: mask_ellipse(np.zeros((4, 4), bool)), "masks"),
    (lambda: mask_ellipse(np.full((1, 4, 4), 2)), "masks"),
    (lambda: mask_ellipse(np.ones((1, 4, 4), bool), -np.ones((1, 4, 4))), "weights"),
    (lambda: connected_blobs(np.ones((1, 4, 4), bool), max_blobs=0), "max_blobs"),
    (lambda: connected_blobs(np.ones((4, 4), bool)), "masks"),
    (lambda: track("blobs"), "blobs"),
    (lambda: StereoCamera(0.0, 0.1, 8, 8), "focal_px"),
    (lambda: StereoCamera(10.0, -0.1, 8, 8), "baseline_m"),
    (lambda: triangulate(StereoCamera(10.0, 0.1, 8, 8), np.zeros((3, 2)), np.zeros((2, 2))), "right_px"),
    (lambda: triangulate(StereoCamera(10.0, 0.1, 8, 8), np.full((1, 2), np.nan), np.zeros((1, 2))), "left_px"),
    (lambda: project(StereoCamera(10.0, 0.1, 8, 8), np.zeros((2, 2))), "points"),
]))
def test_bad_inputs_name_the_argument(case):
    call, name = case
    with pytest.raises(ValueError, match=name):
        call()


def test_side_rules_wait_for_the_hand_beyond_the_face_s_left():
    """While the right hand is out of view, the neck shows as a blob just below the face (left of its
    centre) and the other arm right of it: "left" takes the neck and the hand finds every target taken
    when it appears; "left_of_first" waits for a blob beyond the face's left extent and takes the hand
    (the imitation loop's lost 3-D hand)."""
    masks = np.zeros((4, T, H, W), bool)
    hand = np.stack([22 - 0.5 * t, 36 - 0.5 * t], -1)
    for i in range(T):
        masks[:, i] = disc([32, 8], 4) | disc([30, 16], 2) | disc([50, 34], 3) | (disc(hand[i], 3) if i >= 8 else False)
    blobs = connected_blobs(masks, max_blobs=K)
    options = TrackOptions(alpha=ALPHA, beta=BETA, min_init=3)
    by_side = host(track(blobs, ("top", "left_of_first", "right_of_first"), options))
    leftmost = host(track(blobs, ("top", "left", "right"), options))
    assert by_side.lost[0, :8, 1].all() and not by_side.lost[0, 8:, 1].any()
    np.testing.assert_allclose(by_side.position[0, 12:, 1], hand[12:], atol=1.0)
    assert not by_side.lost[0, :, 2].any() and (by_side.position[0, :, 2, 0] > 32).all()
    assert np.linalg.norm(leftmost.position[0, 12:, 1] - hand[12:], axis=-1).min() > 10  # the failure it fixes
    with pytest.raises(ValueError, match=r"init\[0\]"):
        track(blobs, ("left_of_first", "top"))


def test_a_coasting_track_takes_the_hand_that_reappears_beyond_its_gate():
    """A hand rising from below the table shows first as a few pixels, is missed for a frame, then shows
    whole 13 px away: the track acquired on the few pixels (no velocity, a small ellipse) must take it
    then (its gate grows with the frames since its last measurement), not coast on the few pixels'
    place until lost (the imitation loop's hand frozen beside the true one)."""
    masks = np.zeros((4, T, H, W), bool)
    hand = np.stack([22.0 + np.maximum(t - 8, 0), np.full(T, 30.0)], -1)  # whole from frame 8, moving right
    for i in range(T):
        masks[:, i] = disc([36, 14], 6) | disc([54, 36], 3)  # the face and the other hand
        masks[:, i] |= disc([14, 40], 1) if i == 6 else disc(hand[i], 3) if i >= 8 else False
    blobs = connected_blobs(masks, max_blobs=K)
    options = TrackOptions(alpha=ALPHA, beta=BETA, min_init=3)
    tr = host(track(blobs, ("top", "left_of_first", "right_of_first"), options))
    assert tr.observed[0, 6, 1] and not tr.observed[0, 7, 1] and tr.blob[0, 6, 1] >= 0  # acquired on the few pixels
    np.testing.assert_allclose(tr.position[0, 6, 1], [14.0, 40.0], atol=1e-4)
    assert tr.observed[0, 8:, 1].all() and not tr.lost[0, 6:, 1].any()
    np.testing.assert_allclose(tr.position[0, 8, 1], hand[8], atol=1e-4)  # taken as it reappears
    assert np.linalg.norm(tr.position[0, 8:, 1] - hand[8:], axis=-1).max() < 1.5
    np.testing.assert_allclose(tr.position[0, 6:, 0], np.broadcast_to([36.0, 14.0], (T - 6, 2)), atol=1e-4)  # face


def test_a_lost_hand_is_not_retaken_from_the_other_arm():
    """The right hand goes out of view (behind an object) and is lost while the other arm shows as two
    blobs right of the face, one of them taken by the other hand's target: the lost right hand must not
    take the free one, the free blob nearest its stale position (the imitation loop's hand read on the other
    arm at a recording's end), and takes the hand when it reappears on its side."""
    masks = np.zeros((4, T, H, W), bool)
    hand = np.array([8.0, 30.0])
    for i in range(T):  # the other arm beyond the coasting hand's gate
        masks[:, i] = disc([32, 8], 4) | disc([50, 36], 3) | disc([58, 42], 2)  # face; the other hand, forearm
        masks[:, i] |= disc(hand, 3) if i < 6 or i >= 18 else False
    blobs = connected_blobs(masks, max_blobs=K)
    tr = host(track(blobs, ("top", "left_of_first", "right_of_first"), TrackOptions(alpha=ALPHA, beta=BETA, min_init=3)))
    assert tr.observed[0, :6, 1].all() and tr.lost[0, 12:18, 1].all()
    assert (tr.blob[0, 6:18, 1] == -1).all()
    assert tr.observed[0, 18:, 1].all()
    np.testing.assert_allclose(tr.position[0, 18:, 1], np.broadcast_to(hand, (T - 18, 2)), atol=1e-3)
    assert (tr.position[0, :, 2, 0] > 45).all()
