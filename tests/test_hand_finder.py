"""hog_jax.find_hands: "not found" without a hand, the hand cut from its forearm against a box worked
out by hand, option validation."""
import jax
import numpy as np
import pytest

import hog_jax

SKIN_RGB, BACKGROUND_RGB = (205, 140, 115), (70, 90, 150)


@pytest.fixture(scope="module")
def model():
    rng = np.random.default_rng(0)
    skin = np.clip(rng.normal(SKIN_RGB, 8, size=(400, 3)), 0, 255)
    other = np.clip(np.concatenate([rng.normal(BACKGROUND_RGB, 20, size=(300, 3)),
                                    rng.uniform(0, 255, size=(200, 1)).repeat(3, 1)]), 0, 255)
    return hog_jax.fit_skin_model(jax.random.key(0), skin, other, n_components=2, n_background=3, n_iter=30)


def textured(rng, h=120, w=160):
    """A background of blue cloth with grey grain: no skin colour anywhere."""
    grain = rng.normal(0, 12, size=(h, w, 1))
    return np.clip(np.array(BACKGROUND_RGB) + grain, 0, 255).astype(np.uint8)


def test_not_found_without_a_hand(model):
    frames = textured(np.random.default_rng(1))[None]
    res = hog_jax.find_hands(model, frames)
    assert res.boxes.shape == (1, 2, 4) and res.found.shape == (1, 2)
    assert not np.asarray(res.found).any()
    assert (np.asarray(res.boxes) == -1).all() and (np.asarray(res.scores) == 0).all()


def test_hand_cut_from_forearm_entering_from_bottom(model):
    frame = textured(np.random.default_rng(2))
    frame[20:60, 65:95] = SKIN_RGB     # the hand: rows 20-59, cols 65-94
    frame[60:120, 70:90] = SKIN_RGB    # the forearm, 20 px wide, entering from the bottom edge
    # By hand: the entry is the middle of the rows within the edge band (0.03 x 120 -> 4 rows: 116-119),
    # row 117.5; the farthest pixels are the hand's top corners, so the arm runs straight up; its far end
    # is row 20 (t = 97.5), its width over the near half (rows 70-117) is 20 px, and the hand is the part
    # within 2 widths = 40 px of the far end: t >= 57.5, rows 20-60 (row 60 is the arm's first row).
    res = hog_jax.find_hands(model, frame[None], hog_jax.HandOptions(hand_length=2.0, edge_band=0.03))
    assert bool(res.found[0, 0]) and not bool(res.found[0, 1])
    np.testing.assert_allclose(np.asarray(res.boxes)[0, 0], [20, 65, 61, 95], atol=1)
    np.testing.assert_allclose(np.asarray(res.arm_boxes)[0, 0], [20, 65, 120, 95], atol=1)
    # the same blob not entering from any edge is all hand
    whole = hog_jax.find_hands(model, frame[None], hog_jax.HandOptions(entry_edges=()))
    np.testing.assert_allclose(np.asarray(whole.boxes)[0, 0], [20, 65, 120, 95], atol=1)


def test_boxes_in_input_pixels_at_a_smaller_working_resolution(model):
    frame = np.repeat(np.repeat(textured(np.random.default_rng(3)), 2, 0), 2, 1)   # 240 x 320
    frame[40:120, 130:190] = SKIN_RGB                                                # a blob in the middle
    res = hog_jax.find_hands(model, frame[None], hog_jax.HandOptions(max_side=160))
    np.testing.assert_allclose(np.asarray(res.boxes)[0, 0], [40, 130, 120, 190], atol=2)


def test_saturated_frame_resized_with_rules(model):
    # a white (255) wall around the hand: the working-size resize must stay within [0, 255], which the
    # skin rules check; the box is the blob's, as at full size (the rules are all off)
    frame = np.full((240, 320, 3), 255, np.uint8)
    frame[40:120, 130:190] = SKIN_RGB
    res = hog_jax.find_hands(model, frame[None], hog_jax.HandOptions(max_side=160, rules=hog_jax.SkinRules()))
    assert bool(res.found[0, 0])
    np.testing.assert_allclose(np.asarray(res.boxes)[0, 0], [40, 130, 120, 190], atol=2)


@pytest.mark.parametrize("field, value", [("max_hands", 0), ("entry_edges", ("up",)), ("min_score", 2.0),
                                          ("hand_length", 0.0), ("min_area", 1.0), ("max_side", 8),
                                          ("adapt", 1), ("rules", "none")])
def test_bad_options_name_the_field(model, field, value):
    frames = np.zeros((1, 32, 32, 3), np.uint8)
    with pytest.raises(ValueError, match=field):
        hog_jax.find_hands(model, frames, hog_jax.HandOptions(**{field: value}))


def test_bad_frames_and_model(model):
    with pytest.raises(ValueError, match="frames"):
        hog_jax.find_hands(model, np.zeros((32, 32, 3)))
    with pytest.raises(ValueError, match="frames"):
        hog_jax.find_hands(model, np.full((1, 32, 32, 3), 300.0))
    with pytest.raises(ValueError, match="model"):
        hog_jax.find_hands("skin", np.zeros((1, 32, 32, 3)))


def test_the_grasp_study_skips_the_real_photos_without_the_data(tmp_path, capsys):
    from experiments.grasp_recognition.config import Config
    from experiments.grasp_recognition.stages import real_photos_stage

    # a stage that skips needs no recogniser (the study's setup)
    assert real_photos_stage(Config(), None).metrics == {}  # off by default
    assert real_photos_stage(Config(real_photos=str(tmp_path)), None).metrics == {"real_photos_scored": False}
    assert "the real-photo stage is skipped" in capsys.readouterr().out
