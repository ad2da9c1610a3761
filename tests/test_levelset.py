"""hog_jax.levelset / levelset_grey: eqs. 4-7 and 11 against float64 NumPy, partitions recovered,
the stopping rule, warm start, vmap, the grey front end beside scikit-image, bad input."""
import chex
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.ndimage import distance_transform_edt

from hog_jax.video import (LevelSetOptions, LevelSetStructure, contour_length, curvature, dirac, evolve,
    heaviside, init_level_sets, segment_video, signed_distance)
from hog_jax.video import VAR_FLOOR, chan_vese_scores, chan_vese_segment

H, W = 48, 64
YY, XX = np.mgrid[:H, :W]
ONE_SCALE = LevelSetStructure(2, (H, W), None)
FEW = settings(max_examples=6, deadline=None)


# ------------------------------------------------------------------ float64 NumPy references
def np_heaviside(p, eps):
    return np.where(p < -eps, 0.0, np.where(p > eps, 1.0, 0.5 + p / (2 * eps) + np.sin(np.pi * p / eps) / (2 * np.pi)))


def np_dirac(p, eps):
    return np.where(np.abs(p) > eps, 0.0, (1 + np.cos(np.pi * p / eps)) / (2 * eps))


def np_grad(f):
    p = np.pad(f, 1, mode="edge")
    return (p[2:, 1:-1] - p[:-2, 1:-1]) / 2, (p[1:-1, 2:] - p[1:-1, :-2]) / 2


def np_curvature(f):
    gy, gx = np_grad(f)
    n = np.sqrt(gy ** 2 + gx ** 2 + 1e-6)  # the floor of the module (|grad phi| -> 0)
    return np_grad(gy / n)[0] + np_grad(gx / n)[1]


def np_eq4_step(phi, e1, e2, alpha, mu, eps, dt):
    """Eq. 4 (curvature weight alpha / 2, as eq. 7 gives for R = 2) plus the eq. 11 flow, one Euler step."""
    p = np.pad(phi, 1, mode="edge")
    lap = p[2:, 1:-1] + p[:-2, 1:-1] + p[1:-1, 2:] + p[1:-1, :-2] - 4 * phi
    k = np_curvature(phi)
    return phi + dt * (np_dirac(phi, eps) * (e1 - e2 + alpha / 2 * k) + mu * (lap - k))


def np_energy(phi, e1, e2, alpha, mu, eps):
    """Eq. 3 (length weight alpha / 2) + mu P(phi) of eq. 11, central differences."""
    h = np_heaviside(phi, eps)
    gy, gx = np_grad(h)
    py, px = np_grad(phi)
    return (-(e1 * h).sum() - (e2 * (1 - h)).sum() + alpha / 2 * np.hypot(gy, gx).sum()
            + mu * 0.5 * ((np.hypot(py, px) - 1) ** 2).sum())


def np_sdf(mask):
    return np.where(mask, distance_transform_edt(mask) - 0.5, -(distance_transform_edt(~mask) - 0.5))


def iou(a, b):
    return (a & b).sum() / max((a | b).sum(), 1)


def disc_scores(cy, cx, r, noise=0.1, seed=0):
    """Gaussian log-likelihoods (2, H, W) of a bright disc (0.7) on a dark background (0.3) + noise."""
    truth = (YY - cy) ** 2 + (XX - cx) ** 2 < r ** 2
    img = np.where(truth, 0.7, 0.3) + np.random.default_rng(seed).normal(0, noise, (H, W))
    e = np.stack([-(img - 0.7) ** 2, -(img - 0.3) ** 2]) / (2 * noise ** 2)
    return e.astype(np.float32), truth


OPTS = LevelSetOptions(alpha=2.0)


# ------------------------------------------------------------------ eqs. 5-6, curvature, distances
@pytest.mark.parametrize("eps", [0.5, 1.5, 3.0])
def test_heaviside_and_delta_are_eqs_5_6(eps):
    x = np.linspace(-2 * eps, 2 * eps, 4001)
    np.testing.assert_allclose(np.asarray(heaviside(x.astype(np.float32), eps)), np_heaviside(x, eps), atol=1e-6)
    np.testing.assert_allclose(np.asarray(dirac(x.astype(np.float32), eps)), np_dirac(x, eps), atol=1e-6 / eps)


