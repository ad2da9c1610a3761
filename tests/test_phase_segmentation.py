"""hog_jax.phase_segmentation (LfD 2009 §III-B, eqs. 1-4) against float64 NumPy / SciPy, on a
synthetic scene whose object is known: a textured patch carried by the 'hand' over a static
textured background, seen by a rectified pair in which the object is nearer than the background."""
import jax
import numpy as np
import pytest
from scipy import ndimage
from scipy.ndimage import binary_erosion, gaussian_filter

from hog_jax.video._src.phase_segmentation import CHUNK
from hog_jax.video import (LogRatio, ObjectOptions, gradient_phase, object_masks, segment_objects, stereo_log_ratio,
    temporal_log_ratio)
from tests.xla_level import with_default_fusion_emitters

H, W, T = 48, 64, 4
HALF = (10, 11)
BLUR = 1.0
SIDE = 15
SIGMA = 20.0  # degrees: the hand's width in pixels, as the paper (module docstring)
STEP = np.array([1, 2])  # the hand's motion per frame (rows, columns)
DISPARITY_BG, DISPARITY_OBJ = 2, 6


def _scene():
    """left, right (T, H, W) float64 grey images, hand positions (T, 2) in each view, object mask
    (T, H, W) in the left view."""
    rng = np.random.default_rng(0)
    background = gaussian_filter(rng.uniform(0, 255, (H, W + 20)), 1.0)
    patch = gaussian_filter(rng.uniform(0, 255, (SIDE, SIDE)), 0.8)
    left, right, mask, hand_l, hand_r = [], [], [], [], []
    for t in range(T):
        centre = np.array([20, 24]) + t * STEP
        views = []
        for shift_bg, shift_obj in ((0, 0), (DISPARITY_BG, DISPARITY_OBJ)):
            img = background[:, shift_bg:shift_bg + W].copy()
            r, c = centre[0] - SIDE // 2, centre[1] - SIDE // 2 - shift_obj
            img[r:r + SIDE, c:c + SIDE] = patch
            views.append(img)
        m = np.zeros((H, W), bool)
        m[centre[0] - SIDE // 2:centre[0] + SIDE // 2 + 1, centre[1] - SIDE // 2:centre[1] + SIDE // 2 + 1] = True
        left.append(views[0]), right.append(views[1]), mask.append(m)
        hand_l.append(centre), hand_r.append(centre - np.array([0, DISPARITY_OBJ]))
    return np.stack(left), np.stack(right), np.stack(hand_l), np.stack(hand_r), np.stack(mask)


def _phase_ref(images, sigma):
    out = []
    for img in images:
        gy, gx = np.gradient(gaussian_filter(img, sigma, mode="reflect", truncate=4.0))
        out.append(np.mod(np.degrees(np.arctan2(gy, gx)) + 90.0, 180.0) - 90.0)
    return np.stack(out)


def _wrap(d):
    return np.mod(d + 90.0, 180.0) - 90.0


def _at(psi, centre, dr, dc):
    r, c = centre[0] + dr, centre[1] + dc
    return psi[r, c] if 0 <= r < psi.shape[0] and 0 <= c < psi.shape[1] else np.nan


def _temporal_ref(psi, hand):
    out = np.zeros((T - 1, 2 * HALF[0] + 1, 2 * HALF[1] + 1))
    for t in range(1, T):
        for i, dr in enumerate(range(-HALF[0], HALF[0] + 1)):
            for j, dc in enumerate(range(-HALF[1], HALF[1] + 1)):
                now = _at(psi[t], hand[t], dr, dc)
                fg = _wrap(now - _at(psi[t - 1], hand[t - 1], dr, dc))
                bg = _wrap(now - _at(psi[t - 1], hand[t], dr, dc))
                out[t - 1, i, j] = (bg ** 2 - fg ** 2) / (2 * SIGMA ** 2)
    return out


def _stereo_ref(psi_l, psi_r, hand_l, hand_r, offsets):
    out = np.zeros((T, 2 * HALF[0] + 1, 2 * HALF[1] + 1))
    for t in range(T):
        for i, dr in enumerate(range(-HALF[0], HALF[0] + 1)):
            for j, dc in enumerate(range(-HALF[1], HALF[1] + 1)):
                here = _at(psi_l[t], hand_l[t], dr, dc)
                fg = -_wrap(here - _at(psi_r[t], hand_r[t], dr, dc)) ** 2 / (2 * SIGMA ** 2)
                samples = np.array([-_wrap(here - _at(psi_r[t], hand_r[t], dr, dc + o)) ** 2 / (2 * SIGMA ** 2)
                                    for o in offsets])
                samples = samples[np.isfinite(samples)]
                out[t, i, j] = fg - np.log(np.mean(np.exp(samples)))
    return out


@pytest.fixture(scope="module")
def scene():
    left, right, hand_l, hand_r, mask = _scene()
    return (left, right, hand_l, hand_r, mask, np.asarray(gradient_phase(left, BLUR)),
            np.asarray(gradient_phase(right, BLUR)))


def _window_mask(mask, hand, erode: int = 0):
    """The object mask in the window around the hand, eroded by `erode` pixels (away from where the
    blur mixes the object's phase with the background's)."""
    if erode:
        mask = np.stack([binary_erosion(m, iterations=erode) for m in mask])
    return np.stack([np.pad(m, 20)[c[0] - HALF[0] + 20:c[0] + HALF[0] + 21, c[1] - HALF[1] + 20:c[1] + HALF[1] + 21]
                     for m, c in zip(mask, hand)])


def test_phase_matches_scipy(scene):
    left, _, _, _, _, psi, _ = scene
    diff = _wrap(psi - _phase_ref(left, BLUR))
    assert np.abs(diff).max() < 0.05  # degrees; float32 against float64
    assert psi.min() >= -90.0 and psi.max() < 90.0


def test_temporal_ratio_is_eq1_over_the_static_background(scene):
    _, _, hand_l, _, mask, psi, _ = scene
    got = temporal_log_ratio(psi, hand_l, HALF, SIGMA)
    want = _temporal_ref(psi.astype(np.float64), hand_l)
    assert np.asarray(got.valid).all()
    np.testing.assert_allclose(np.asarray(got.log_ratio), want, atol=2e-4)
    core, obj = _window_mask(mask, hand_l, erode=3)[1:], _window_mask(mask, hand_l)[1:]
    assert np.mean(want[core] > 0.01) > 0.8 and np.mean(want[~obj] < 0.01) > 0.6  # the object moves with the hand


def test_stereo_ratio_is_eq3_over_eq4(scene):
    _, _, hand_l, hand_r, mask, psi_l, psi_r = scene
    key = jax.random.key(3)
    got = stereo_log_ratio(key, psi_l, psi_r, hand_l, hand_r, HALF, SIGMA, max_offset=10, n_samples=50)
    offsets = np.asarray(jax.random.randint(key, (50,), -10, 11))
    want = _stereo_ref(psi_l.astype(np.float64), psi_r.astype(np.float64), hand_l, hand_r, offsets)
    np.testing.assert_allclose(np.asarray(got.log_ratio), want, atol=2e-4)
    core = _window_mask(mask, hand_l, erode=3)
    assert np.mean(want[core] > 0.01) > 0.8  # the object lies at the hand's disparity


def test_windows_outside_the_image_are_flagged_and_bad_input_named(scene):
    _, _, hand_l, _, _, psi, _ = scene
    corner = np.array([[0, 0], [1, 2]])
    res = temporal_log_ratio(psi[:2], corner, HALF, SIGMA)
    valid = np.asarray(res.valid)[0]
    assert not valid[:HALF[0]].any() and valid[HALF[0] + 1:, HALF[1] + 2:].all()
    assert np.isfinite(np.asarray(res.log_ratio)).all() and np.all(np.asarray(res.log_ratio)[0][~valid] == 0)
    with pytest.raises(ValueError, match="hand: contains"):
        temporal_log_ratio(psi, np.full((T, 2), np.nan), HALF, SIGMA)
    with pytest.raises(ValueError, match="phase: the temporal cue needs T >= 2"):
        temporal_log_ratio(psi[:1], hand_l[:1], HALF, SIGMA)
    with pytest.raises(ValueError, match="right: expected the shape of left"):
        stereo_log_ratio(jax.random.key(0), psi, psi[:, :-1], hand_l, hand_l, HALF, SIGMA, 5)
    with pytest.raises(ValueError, match="sigma: must be > 0"):
        temporal_log_ratio(psi, hand_l, HALF, 0.0)
    with pytest.raises(ValueError, match="half_window"):
        temporal_log_ratio(psi, hand_l, (3,), SIGMA)


def _object_masks_ref(fg, min_fraction, k):
    """SciPy: 8-connected labels, the nearest region above the size floor, holes filled, k
    erosions (the outside counts as foreground, as OpenCV's default border) and k dilations."""
    out = np.zeros_like(fg)
    h, w = fg.shape[1:]
    for t, f in enumerate(fg):
        labels, n = ndimage.label(f, structure=np.ones((3, 3)))
        best, best_d = 0, np.inf
        for i in range(1, n + 1):
            r, c = np.nonzero(labels == i)
            d = np.hypot(r - h // 2, c - w // 2).min()
            if len(r) > min_fraction * f.sum() and d < best_d:
                best, best_d = i, d
        m = ndimage.binary_fill_holes(labels == best) if best else np.zeros_like(f)
        if k and m.any():
            m = ndimage.binary_dilation(ndimage.binary_erosion(m, np.ones((3, 3)), k, border_value=1),
                                        np.ones((3, 3)), k)
        out[t] = m
    return out


def test_object_masks_match_scipy_and_find_the_object(scene):
    _, _, hand_l, hand_r, mask, psi_l, psi_r = scene
    temporal = temporal_log_ratio(psi_l, hand_l, HALF, SIGMA)
    stereo = stereo_log_ratio(jax.random.key(3), psi_l[1:], psi_r[1:], hand_l[1:], hand_r[1:], HALF, SIGMA, 10, 50)
    hand = np.zeros(np.shape(temporal.log_ratio), bool)
    hand[:, HALF[0] - 1:HALF[0] + 2, HALF[1] - 1:HALF[1] + 2] = True  # the 'hand' at the window centre
    got, found = object_masks(temporal, stereo, hand)
    fg = (np.asarray(temporal.valid) & np.asarray(stereo.valid) & ~hand
          & (np.asarray(temporal.log_ratio) + np.asarray(stereo.log_ratio) > 0.01))
    np.testing.assert_array_equal(np.asarray(got), _object_masks_ref(fg, 0.1, 2))
    truth = _window_mask(mask, hand_l)[1:]
    got = np.asarray(got)
    assert np.asarray(found).all()
    assert (got & truth).sum() / (got | truth).sum() > 0.5


def test_object_masks_holes_and_nothing_found():
    """A ring's hole is filled; a frame with no foreground is flagged, its mask empty."""
    ring = np.zeros((2, 15, 15), bool)
    ring[0, 3:12, 3:12] = True
    ring[0, 6:9, 6:9] = False
    cue = LogRatio(jax.numpy.asarray(np.where(ring, 1.0, -1.0)), jax.numpy.ones(ring.shape, bool))
    zero = LogRatio(jax.numpy.zeros(ring.shape), jax.numpy.ones(ring.shape, bool))
    masks, found = object_masks(cue, zero, np.zeros(ring.shape, bool), morphology=0)
    assert np.asarray(masks)[0, 3:12, 3:12].all() and np.asarray(masks)[0].sum() == 81
    assert list(np.asarray(found)) == [True, False] and not np.asarray(masks)[1].any()
    with pytest.raises(ValueError, match="stereo: expected log ratios"):
        object_masks(cue, LogRatio(zero.log_ratio[:1], zero.valid[:1]), np.zeros(ring.shape, bool))
    with pytest.raises(ValueError, match="hand: expected shape"):
        object_masks(cue, zero, np.zeros((2, 15, 14), bool))


def test_segment_objects_composes_the_pieces(scene):
    """End to end from grey frames: the composition of phase, both cues and the masks, with the hand's
    pixels given in image coordinates; frame 0 (no previous frame) flagged not found."""
    left, right, hand_l, hand_r, mask, psi_l, psi_r = scene
    hands = np.zeros(left.shape, bool)
    for t, (r, c) in enumerate(hand_l):
        hands[t, r - 1:r + 2, c - 1:c + 2] = True
    key = jax.random.key(3)
    res = segment_objects(key, left, right, hand_l, hand_r, hands,
                          ObjectOptions(HALF, SIGMA, 10, blur_sigma=BLUR, n_samples=50))
    temporal = temporal_log_ratio(psi_l, hand_l, HALF, SIGMA)
    stereo = stereo_log_ratio(key, psi_l[1:], psi_r[1:], hand_l[1:], hand_r[1:], HALF, SIGMA, 10, 50)
    in_window = np.zeros(np.shape(temporal.log_ratio), bool)
    in_window[:, HALF[0] - 1:HALF[0] + 2, HALF[1] - 1:HALF[1] + 2] = True
    want, found = object_masks(temporal, stereo, in_window)
    np.testing.assert_array_equal(np.asarray(res.masks)[1:], np.asarray(want))
    assert list(np.asarray(res.found)) == [False] + list(np.asarray(found))
    assert not np.asarray(res.masks)[0].any()
    assert list(np.asarray(res.hand_moved)) == [False] + [True] * (len(left) - 1)  # the hand moves 2 px a frame
    still = segment_objects(key, left, right, hand_l, hand_r, hands,
                            ObjectOptions(HALF, SIGMA, 10, blur_sigma=BLUR, n_samples=50, min_hand_motion=2.5))
    assert not np.asarray(still.hand_moved).any()
    np.testing.assert_array_equal(np.asarray(still.masks), np.asarray(res.masks))


@pytest.mark.parametrize("crop_margin", [None, 8])
def test_opencv_peer_finds_the_object_on_the_same_windows(scene, crop_margin):
    """The OpenCV object peer (StereoSGBM + DIS flow, the same selection as ours) on the synthetic pair,
    on the full frames and on crops: its mask lies on the object (the scene's object is nearer and
    moves with the hand)."""
    from experiments.peers.object_peer import peer_object_masks

    left, right, hand_l, hand_r, mask, _, _ = scene
    u8 = lambda a: np.clip(a, 0, 255).astype(np.uint8)
    hands = np.zeros(left.shape, bool)
    masks, found = peer_object_masks(u8(left), u8(right), hand_l, hand_r, hands, HALF, num_disparities=16,
                                     crop_margin=crop_margin)
    truth = _window_mask(mask, hand_l)
    assert not found[0] and found[1:].all()
    assert (masks & truth).sum() > 0.8 * masks.sum() and (masks & truth)[1:].sum() > 0.3 * truth[1:].sum()


class _LocalSGBM:
    """StereoSGBM's interface with a known support: the object's disparity where the block means of
    the left view at x and of the right view at x - (n - 1) are bright together, invalid in the
    first n columns (as OpenCV), zero outside the input."""

    def __init__(self, n: int, block: int):
        self.n, self.block = n, block

    def compute(self, left, right):
        mean = lambda a: ndimage.uniform_filter(a.astype(float), self.block, mode="constant")
        shifted = np.zeros(right.shape)
        shifted[:, self.n - 1:] = mean(right)[:, :max(right.shape[1] - self.n + 1, 0)]
        out = np.where(mean(left) + shifted > 256, 16 * DISPARITY_OBJ, 0).astype(np.int16)
        out[:, :self.n] = -16
        return out


class _LocalDIS:
    """DISOpticalFlow's interface with a known support (radius px): back along the hand's motion
    (the next of `motions`, (rows, columns)) where the two frames' local means are bright together."""

    def __init__(self, radius: int, motions):
        self.radius, self.motions = radius, iter(motions)

    def calc(self, now, before, _):
        mean = lambda a: ndimage.uniform_filter(a.astype(float), 2 * self.radius + 1, mode="constant")
        dr, dc = next(self.motions)
        bright = (mean(now) + mean(before) > 256)[..., None]
        return np.where(bright, np.array([-dc, -dr], np.float32), np.float32(5.0))


def test_opencv_peer_on_crops_equals_the_full_frames_where_the_fields_are_local(scene, monkeypatch):
    """With SGBM and DIS replaced by stand-ins whose outputs depend on a known neighbourhood (the
    block, the disparity range, the flow's radius = crop_margin), the peer on crops equals the peer
    on the full frames exactly, for windows inside and over the image border: the crops hold the
    fields' whole support and their windows are read at the right offsets."""
    from experiments.peers import object_peer

    left, right, *_ = scene
    u8 = lambda a: np.clip(a, 0, 255).astype(np.uint8)
    hand_l = np.array([[20, 24], [H // 2, W - 12], [1, 2], [H - 2, W // 2], [H // 2 + 3, W // 2 + 5]])
    hand_r = hand_l - np.array([0, DISPARITY_OBJ])
    frames = [u8(np.resize(v, (len(hand_l), H, W))) for v in (left, right)]
    hands = np.zeros(frames[0].shape, bool)
    radius = 6
    monkeypatch.setattr(object_peer.cv2, "StereoSGBM_create",
                        lambda **kw: _LocalSGBM(kw["numDisparities"], kw["blockSize"]))
    monkeypatch.setattr(object_peer.cv2, "DISOpticalFlow_create", lambda _: _LocalDIS(radius, np.diff(hand_l, axis=0)))
    run = lambda margin: object_peer.peer_object_masks(*frames, hand_l, hand_r, hands, HALF, num_disparities=16,
                                                       crop_margin=margin)
    (full, found_full), (cropped, found) = run(None), run(radius)
    np.testing.assert_array_equal(cropped, full)
    np.testing.assert_array_equal(found, found_full)
    assert found_full.sum() >= 2 and full.any()


def test_opencv_peer_on_crops_runs_on_windows_over_the_border(scene):
    """Crops clipped by the image border are grown to what OpenCV accepts (SGBM fails on no more
    columns than disparities, DIS on short wide images): masks and flags, no crash."""
    from experiments.peers.object_peer import peer_object_masks

    left, right, *_ = scene
    u8 = lambda a: np.clip(a, 0, 255).astype(np.uint8)
    hand_l = np.array([[20, 24], [1, 2], [H - 1, W - 1], [0, W - 3]])
    for half in (HALF, (3, 20)):  # (3, 20): DIS on a crop of 5 x 41 px would crash
        masks, found = peer_object_masks(u8(left), u8(right), hand_l, hand_l, np.zeros(left.shape, bool), half,
                                         num_disparities=16, crop_margin=0)
        assert masks.shape == (len(hand_l), 2 * half[0] + 1, 2 * half[1] + 1) and found.shape == (len(hand_l),)
        assert not found[0]


def _window_ref(image, centre, half):
    """The (2 hh + 1, 2 hw + 1) window of image around centre, NaN outside the image."""
    rows, cols = centre[0] + np.arange(-half[0], half[0] + 1), centre[1] + np.arange(-half[1], half[1] + 1)
    ok_r, ok_c = (rows >= 0) & (rows < image.shape[0]), (cols >= 0) & (cols < image.shape[1])
    out = np.full((len(rows), len(cols)), np.nan, np.float32)
    out[np.ix_(ok_r, ok_c)] = image[np.ix_(rows[ok_r], cols[ok_c])]
    return out


@pytest.mark.parametrize("shape, blur, half", [((H, W), BLUR, HALF), ((H, W), 2.5, (6, 9)), ((5, 7), 2.0, (1, 2))])
def test_crop_phase_equals_the_full_frame_phase_at_the_border_and_inside(shape, blur, half):
    """`segment_objects` computes Psi only on crops around the windows (`hog_jax._phase.crop_phase`):
    the windows of `gradient_phase` of the whole frame, NaN outside the image, for windows over a
    corner, an edge, partly and wholly outside the image and near its centre; (5, 7) with a kernel
    of radius 8 needs the symmetric padding reflected more than once. Compiled with XLA's default
    fusion emitters (`tests.xla_level.with_default_fusion_emitters`), as users run it."""
    with_default_fusion_emitters(_check_crop_phase, shape, blur, half)


def _check_crop_phase(shape, blur, half):
    from hog_jax.video import crop_phase, gaussian_kernel

    image = gaussian_filter(np.random.default_rng(1).uniform(0, 255, shape), 0.7).astype(np.float32)
    full = np.asarray(gradient_phase(image, blur))
    (h, w), (ch, cw) = shape, (shape[0] // 2, shape[1] // 2)
    centres = np.array([[0, 0], [2, w - 1], [h - 1, 3], [-3, cw], [h + 2, w + 1], [ch, cw], [ch + 1, cw - 1],
                        [-40, -40]])
    crops = jax.jit(lambda img, cs, k: jax.vmap(lambda c: crop_phase(img, c, half, k))(cs))(
        image, centres.astype(np.int32), gaussian_kernel(blur))
    want = np.stack([_window_ref(full, c, half) for c in centres])
    crops = np.asarray(crops)
    np.testing.assert_array_equal(np.isnan(crops), np.isnan(want))
    assert np.isfinite(want[5]).all() and np.isnan(want[-1]).all()
    np.testing.assert_allclose(np.nan_to_num(_wrap(crops - want)), 0.0, atol=1e-4)  # degrees: float32 round-off


def test_segment_objects_cues_equal_the_full_frame_pieces_near_the_border():
    """The cues `segment_objects` computes from crops of 8-bit frames are those of
    `temporal_log_ratio` and `stereo_log_ratio` on `gradient_phase` of the whole frames, for
    windows over the image border (the right view's partly outside) and one inside. Compiled with
    XLA's default fusion emitters (`tests.xla_level.with_default_fusion_emitters`), as users run it."""
    with_default_fusion_emitters(_check_cues_near_the_border)


def _check_cues_near_the_border():
    left, right, *_ = _scene()
    u8 = lambda a: np.clip(a, 0, 255).astype(np.uint8)
    hand_l = np.array([[1, 2], [3, 5], [H - 2, W - 4], [H // 2, W // 2]])
    hand_r = hand_l - np.array([0, DISPARITY_OBJ])
    key = jax.random.key(5)
    res = segment_objects(key, u8(left), u8(right), hand_l, hand_r, np.zeros(left.shape, bool),
                          ObjectOptions(HALF, SIGMA, 10, blur_sigma=BLUR, n_samples=50))
    psi_l, psi_r = gradient_phase(u8(left), BLUR), gradient_phase(u8(right), BLUR)
    temporal = temporal_log_ratio(psi_l, hand_l, HALF, SIGMA)
    stereo = stereo_log_ratio(key, psi_l[1:], psi_r[1:], hand_l[1:], hand_r[1:], HALF, SIGMA, 10, 50)
    for got, want in ((res.temporal, temporal), (res.stereo, stereo)):
        np.testing.assert_array_equal(np.asarray(got.valid), np.asarray(want.valid))
        np.testing.assert_allclose(np.asarray(got.log_ratio), np.asarray(want.log_ratio), atol=1e-5)
    assert not np.asarray(res.stereo.valid)[0].all() and np.asarray(res.stereo.valid)[-1].all()


def test_stereo_ratio_with_fewer_draws_than_offsets(scene):
    """Eq. 4's mean over the draws, as counts over the 2 d + 1 offsets, also where most offsets are
    never drawn (N = 4 < 21)."""
    _, _, hand_l, hand_r, _, psi_l, psi_r = scene
    key = jax.random.key(7)
    got = stereo_log_ratio(key, psi_l, psi_r, hand_l, hand_r, HALF, SIGMA, max_offset=10, n_samples=4)
    offsets = np.asarray(jax.random.randint(key, (4,), -10, 11))
    want = _stereo_ref(psi_l.astype(np.float64), psi_r.astype(np.float64), hand_l, hand_r, offsets)
    np.testing.assert_allclose(np.asarray(got.log_ratio), want, atol=2e-4)


def test_segment_objects_in_chunks_of_frames(scene):
    """`segment_objects` computes the stereo cue in chunks of frames (`_in_chunks`, padded to whole
    chunks): over more frames than a chunk, not a multiple of it, the cues are still those of the
    full-frame pieces, and a frame's values do not depend on how many frames come with it."""
    left, right, hand_l, hand_r, *_ = scene
    order = np.arange(CHUNK + 3) % T  # the scene's frames again and again: 2 chunks, the second padded
    left, right, hand_l, hand_r = left[order], right[order], hand_l[order], hand_r[order]
    key = jax.random.key(11)

    def run(n):
        return segment_objects(key, left[:n], right[:n], hand_l[:n], hand_r[:n], np.zeros(left[:n].shape, bool),
                               ObjectOptions(HALF, SIGMA, 10, blur_sigma=BLUR, n_samples=50))

    res, short = run(len(order)), run(4)
    psi_l, psi_r = gradient_phase(left, BLUR), gradient_phase(right, BLUR)
    temporal = temporal_log_ratio(psi_l, hand_l, HALF, SIGMA)
    stereo = stereo_log_ratio(key, psi_l[1:], psi_r[1:], hand_l[1:], hand_r[1:], HALF, SIGMA, 10, 50)
    for got, want, head in ((res.temporal, temporal, short.temporal), (res.stereo, stereo, short.stereo)):
        assert np.shape(got.log_ratio) == (len(order) - 1, 2 * HALF[0] + 1, 2 * HALF[1] + 1)
        np.testing.assert_array_equal(np.asarray(got.valid), np.asarray(want.valid))
        np.testing.assert_allclose(np.asarray(got.log_ratio), np.asarray(want.log_ratio), atol=1e-5)
        np.testing.assert_array_equal(np.asarray(head.log_ratio), np.asarray(got.log_ratio)[:3])
        np.testing.assert_array_equal(np.asarray(head.valid), np.asarray(got.valid)[:3])
    np.testing.assert_array_equal(np.asarray(short.masks), np.asarray(res.masks)[:4])
