"""hog_jax.hog against a float64 numpy reference (loops) and scikit-image's `hog`."""

import chex
import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from hog_jax import HOGConfig, hog, hog_dim


def ref_hog(img, cfg: HOGConfig, mask=None):
    """Independent float64 reference, written from the module docstring's definitions."""
    I = np.asarray(img, np.float64)
    H, W = I.shape
    gx, gy = np.zeros_like(I), np.zeros_like(I)
    gx[1:-1, :] = I[2:, :] - I[:-2, :]
    gy[:, 1:-1] = I[:, 2:] - I[:, :-2]
    B = cfg.n_bins
    if cfg.orientation == "grasp":
        phi, span = np.arctan2(gy, gx) % np.pi, np.pi
    else:
        phi, span = np.arctan2(np.abs(gy), np.abs(gx)), np.pi / 2
    votes = np.zeros((H, W, B))
    for r in range(H):
        for c in range(W):
            if gx[r, c] == 0 and gy[r, c] == 0:
                continue
            if mask is not None and not mask[r, c]:
                continue
            w = np.hypot(gx[r, c], gy[r, c]) if cfg.weighting == "magnitude" else 1.0
            if cfg.binning == "hard":
                b = int(phi[r, c] * B / span)
                b = b % B if cfg.orientation == "grasp" else min(b, B - 1)
                votes[r, c, b] += w
            else:
                t = phi[r, c] * B / span - 0.5
                if cfg.orientation == "grasp":
                    lo = int(np.floor(t))
                    f = t - lo
                    votes[r, c, lo % B] += (1 - f) * w
                    votes[r, c, (lo + 1) % B] += f * w
                else:
                    t = min(max(t, 0.0), B - 1.0)
                    lo = int(np.floor(t))
                    f = t - lo
                    votes[r, c, lo] += (1 - f) * w
                    if lo + 1 < B:
                        votes[r, c, lo + 1] += f * w
    sides = [cfg.n_levels] if cfg.layout == "grid" else [2 ** (cfg.n_levels - l) for l in range(1, cfg.n_levels + 1)]
    feats = []
    for n in sides:
        for i in range(n):
            for j in range(n):
                h = votes[i * H // n:(i + 1) * H // n, j * W // n:(j + 1) * W // n].sum(axis=(0, 1))
                if cfg.normalize == "cell" and h.sum() > 0:
                    h = h / h.sum()
                feats.append(h)
    out = np.concatenate(feats)
    if cfg.normalize == "global":
        out = out / votes.sum()
    return out


def smooth_images(rng, n, h, w):
    """Continuous-valued images (no exact ties at bin borders), blurred noise plus a bright blob."""
    import cv2
    imgs = []
    for _ in range(n):
        a = cv2.GaussianBlur(rng.random((h, w)), (0, 0), 1.2)
        rr, cc = np.mgrid[0:h, 0:w]
        a += np.exp(-((rr - rng.uniform(0, h)) ** 2 + (cc - rng.uniform(0, w)) ** 2) / (0.1 * h * w))
        imgs.append(a)
    return np.stack(imgs).astype(np.float32)


CONFIGS = [
    HOGConfig(),  # GRASP defaults: B = 4, L = 3 pyramid, eq. 1, magnitude, hard, global
    HOGConfig(n_bins=6, n_levels=2, binning="soft", normalize="cell"),
    HOGConfig(n_bins=4, n_levels=4, layout="grid", orientation="abs", normalize="none"),  # LfD 2009
    HOGConfig(n_bins=5, n_levels=3, orientation="abs", binning="soft", weighting="count"),
    HOGConfig(n_bins=3, n_levels=2, weighting="count", normalize="none"),
]


@pytest.mark.parametrize("cfg", CONFIGS, ids=lambda c: f"{c.layout}-{c.orientation}-{c.binning}-{c.weighting}-{c.normalize}")
@pytest.mark.parametrize("shape", [(24, 20), (17, 23)])  # divisible and uneven cell borders
def test_matches_float64_reference(cfg, shape):
    rng = np.random.default_rng(hash((cfg, shape)) % 2**32)
    imgs = smooth_images(rng, 3, *shape)
    ours = np.asarray(hog(imgs, cfg))
    chex.assert_shape(ours, (3, hog_dim(cfg)))
    for b in range(3):
        np.testing.assert_allclose(ours[b], ref_hog(imgs[b], cfg), rtol=2e-5, atol=1e-5 * np.abs(ours[b]).max())


def test_mask_excludes_pixels():
    rng = np.random.default_rng(1)
    imgs = smooth_images(rng, 2, 16, 16)
    mask = rng.random((2, 16, 16)) > 0.4
    cfg = HOGConfig(n_levels=2, normalize="none")
    ours = np.asarray(hog(imgs, cfg, mask=mask))
    for b in range(2):
        np.testing.assert_allclose(ours[b], ref_hog(imgs[b], cfg, mask[b]), rtol=2e-5, atol=1e-4)


def test_length_and_pyramid_structure():
    cfg = HOGConfig(n_bins=4, n_levels=3)
    assert hog_dim(cfg) == 4 * (16 + 4 + 1)  # B sum_l 4^(L-l), GRASP §IV
    assert hog_dim(HOGConfig(n_levels=4, layout="grid")) == 4 * 16  # LfD: L x L cells
    x = np.asarray(hog(smooth_images(np.random.default_rng(2), 1, 32, 32), cfg.__class__(normalize="none")))[0]
    fine, mid, top = x[:64].reshape(4, 4, 4), x[64:80].reshape(2, 2, 4), x[80:]
    np.testing.assert_allclose(mid, fine.reshape(2, 2, 2, 2, 4).sum(axis=(1, 3)), rtol=1e-5)
    np.testing.assert_allclose(top, fine.sum(axis=(0, 1)), rtol=1e-5)


def test_orientation_convention_eq1():
    """x is down, y is right: a horizontal ramp (intensity grows to the right) has dI/dx = 0, so
    Phi = arctan(dI/dy / 0) = pi/2 (bin 2 of 4); a vertical ramp has Phi = 0 (bin 0)."""
    r = np.arange(16, dtype=np.float32)
    cfg = HOGConfig(n_levels=1)
    right = np.asarray(hog(np.tile(r, (16, 1)) + 1, cfg))
    down = np.asarray(hog(np.tile(r[:, None], (1, 16)) + 1, cfg))
    np.testing.assert_allclose(right, [0, 0, 1, 0], atol=1e-6)
    np.testing.assert_allclose(down, [1, 0, 0, 0], atol=1e-6)
    inner = np.zeros((16, 16), bool)
    inner[1:-1, 1:-1] = True  # border rows/columns have only one derivative (zero padding)
    diag = np.asarray(hog(r[:, None] + r[None, :] + 1, HOGConfig(n_levels=1, n_bins=8), mask=inner))
    np.testing.assert_allclose(diag, np.eye(8)[2], atol=1e-6)  # Phi = pi/4: bin [pi/4, 3pi/8)


@pytest.mark.parametrize("n_cells", [1, 4])
def test_agrees_with_skimage(n_cells):
    """skimage.feature.hog with cells_per_block=(1, 1) (no block normalisation beyond one cell).

    Differences in definitions, accounted for here: skimage measures the angle as
    arctan2(g_row, g_col), i.e. from the column axis, while eq. 1 measures arctan(g_col / g_row) from
    the row axis, so skimage is run on the TRANSPOSED image (its cell (j, i) is our (i, j)); skimage
    divides each cell by its area and L1-normalises every 1 x 1 block as h / (sum h + 1e-5), which
    is applied here to our raw (normalize="none") histograms. Both bin hard with [start, end) bins.
    """
    skimage_feature = pytest.importorskip("skimage.feature", reason="scikit-image (the bench extra) is not installed")
    rng = np.random.default_rng(3)
    imgs = smooth_images(rng, 2, 32, 24) * 255
    B = 9
    cfg = HOGConfig(n_bins=B, n_levels=n_cells, layout="grid", normalize="none")
    ours = np.asarray(hog(imgs, cfg)).reshape(2, n_cells, n_cells, B)
    area = (32 // n_cells) * (24 // n_cells)
    for b in range(2):
        sk = skimage_feature.hog(imgs[b].T.astype(np.float64), orientations=B,
                                 pixels_per_cell=(24 // n_cells, 32 // n_cells), cells_per_block=(1, 1),
                                 block_norm="L1", feature_vector=False)[:, :, 0, 0, :]
        mine = ours[b].transpose(1, 0, 2) / area
        mine = mine / (mine.sum(-1, keepdims=True) + 1e-5)
        np.testing.assert_allclose(mine, sk, rtol=1e-5, atol=1e-6)


@settings(max_examples=15, deadline=None)
@given(log2_scale=st.integers(-4, 4), offset=st.integers(0, 50), seed=st.integers(0, 2**16))
def test_global_normalisation_invariant_to_contrast_and_offset(log2_scale, offset, seed):
    # pixels on a 1/256 grid, a power-of-two contrast and an integer offset: img * scale + offset is exact
    # in float32, so the promise is tested without rounding. (With any float scale and offset, rounding
    # moves a gradient that lies on an orientation-bin border into the next bin under hard binning: a
    # vote of 2e-3 moved between bins 37 and 38 at scale 1, offset 16 in CI.)
    img = np.round(smooth_images(np.random.default_rng(seed), 1, 16, 16)[0] * 256) / 256
    a = np.asarray(hog(img))
    b = np.asarray(hog(img * np.float32(2.0 ** log2_scale) + np.float32(offset)))
    np.testing.assert_allclose(a, b, atol=2e-6)
    assert np.allclose([a[:64].sum(), a[64:80].sum(), a[80:].sum()], 1.0, atol=1e-5)  # each level sums to 1


@settings(max_examples=15, deadline=None)
@given(scale=st.floats(0.05, 20.0), offset=st.floats(0.0, 50.0), seed=st.integers(0, 2**16))
@example(scale=1.0, offset=16.0, seed=142)  # the case that moved a hard-binning vote in CI
def test_soft_binning_invariant_to_contrast_and_offset_up_to_rounding(scale, offset, seed):
    img = smooth_images(np.random.default_rng(seed), 1, 16, 16)[0]
    config = HOGConfig(binning="soft")
    a = np.asarray(hog(img, config))
    b = np.asarray(hog(img * scale + offset, config))
    # soft binning is continuous in the gradients: float32 rounds img * scale + offset to ~eps32 * offset,
    # relative to the contrast (scale) the error the gradients inherit
    np.testing.assert_allclose(a, b, atol=2e-5 + 1e-5 * offset / scale)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**16), k=st.integers(1, 3))
def test_rotation_by_90_degrees_permutes_bins(seed, k):
    """Rotating the image by 90 degrees turns Phi by 90 degrees: with B = 4 bins the bins shift by 2."""
    img = smooth_images(np.random.default_rng(seed), 1, 16, 16)[0]
    cfg = HOGConfig(n_levels=1)
    a = np.asarray(hog(img, cfg))
    b = np.asarray(hog(np.rot90(img, k).copy(), cfg))
    np.testing.assert_allclose(np.roll(a, 2 * k), b, atol=1e-5)


def test_batch_equals_single_and_jax_input():
    import jax.numpy as jnp
    imgs = smooth_images(np.random.default_rng(4), 5, 20, 20)
    batch = np.asarray(hog(imgs))
    for i in range(5):
        np.testing.assert_allclose(np.asarray(hog(imgs[i])), batch[i], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(np.asarray(hog(jnp.asarray(imgs))), batch, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("bad, match", [
    (np.zeros((0, 16, 16)), "images: must not be empty"),
    (np.ones((2, 2, 16, 16)), "images: expected a 2 or 3-D"),
    (np.ones(16), "images: expected a 2 or 3-D"),
    (np.stack([np.ones((16, 16)), np.zeros((16, 16))]), "images: image 1 is all zero"),
    (np.where(np.eye(16, dtype=bool), np.nan, 1.0)[None], "images: image 0 contains NaN"),
    (np.ones((2, 3, 3)), "images: 3x3 is smaller"),
])
def test_bad_images(bad, match):
    with pytest.raises(ValueError, match=match):
        hog(bad)


def test_bad_mask_and_config():
    img = np.ones((16, 16))
    with pytest.raises(ValueError, match="mask: expected shape"):
        hog(img, mask=np.ones((8, 8), bool))
    with pytest.raises(ValueError, match="mask: image 0 has no unmasked"):
        hog(img, mask=np.zeros((16, 16), bool))
    with pytest.raises(ValueError, match="config.binning"):
        hog(img, HOGConfig(binning="bilinear"))
    with pytest.raises(ValueError, match="config.n_bins"):
        hog(img, HOGConfig(n_bins=0))


# ------------------------------------------------------------------ bad input, edge cases
def test_huge_and_tiny_images_give_the_unit_scale_features():
    """Values 1e20 (finite in float32) made gx*gx overflow (81 of 84 features NaN). Images outside
    [2^-40, 2^60] are rescaled by an exact power of two: the features are those of the unit-scale image."""
    import jax.numpy as jnp
    img = np.random.default_rng(0).uniform(0, 1, (2, 24, 24)).astype(np.float32)
    for cfg in (HOGConfig(), HOGConfig(normalize="cell", binning="soft"), HOGConfig(weighting="count")):
        ref = np.asarray(hog(img, cfg))
        for scale in (2.0**70, 2.0**-70, 2.0**120):  # powers of two: bit-identical features
            np.testing.assert_array_equal(np.asarray(hog(img * np.float32(scale), cfg)), ref)
        for scale in (1e20, 3e37, 1e-30):  # rounding of the product only
            got = np.asarray(hog((img * scale).astype(np.float32), cfg))
            assert np.isfinite(got).all()
            np.testing.assert_allclose(got, ref, rtol=1e-4, atol=1e-6)
        np.testing.assert_array_equal(np.asarray(hog(jnp.asarray(img * np.float32(2.0**70)), cfg)), ref)
    raw = HOGConfig(normalize="none")
    np.testing.assert_array_equal(np.asarray(hog(img * np.float32(2.0**70), raw)),
                                  np.asarray(hog(img, raw)) * np.float32(2.0**70))  # raw sums scale back
    with pytest.raises(ValueError, match="images: the raw .* overflow float32"):
        hog(img * np.float32(1e38), raw)
    with pytest.raises(ValueError, match="images: image 0 has values up to 1e\\+39, beyond float32"):
        hog(np.full((16, 16), 1e39))