@pytest.mark.parametrize("r", [8.0, 16.0])
def test_curvature_of_a_circle_is_one_over_r(r):
    dist = np.hypot(YY - 24.3, XX - 31.7)
    on_circle = np.abs(dist - r) < 0.5
    for sign in (1, -1):  # positive outside: +1/r; positive inside: -1/r
        k = np.asarray(curvature((sign * (dist - r)).astype(np.float32)))
        np.testing.assert_allclose(k[on_circle], sign / dist[on_circle], rtol=0.03)
    length = float(contour_length((dist - r)[None].astype(np.float32)))  # sum |grad H(phi)|
    assert length == pytest.approx(2 * np.pi * r, rel=0.02)


def test_signed_distance_and_init_match_scipy():
    rng = np.random.default_rng(1)
    mask = np.zeros((H, W), bool)
    for cy, cx, r in rng.uniform([5, 5, 3], [43, 59, 12], (4, 3)):
        mask |= (YY - cy) ** 2 + (XX - cx) ** 2 < r ** 2
    np.testing.assert_allclose(np.asarray(signed_distance(mask)), np_sdf(mask), atol=1e-4)
    e = rng.normal(size=(3, H, W)).astype(np.float32)
    labels = np.argmax(e, 0)
    phi = np.asarray(init_level_sets(e))
    for i in range(3):  # outside region i: distance to it; inside: distance to the nearest other region
        inside = labels == i
        want = np.where(inside, distance_transform_edt(inside) - 0.5, -(distance_transform_edt(~inside) - 0.5))
        np.testing.assert_allclose(phi[i], want, atol=1e-4)


# ------------------------------------------------------------------ two regions: eq. 4, energy, IoU
@pytest.fixture(scope="module")
def disc():
    return disc_scores(24, 30, 14)


def test_two_regions_are_eq_4_in_numpy(disc):
    e, _ = disc
    alpha, mu, eps = OPTS.alpha, OPTS.mu, OPTS.epsilon
    dt = 0.9 * 0.25 / (2 * mu + alpha / (2 * eps))  # the documented default step
    e64 = np.maximum(e, e.max(0) - OPTS.max_log_ratio).astype(np.float64)  # the documented score floor
    phi = np_sdf(np.argmax(e, 0) == 0).astype(np.float64)
    for _ in range(10):
        phi = np_eq4_step(phi, e64[0], e64[1], alpha, mu, eps, dt)
    res = evolve(ONE_SCALE, e, options=OPTS._replace(it_min=10, it_max=10))
    chex.assert_shape(res.phi, (2, H, W))
    res = res._replace(phi=np.asarray(res.phi))
    band = np.abs(phi) <= 3  # near the contour; far from it, on ridges of phi (|grad phi| -> 0), the
    # curvature of eq. 11's flow amplifies float32 rounding (up to ~0.1 after 10 steps; labels unaffected)
    np.testing.assert_allclose(res.phi[0][band], phi[band], atol=2e-4)
    np.testing.assert_allclose(res.phi[0], phi, atol=0.2)
    np.testing.assert_allclose(res.phi[1], -res.phi[0], atol=1e-5)


def test_energy_decreases_and_partition_recovered(disc):
    e, truth = disc
    e64 = np.maximum(e, e.max(0) - OPTS.max_log_ratio).astype(np.float64)
    energies = [np_energy(np.asarray(evolve(ONE_SCALE, e, options=OPTS._replace(it_min=k, it_max=k)).phi,
                                     np.float64)[0], e64[0], e64[1], OPTS.alpha, OPTS.mu, OPTS.epsilon)
                for k in range(1, 41, 3)]
    assert np.all(np.diff(energies) <= 1e-6 * abs(energies[0])), energies
    assert energies[-1] < energies[0] - 10
    res = evolve(ONE_SCALE, e, options=OPTS)
    assert bool(res.converged)
    assert iou(np.asarray(res.labels) == 0, truth) >= 0.98


def test_stopping_rule_respects_it_min_and_it_max(disc):
    e, _ = disc
    # tol 1 counts every iteration as unchanged: patience is reached (seen one iteration late) unless
    # it_min is larger
    for it_min, patience in ((0, 3), (12, 3)):
        res = evolve(ONE_SCALE, e, options=OPTS._replace(tol=1.0, it_min=it_min, patience=patience))
        assert int(res.iterations) == max(it_min, patience + 1) and bool(res.converged)
    res = evolve(ONE_SCALE, e, options=OPTS._replace(tol=0.0, it_max=17))  # never unchanged
    assert int(res.iterations) == 17 and not bool(res.converged)
    assert int(res.iterations_coarse) == 0


