"""The realism steps of `lfd_jax.grasp` against their definitions: OpenCV's blur, filter and JPEG codec,
float64 numpy formulas, the noise's moments."""
import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lfd_jax import grasp

RNG = np.random.default_rng(0)
FRAMES = RNG.integers(0, 256, (3, 24, 20, 3), dtype=np.uint8)


def test_paste_backgrounds_only_where_the_foreground_is_off():
    fg = RNG.uniform(size=FRAMES.shape[:3]) < 0.4
    patches = RNG.integers(0, 256, (5, 24, 20, 3), dtype=np.uint8)
    index = np.array([4, 0, 4])
    out = grasp.paste_backgrounds(FRAMES, fg, patches, index)
    for i in range(3):
        np.testing.assert_array_equal(out[i][fg[i]], FRAMES[i][fg[i]])
        np.testing.assert_array_equal(out[i][~fg[i]], patches[index[i]][~fg[i]])
    with pytest.raises(ValueError, match="index"):
        grasp.paste_backgrounds(FRAMES, fg, patches, np.array([5, 0, 0]))


def test_background_patches_are_crops_of_the_sources():
    flat = np.full((30, 40, 3), 77, np.uint8)  # a constant frame: every crop, resized or mirrored, is constant
    ramp = np.repeat(np.arange(40, dtype=np.uint8)[None, :, None], 30, 0).repeat(3, 2)
    out = grasp.background_patches([flat, ramp], 16, 40, seed=1)
    assert out.shape == (40, 16, 16, 3) and out.dtype == np.uint8
    constant = np.all(out == 77, axis=(1, 2, 3))
    assert 0 < constant.sum() < 40  # both sources used
    rows = out[~constant, :, :, 0].astype(int)
    assert np.abs(rows - rows[:, :1]).max() <= 1  # the ramp's crops vary along x only (up to resize rounding)
    slope = np.diff(rows[:, 0], axis=1).mean(1)
    assert np.any(slope > 0) and np.any(slope < 0)  # some mirrored
    with pytest.raises(ValueError, match="images"):
        grasp.background_patches([flat.astype(np.float32)], 16, 4)


def test_adjust_light_against_a_float64_formula():
    exposure, wb, gamma = np.array([0.7, 1.0, 1.4]), np.array([[1.1, 1, 0.9], [1, 1, 1], [0.88, 1, 1.13]]), \
        np.array([0.8, 1.0, 1.25])
    want = 255.0 * np.clip(exposure[:, None, None, None] * wb[:, None, None, :] * FRAMES.astype(np.float64) / 255.0,
                           0, 1) ** gamma[:, None, None, None]
    out = grasp.adjust_light(FRAMES, exposure, wb, gamma)
    np.testing.assert_allclose(out, want, atol=1e-3)
    np.testing.assert_allclose(out[1], FRAMES[1], atol=1e-3)  # unit gains and gamma: the identity
    with pytest.raises(ValueError, match="gamma"):
        grasp.adjust_light(FRAMES, exposure, wb, np.array([1.0, 0.0, 1.0]))


def test_gaussian_blur_equals_opencv():
    sigma, radius = np.array([0.5, 1.0, 1.5]), 5
    kernels = grasp.gaussian_kernels(sigma, radius)
    out = grasp.blur(FRAMES, kernels)
    for i, s in enumerate(sigma):
        want = cv2.GaussianBlur(FRAMES[i].astype(np.float32), (2 * radius + 1, 2 * radius + 1), s,
                                borderType=cv2.BORDER_REFLECT_101)
        np.testing.assert_allclose(out[i], want, atol=1e-2)
    np.testing.assert_allclose(grasp.blur(FRAMES, grasp.gaussian_kernels(np.zeros(3), 2)), FRAMES, atol=1e-3)


def test_motion_blur_equals_opencv_filter2d_and_spreads_along_its_line():
    kernels = grasp.motion_kernels(np.array([1.0, 6.0, 9.0]), np.array([0.0, np.pi / 2, 0.7]), 5)
    np.testing.assert_allclose(kernels.sum((1, 2)), 1.0, atol=1e-6)
    np.testing.assert_allclose(kernels, kernels[:, ::-1, ::-1], atol=1e-6)  # symmetric about the centre
    assert np.count_nonzero(kernels[1][:, 5] > 1e-3) == 7 and np.all(kernels[1][:, [0, 1, 9, 10]] < 1e-6)  # vertical
    out = grasp.blur(FRAMES, kernels)
    for i in range(3):
        want = cv2.filter2D(FRAMES[i].astype(np.float32), -1, kernels[i], borderType=cv2.BORDER_REFLECT_101)
        np.testing.assert_allclose(out[i], want, atol=1e-2)


