"""hog_jax.segment: EM, median filter vs OpenCV, the skin model on real UCI pixels, whole frames."""
from pathlib import Path

import chex
import cv2
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import ndimage

from hog_jax import (fit_gmm, fit_skin_model, gmm_log_prob, load_skin_model, median3, rgb_to_chroma,
                     save_skin_model, segment, skin_log_ratio)

UCI = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "skin_nonskin_uci.tsv"


def test_chroma_matches_opencv():
    rgb = np.random.default_rng(0).integers(0, 256, (50, 1, 3)).astype(np.uint8)
    ycrcb = cv2.cvtColor(rgb, cv2.COLOR_RGB2YCrCb).astype(np.float64)[:, 0, 1:]
    np.testing.assert_allclose(np.asarray(rgb_to_chroma(rgb[:, 0])) * 255, ycrcb, atol=1.0)  # OpenCV rounds


def test_gmm_log_prob_matches_scipy():
    from scipy.stats import multivariate_normal
    rng = np.random.default_rng(1)
    x = rng.normal(size=(2000, 2)).astype(np.float32)
    g = fit_gmm(jax.random.key(0), x, n_components=3, n_iter=5)
    pts = rng.normal(size=(7, 2))
    w = np.exp(np.asarray(g.log_weights))
    covs = np.asarray(g.chols) @ np.asarray(g.chols).transpose(0, 2, 1)
    ref = np.log(sum(w[i] * multivariate_normal(np.asarray(g.means[i]), covs[i]).pdf(pts) for i in range(3)))
    np.testing.assert_allclose(np.asarray(gmm_log_prob(g, jnp.asarray(pts, jnp.float32))), ref, rtol=1e-4)
    assert np.exp(np.asarray(g.log_weights)).sum() == pytest.approx(1.0, abs=1e-5)


def test_em_recovers_well_separated_mixture():
    rng = np.random.default_rng(2)
    means = np.array([[0.0, 0.0], [5.0, 5.0], [-5.0, 5.0]])
    n = np.array([3000, 2000, 1000])
    x = np.concatenate([rng.normal(m, 0.5, size=(k, 2)) for m, k in zip(means, n)]).astype(np.float32)
    best = None
    for seed in range(3):  # EM is local: take the best of three starts (by likelihood)
        g = fit_gmm(jax.random.key(seed), x, n_components=3, n_iter=60)
        ll = float(gmm_log_prob(g, x).mean())
        best = (ll, g) if best is None or ll > best[0] else best
    g = best[1]
    order = np.argsort(np.asarray(g.means)[:, 0] * 10 + np.asarray(g.means)[:, 1])
    got = np.asarray(g.means)[order]
    want = means[np.argsort(means[:, 0] * 10 + means[:, 1])]
    np.testing.assert_allclose(got, want, atol=0.1)
    np.testing.assert_allclose(np.sort(np.exp(np.asarray(g.log_weights))), np.sort(n / n.sum()), atol=0.02)


def test_median3_matches_opencv_three_times():
    rng = np.random.default_rng(3)
    masks = rng.random((4, 23, 31)) > 0.5
    ours = np.asarray(median3(masks, 3))
    for b in range(4):
        m = masks[b].astype(np.uint8) * 255
        for _ in range(3):
            m = cv2.medianBlur(m, 3)
        np.testing.assert_array_equal(ours[b], m > 0)


@pytest.fixture(scope="module")
def uci():
    if not UCI.exists():
        pytest.skip(f"real skin data absent: {UCI} (the UCI Skin Segmentation set; see ../shared/data/README.md)")
    d = np.loadtxt(UCI, skiprows=1, dtype=np.int64)
    return d


def test_uci_column_order_is_bgr(uci):
    """The header says R G B, the UCI documentation B G R. Chroma models cannot tell (swapping R and B
    mirrors both classes alike), so check physics: skin reflects more red than blue."""
    skin = uci[uci[:, 3] == 1]
    assert np.mean(skin[:, 2] > skin[:, 0]) > 0.95  # third column (R under B, G, R) exceeds the first