# ------------------------------------------------------------------ more regions
def test_three_regions_recovered_and_disjoint():
    disc = (YY - 20) ** 2 + (XX - 20) ** 2 < 11 ** 2
    rect = (YY > 12) & (YY < 40) & (XX > 38) & (XX < 58)
    truth = np.where(disc, 1, np.where(rect, 2, 0))
    means = np.array([0.2, 0.5, 0.8])
    img = means[truth] + np.random.default_rng(2).normal(0, 0.06, (H, W))
    e = (-(img[None] - means[:, None, None]) ** 2 / (2 * 0.06 ** 2)).astype(np.float32)
    e[2, :, :8] = -np.inf  # log 0 (no rectangle there), resampled to the coarse scale: floored first
    res = evolve(LevelSetStructure(3, (H, W), (24, 32)), e, options=OPTS)  # two scales (TR §5)
    labels, phi = np.asarray(res.labels), np.asarray(res.phi)
    assert int(res.iterations_coarse) > 0
    for i in range(3):
        assert iou(labels == i, truth == i) >= 0.97, i
    assert np.sum((phi > 0).sum(0) > 1) == 0  # pairwise disjoint regions
    assert np.mean(labels == -1) < 0.02  # unassigned pixels: boundaries only


# ------------------------------------------------------------------ video: warm start, vmap
@pytest.fixture(scope="module")
def videos():
    """Two 5-frame videos of a disc moving 2 px per frame (forwards, backwards), segmented as a batch."""
    frames = [disc_scores(24, 20 + 2 * t, 12, noise=0.15, seed=10 + t) for t in range(5)]
    scores = np.stack([f[0] for f in frames])
    batch = segment_video(ONE_SCALE, np.stack([scores, scores[::-1]]), options=OPTS)
    chex.assert_shape(batch.labels, (2, 5, H, W))
    chex.assert_shape(batch.phi, (2, 5, 2, H, W))
    return np.stack([scores, scores[::-1]]), np.stack([f[1] for f in frames]), batch._replace(
        **{k: np.asarray(v) for k, v in batch._asdict().items()})


def test_warm_start_uses_fewer_iterations(videos):
    scores, truth, batch = videos
    cold = [evolve(ONE_SCALE, s, options=OPTS) for s in scores[0, 1:]]
    assert np.sum(batch.iterations[0, 1:]) < np.sum([int(c.iterations) for c in cold]), batch.iterations
    # noise far from the previous contour lies outside the band of eq. 6 and stays put: no worse than cold
    warm_iou = [iou(batch.labels[0, t] == 0, truth[t]) for t in range(1, 5)]
    cold_iou = [iou(np.asarray(c.labels) == 0, truth[t]) for t, c in enumerate(cold, start=1)]
    assert min(warm_iou) >= 0.93 and np.mean(warm_iou) >= np.mean(cold_iou) - 0.01, (warm_iou, cold_iou)


def test_vmap_batch_equals_single_runs(videos):
    scores, _, batch = videos
    for b in range(2):  # one video alone, frame by frame, each from the previous frame's level sets
        phi = None
        for t in range(5):
            one = evolve(ONE_SCALE, scores[b, t], phi0=phi, options=OPTS)
            phi = np.asarray(one.phi)
            assert int(one.iterations) == batch.iterations[b, t]
            np.testing.assert_array_equal(np.asarray(one.labels), batch.labels[b, t])
            np.testing.assert_allclose(phi, batch.phi[b, t], atol=1e-4)


# ------------------------------------------------------------------ grey front end
def test_chan_vese_scores_are_region_statistics():
    rng = np.random.default_rng(3)
    grey = rng.random((H, W)).astype(np.float32)
    labels = rng.integers(-1, 2, (H, W))
    cv, gauss = np.asarray(chan_vese_scores(grey, labels)), np.asarray(chan_vese_scores(grey, labels, True))
    for k in range(2):
        c, v = grey[labels == k].mean(), max(grey[labels == k].var(), VAR_FLOOR)
        np.testing.assert_allclose(cv[k], -(grey - c) ** 2, atol=1e-5)
        np.testing.assert_allclose(gauss[k], -(grey - c) ** 2 / (2 * v) - 0.5 * np.log(2 * np.pi * v), atol=1e-4)


def test_chan_vese_segment_beside_scikit_image():
    from skimage.segmentation import chan_vese
    truth = (YY - 22) ** 2 / 14 ** 2 + (XX - 36) ** 2 / 20 ** 2 < 1
    grey = np.where(truth, 0.65, 0.35) + np.random.default_rng(4).normal(0, 0.15, (H, W))
    ours = chan_vese_segment(ONE_SCALE, grey, options=OPTS._replace(alpha=1.0))
    seg = np.asarray(ours.labels) == 0
    theirs = chan_vese(grey, max_num_iter=200)
    best = max(iou(seg, truth), iou(~seg, truth))
    assert bool(ours.converged)
    assert best >= 0.88 and best >= max(iou(theirs, truth), iou(~theirs, truth)) - 0.01
    flat = chan_vese_segment(ONE_SCALE, np.zeros((H, W)), options=OPTS)  # no contrast at all
    assert np.all(np.isfinite(np.asarray(flat.phi)))