def test_noise_statistics():
    flat = np.concatenate([np.full((1, 64, 64, 3), v, np.uint8) for v in (40, 120, 200)])
    read, shot = np.array([3.0, 5.0, 0.0]), np.array([0.2, 0.0, 0.4])
    out = grasp.add_noise(flat, read, shot, seed=3)
    for i, v in enumerate((40, 120, 200)):
        d = out[i].astype(np.float64) - v
        var = read[i] ** 2 + shot[i] * v
        n = d.size
        assert abs(d.mean()) < 4 * np.sqrt(var / n)
        assert abs(d.var() / var - 1) < 4 * np.sqrt(2 / n)
    np.testing.assert_array_equal(grasp.add_noise(flat, read, shot, seed=3), out)  # seeded


def test_jpeg_equals_opencv_decode_of_encode():
    quality = np.array([30, 60, 95])
    out = grasp.jpeg_roundtrip(FRAMES, quality)
    for i, q in enumerate(quality):
        _, data = cv2.imencode(".jpg", cv2.cvtColor(FRAMES[i], cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(q)])
        np.testing.assert_array_equal(out[i], cv2.cvtColor(cv2.imdecode(data, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB))
    assert np.abs(out[0].astype(int) - FRAMES[0]).mean() > np.abs(out[2].astype(int) - FRAMES[2]).mean()


def test_sample_realism_within_its_ranges():
    p = grasp.sample_realism(400, 7, seed=2)
    assert p.patch.min() >= 0 and p.patch.max() == 6
    assert 0.7 <= p.exposure.min() and p.exposure.max() <= 1.4 and 0.8 <= p.gamma.min() and p.gamma.max() <= 1.25
    np.testing.assert_array_equal(p.white_balance[:, 1], 1.0)
    assert np.all(np.abs(np.log(p.white_balance[:, [0, 2]])) <= np.array([0.15, 0.12]) + 1e-6)
    np.testing.assert_allclose(p.kernels.sum((1, 2)), 1.0, atol=1e-5)
    assert 30 <= p.quality.min() and p.quality.max() <= 95 and p.read_sigma.max() <= 6 and p.shot_gain.max() <= 0.5
    assert p.pasted.all() and 150 < grasp.sample_realism(400, 7, seed=2, background_share=0.5).pasted.sum() < 250


@settings(max_examples=10, deadline=None)
@given(st.sampled_from(["background", "light", "blur", "noise", "jpeg"]), st.integers(0, 2 ** 16), st.booleans())
def test_realistic_frames_keep_shape_dtype_and_range(step, seed, everything):
    frames = np.random.default_rng(seed).integers(0, 256, (2, 16, 16, 3), dtype=np.uint8)
    fg = np.random.default_rng(seed + 1).uniform(size=(2, 16, 16)) < 0.5
    realism = grasp.Realism(**{s: everything or s == step for s in ("background", "light", "blur", "noise", "jpeg")})
    patches = np.zeros((3, 16, 16, 3), np.uint8)
    out = grasp.realistic_frames(frames, fg, realism, patches, seed=seed)
    assert out.shape == frames.shape and out.dtype == np.uint8
    np.testing.assert_array_equal(grasp.realistic_frames(frames, fg, realism, patches, seed=seed), out)


def test_realistic_frames_all_off_is_the_identity_and_background_needs_patches():
    fg = np.ones(FRAMES.shape[:3], bool)
    np.testing.assert_array_equal(grasp.realistic_frames(FRAMES, fg, grasp.Realism()), FRAMES)
    with pytest.raises(ValueError, match="patches"):
        grasp.realistic_frames(FRAMES, fg, grasp.Realism(background=True))


def test_background_share_pastes_that_share_of_the_frames():
    frames = np.full((200, 8, 8, 3), 9, np.uint8)
    fg = np.zeros(frames.shape[:3], bool)
    patches = np.full((2, 8, 8, 3), 200, np.uint8)
    out = grasp.realistic_frames(frames, fg, grasp.Realism(background=True, background_share=0.3), patches, seed=5)
    pasted = np.all(out == 200, axis=(1, 2, 3))
    assert np.all(pasted | np.all(out == 9, axis=(1, 2, 3)))  # a frame is pasted whole or kept whole
    np.testing.assert_array_equal(pasted, grasp.sample_realism(200, 2, 5, 0.3).pasted)
    assert 40 < pasted.sum() < 80
    with pytest.raises(ValueError, match="background_share"):
        grasp.Realism(background=True, background_share=1.5)


def test_study_config_names_the_steps(tmp_path):
    from experiments.grasp_recognition import Config
    from experiments.grasp_recognition.scene_realism import background_frames, realism_of
    assert realism_of("light+jpeg") == grasp.Realism(light=True, jpeg=True) and realism_of("none") == grasp.Realism()
    for bad in ("light+light", "fog", "background"):  # repeated, unknown, background without a folder
        with pytest.raises(ValueError, match="scene_realism|backgrounds"):
            Config(scene_realism=bad)
    with pytest.raises(ValueError, match="backgrounds"):
        background_frames(tmp_path)