@pytest.fixture(scope="module")
def skin_model(uci):
    rgb = uci[:, [2, 1, 0]].astype(np.float32)  # B, G, R columns -> R, G, B
    lab = uci[:, 3]
    perm = np.random.default_rng(0).permutation(len(uci))
    tr, te = perm[: len(perm) // 5], perm[len(perm) // 5:]  # 20 % to fit, 80 % held out
    model = fit_skin_model(jax.random.key(0), rgb[tr][lab[tr] == 1], rgb[tr][lab[tr] == 2], n_iter=60)
    return model, rgb[te], lab[te] == 1


def test_skin_model_on_real_pixels(skin_model):
    model, rgb, is_skin = skin_model
    llr = np.asarray(skin_log_ratio(model, rgb))
    acc = np.mean((llr > 0) == is_skin)
    # equal-error rate from the ROC
    ths = np.quantile(llr, np.linspace(0, 1, 801))
    fpr = 1.0 - np.searchsorted(np.sort(llr[~is_skin]), ths, side="right") / np.sum(~is_skin)
    fnr = np.searchsorted(np.sort(llr[is_skin]), ths, side="right") / np.sum(is_skin)
    eer = float(np.min(np.maximum(fpr, fnr)))
    assert acc > 0.97 and eer < 0.03, (acc, eer)  # the pixel-level set is easy; a broken model is not


def make_frames(rng, n=3, h=60, w=80):
    """Frames with a skin-coloured blob (hand) and a smaller one, on a bluish-grey background."""
    frames = np.empty((n, h, w, 3), np.float32)
    frames[:] = [90, 100, 120] + rng.normal(0, 4, (n, h, w, 3))
    rr, cc = np.mgrid[0:h, 0:w]
    boxes = []
    for i in range(n):
        r0, c0 = rng.integers(15, h - 15), rng.integers(20, w - 20)
        hand = ((rr - r0) / 12.0) ** 2 + ((cc - c0) / 8.0) ** 2 <= 1
        frames[i][hand] = [200, 140, 110] + rng.normal(0, 4, (hand.sum(), 3))
        small = ((rr - 5) ** 2 + (cc - 5) ** 2) <= 4
        frames[i][small] = [200, 140, 110]
        ys, xs = np.nonzero(hand)
        boxes.append((ys.min(), xs.min(), ys.max() + 1, xs.max() + 1))
    return np.clip(frames, 0, 255), np.array(boxes)


@pytest.fixture(scope="module")
def toy_model():
    rng = np.random.default_rng(7)
    skin = rng.normal([200, 140, 110], 8, (3000, 3)).clip(0, 255)
    bg = np.concatenate([rng.normal([90, 100, 120], 8, (2000, 3)), rng.uniform(0, 255, (1000, 3))]).clip(0, 255)
    return fit_skin_model(jax.random.key(1), skin, bg, n_iter=40)


def test_segment_frames_largest_seed_and_empty(tmp_path, toy_model):
    rng = np.random.default_rng(4)
    frames, boxes = make_frames(rng)
    frames[2] = [90, 100, 120]  # no skin in the last frame
    model = toy_model
    seg = segment(model, frames, out_size=32, margin=0.0)
    chex.assert_shape([seg.images, seg.masks], (3, 32, 32))
    chex.assert_shape([seg.found, seg.boxes, seg.skin], [(3,), (3, 4), frames.shape[:3]])
    found = np.asarray(seg.found)
    assert found.tolist() == [True, True, False]
    for i in range(2):
        top, left, bottom, right = np.asarray(seg.boxes[i])
        h, w = boxes[i][2] - boxes[i][0], boxes[i][3] - boxes[i][1]
        assert bottom - top == right - left  # square
        assert max(h, w) - 3 <= bottom - top <= max(h, w)  # the larger side; the median filter erodes the tips
        assert abs((top + bottom) / 2 - (boxes[i][0] + boxes[i][2]) / 2) <= 1
        assert abs((left + right) / 2 - (boxes[i][1] + boxes[i][3]) / 2) <= 1
        m = np.asarray(seg.masks[i])
        assert 0.4 < m.mean() < 0.7  # an 8 x 12 ellipse in a 24 x 24 square: pi/4 * 8/12 ~ 0.52
        img = np.asarray(seg.images[i])
        assert np.all(img[~m] < 0.45) and img[m].mean() > 0.5  # background black, hand bright
        # context: the same box unmasked, the hand as in the crop, the background's grey around it
        ctx, inner = np.asarray(seg.context[i]), ndimage.binary_erosion(m, iterations=3)
        np.testing.assert_allclose(ctx[inner], img[inner], atol=0.08)
        background_grey = np.dot([90, 100, 120], [0.299, 0.587, 0.114]) / 255.0
        assert abs(np.median(ctx[~ndimage.binary_dilation(m, iterations=3)]) - background_grey) < 0.05
    assert not np.asarray(seg.masks[2]).any() and np.asarray(seg.boxes[2]).tolist() == [-1] * 4
    assert not np.asarray(seg.context[2]).any()
    # a seed at the small blob picks it instead of the largest component
    seg2 = segment(model, frames[:1], seed_points=[[5, 5]], out_size=16)
    top, left, bottom, right = np.asarray(seg2.boxes[0])
    assert top <= 5 <= bottom and left <= 5 <= right and bottom - top < 10
    # the crops feed HOG with their masks
    import hog_jax
    x = hog_jax.hog(np.asarray(seg.images[:2]), mask=np.asarray(seg.masks[:2]))
    chex.assert_shape(x, (2, 84))
    assert np.all(np.isfinite(np.asarray(x)))


def test_skin_model_persistence_round_trip_and_checks(tmp_path, toy_model):
    from lfd_common import read_file, save_arrays, write_npz

    model = toy_model
    frames, _ = make_frames(np.random.default_rng(4))
    path = save_skin_model(tmp_path / "skin", model)
    assert path.name == "skin.npz"
    kind, arrays, config, _ = read_file(path)
    assert kind == "hog_jax.SkinModel"
    assert config["structure"] == {"n_skin_components": 4, "n_background_components": 4, "chroma": "CrCb/255 BT.601"}
    back = load_skin_model(tmp_path / "skin")  # no type argument; the path maps as save maps it
    chex.assert_trees_all_equal(back, model)
    np.testing.assert_array_equal(np.asarray(skin_log_ratio(back, frames[0])), np.asarray(skin_log_ratio(model, frames[0])))
    with pytest.raises(ValueError, match="holds a"):
        load_skin_model(save_arrays(tmp_path / "other", "phmm_jax.HMM", {"a": np.zeros(2)}))

    def tampered(name, value):  # the saved file with one array replaced
        bad = dict(arrays, **{name: value})
        meta = np.load(path)["__lfd_meta__"]
        return write_npz(tmp_path / f"bad_{name.replace('/', '_')}.npz", __lfd_meta__=meta, **bad)

    with pytest.raises(ValueError, match="skin/means"):
        load_skin_model(tampered("skin/means", np.zeros((3, 2), np.float32)))  # 3 components, structure says 4
    chols = np.array(arrays["background/chols"])
    chols[1, 0, 1] = 0.5  # not lower triangular
    with pytest.raises(ValueError, match="background: covariances not positive definite"):
        load_skin_model(tampered("background/chols", chols))
    chols = np.array(arrays["skin/chols"])
    chols[0, 1, 1] = -chols[0, 1, 1]
    with pytest.raises(ValueError, match="skin: covariances not positive definite"):
        load_skin_model(tampered("skin/chols", chols))
    with pytest.raises(ValueError, match="skin: mixture weights sum to"):
        load_skin_model(tampered("skin/log_weights", np.zeros(4, np.float32)))
    with pytest.raises(ValueError, match="NaN"):
        load_skin_model(tampered("threshold", np.float32(np.nan)))
    with pytest.raises(ValueError, match="mixture weights"):  # a bad model is not written either
        unnormalised = model.skin._replace(log_weights=model.skin.log_weights + 1)
        save_skin_model(tmp_path / "never", model._replace(skin=unnormalised))
    with pytest.raises(FileNotFoundError):
        load_skin_model(tmp_path / "missing")


def test_segment_bad_input(toy_model):
    model = toy_model
    with pytest.raises(ValueError, match="frames: expected a 4-D"):
        segment(model, np.zeros((10, 10, 3)))
    with pytest.raises(ValueError, match="frames: expected \\(B, H, W, 3\\)"):
        segment(model, np.zeros((1, 10, 10, 4)))
    with pytest.raises(ValueError, match="frames: must not be empty"):
        segment(model, np.zeros((0, 10, 10, 3)))
    with pytest.raises(ValueError, match="frames: contains 1 NaN"):
        f = np.zeros((1, 10, 10, 3))
        f[0, 0, 0, 0] = np.nan
        segment(model, f)
    with pytest.raises(ValueError, match="seed_points: expected shape \\(1, 2\\)"):
        segment(model, np.zeros((1, 10, 10, 3)), seed_points=[[1, 2, 3]])


# ------------------------------------------------------------------ bad input, edge cases
def test_one_pixel_per_class_floors_the_covariance(tmp_path):
    """One pixel per class and one component: the covariance of one sample was 0/0 (NaN means). It is
    floored at reg * I (with a warning) and the model classifies and round-trips."""
    skin, bg = np.array([[200.0, 140.0, 110.0]]), np.array([[40.0, 60.0, 200.0]])
    with pytest.warns(UserWarning, match="(skin_rgb|background_rgb): 1 point\\(s\\) in 2 dimensions"):
        model = fit_skin_model(jax.random.key(0), skin, bg, n_components=1, n_background=1, n_iter=5)
    for gmm, px in ((model.skin, skin), (model.background, bg)):
        np.testing.assert_allclose(np.asarray(gmm.means), np.asarray(rgb_to_chroma(px)), atol=1e-6)
        cov = np.asarray(gmm.chols[0] @ gmm.chols[0].T)
        np.testing.assert_allclose(cov, 1e-5 * np.eye(2), rtol=1e-4)
    ratio = np.asarray(skin_log_ratio(model, np.concatenate([skin, bg])))
    assert np.isfinite(ratio).all() and ratio[0] > 0 > ratio[1]
    loaded = load_skin_model(save_skin_model(tmp_path / "one", model))
    np.testing.assert_array_equal(np.asarray(loaded.skin.means), np.asarray(model.skin.means))
    with pytest.warns(UserWarning, match="x: 1 point"):
        g = fit_gmm(jax.random.key(1), np.array([[0.3, 0.7]]), n_components=1, n_iter=0)
    assert np.isfinite(np.asarray(g.chols)).all()
    with pytest.raises(ValueError, match="n_background: must be <= 1"):
        fit_skin_model(jax.random.key(0), skin, bg, n_components=1, n_background=2)
    with pytest.raises(ValueError, match="key: expected a jax.random key"):
        fit_skin_model(0, skin, bg, n_components=1, n_background=1)