# ------------------------------------------------------------------ the public promise, bad input
@FEW
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.3))
def test_valid_scores_give_finite_labelled_output(seed, frac_neg_inf):
    rng = np.random.default_rng(seed)
    e = rng.normal(0, 5, (2, H, W)).astype(np.float32)
    e[rng.random(e.shape) < frac_neg_inf] = -np.inf  # log 0: floored, never NaN
    e[:, :4, :4] = -np.inf  # a pixel where no region is possible at all
    res = evolve(ONE_SCALE, e, options=OPTS._replace(it_max=30))
    assert np.all(np.isfinite(np.asarray(res.phi)))
    assert set(np.unique(np.asarray(res.labels))) <= {-1, 0, 1}
    assert 1 <= int(res.iterations) <= 30


BAD_OPTIONS = [("alpha", -1.0), ("mu", -0.1), ("epsilon", 0.0), ("dt", 10.0), ("dt", -1.0), ("tol", -1e-3),
               ("it_min", -1), ("it_max", 0), ("patience", 0), ("max_log_ratio", 0.0), ("refit_every", 0),
               ("it_min", 2.5), ("alpha", float("nan"))]


@FEW
@given(st.sampled_from(BAD_OPTIONS))
def test_bad_options_are_named(case):
    name, value = case
    e, _ = disc_scores(24, 30, 14)
    with pytest.raises(ValueError, match=name):
        evolve(ONE_SCALE, e, options=OPTS._replace(**{name: value}))


@FEW
@given(st.sampled_from(["ndim", "regions", "nan", "inf", "empty", "phi0", "video_empty"]))
def test_bad_scores_are_named(case):
    e, _ = disc_scores(24, 30, 14)
    bad = {"ndim": e[0], "regions": np.concatenate([e, e[:1]]), "nan": np.where(YY == 3, np.nan, e),
           "inf": np.where(XX == 5, np.inf, e), "empty": e[:, :0]}
    if case == "phi0":
        with pytest.raises(ValueError, match="phi0"):
            evolve(ONE_SCALE, e, phi0=np.zeros((2, H, W - 1)))
    elif case == "video_empty":
        with pytest.raises(ValueError, match="scores"):
            segment_video(ONE_SCALE, np.zeros((0, 2, H, W), np.float32))
    else:
        with pytest.raises(ValueError, match="scores"):
            evolve(ONE_SCALE, bad[case])


def test_bad_structures_and_grey_frames_are_named():
    with pytest.raises(ValueError, match="n_regions"):
        LevelSetStructure(1, (H, W), None)
    with pytest.raises(ValueError, match="coarse"):
        LevelSetStructure(2, (40, 60), (60, 80))  # frames smaller than the coarse scale
    with pytest.raises(ValueError, match="shape"):
        LevelSetStructure(2, (H,), None)
    with pytest.raises(ValueError, match="structure"):
        chan_vese_segment(LevelSetStructure(3, (H, W), None), np.zeros((H, W)))
    with pytest.raises(ValueError, match="grey"):
        chan_vese_segment(ONE_SCALE, np.full((H, W), np.nan))
    with pytest.raises(ValueError, match="grey"):
        chan_vese_segment(ONE_SCALE, np.zeros((H, W + 1)))


def test_reseed_margin_brings_back_an_absent_region():
    """Region 0 (the disc) is absent from frame 0, so without re-seeding it has no front and never
    appears; with reseed_margin it is found from frame 1 on. Same shapes as `videos` (one compilation)."""
    frames = [disc_scores(24, 30, 12, noise=0.15, seed=20 + t) for t in range(5)]
    scores = np.stack([f[0] for f in frames])
    scores[0] = np.array([-10.0, 0.0], np.float32)[:, None, None]  # frame 0: only the background
    truth = np.stack([f[1] for f in frames])
    truth[0] = False
    reseeded = segment_video(ONE_SCALE, np.stack([scores, scores]), options=OPTS._replace(reseed_margin=3.0))
    plain = segment_video(ONE_SCALE, np.stack([scores, scores]), options=OPTS)
    assert not (np.asarray(plain.labels[0]) == 0).any()
    assert min(iou(np.asarray(reseeded.labels[0, t]) == 0, truth[t]) for t in range(1, 5)) >= 0.9
    assert not (np.asarray(reseeded.labels[0, 0]) == 0).any()
