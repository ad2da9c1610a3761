"""The imitation loop: one scripted demonstration with known answers through the
whole loop at the quick preset (rendered video -> the stereo front end -> the online PHMMs -> the
nearest object -> the robot, `sim.task_controller`), and the loop's input checks.

Fast: the recording, the front end's tracks and the PHMMs are cached under the project cache (the first
run of a fresh cache renders, tracks and trains: about a minute); the validation-chosen settings of the
quick preset (tracker offset, noise, threshold) are fixed here instead of re-running the validation."""
import numpy as np
import pytest

import phmm_jax
import sim
import sim.robot
from experiments.imitation import Config, Demo, PRESETS
from experiments.imitation import pipeline as pl
from experiments.imitation import stages as st
from experiments.imitation.demonstrations import check_demo, draw_demos
from lfd_jax import imitation as im

CFG = Config(**PRESETS["quick"])
# the quick preset's validation choices (`stages.validation_stage`, seed 1000): offset, sigma, threshold
OFFSET_M = np.array([-0.016, -0.032, 0.017])
SIGMA_M, THRESHOLD_M = 0.1, 0.08
# person 0 points at the pitcher (object 2) at the far side of the table, binoculars and cup elsewhere
DEMO = Demo("point", person=0, seed=7, objects_xy=np.array([[-0.24, -0.32], [0.10, -0.36], [-0.10, -0.47]]),
            target=2, grasp=-1, place_xy=np.array(CFG.handover_xy))


@pytest.fixture(scope="module")
def loop():
    sim.setup_rendering()
    settings = CFG.video_settings()
    rgb_skin = st.skin_models(CFG, settings)
    phmms = st.phmm_models(CFG, settings)
    rec = st.render_demo(settings, DEMO)
    tracked = pl.track(CFG, settings, DEMO, rec, rgb_skin)
    online = im.recognizer(phmms, SIGMA_M, THRESHOLD_M, CFG.online_window)
    return rec, tracked, im.recognise_demo(online, tracked, OFFSET_M, CFG.median_frames, DEMO.objects_xy,
                                           CFG.handover_xy, area=pl.AREA), phmms


def test_scripted_pointing_demonstration(loop):
    rec, tracked, r, _ = loop
    assert tracked.found.sum() >= 5                      # the front end followed the hand
    assert r.kind == "point"                             # the action
    assert r.target == DEMO.target                       # the object pointed at
    assert np.linalg.norm(r.target_xy - DEMO.objects_xy[DEMO.target]) < 0.12
    assert r.start < r.end and r.grasp == -1 and np.allclose(r.place_xy, CFG.handover_xy)


def test_robot_fetches_the_recognised_object(loop):
    _, _, r, phmms = loop
    spec = st.task_spec(CFG, DEMO, r)  # the script's object, its stand-in's grasp, to the hand-over spot
    assert spec.target == DEMO.target and spec.grasp == spec.objects[DEMO.target]
    assert np.allclose(spec.object_xy, DEMO.objects_xy) and np.allclose(spec.place_xy, CFG.handover_xy)
    reach = im.synthesised_reach(phmms[pl.REACH], spec.object_xy[spec.target], area=pl.AREA)  # the approach's shape
    assert reach.ndim == 2 and reach.shape[1] == 3 and len(reach) >= 10 and np.isfinite(reach).all()
    c = phmms[pl.REACH].config  # the reach PHMM's own mean movement gives its target back (PHMM eq. 3)
    short = im.synthesised_reach(phmms[pl.REACH], spec.object_xy[spec.target], max(c.min_length, c.max_length // 3),
                                 pl.AREA)
    xy = im.reach_target(phmms[pl.REACH], short, pl.AREA)
    assert xy is not None and np.linalg.norm(xy - spec.object_xy[spec.target]) < 0.05
    unpadded = phmm_jax.recognize([phmms[pl.REACH]], short[None], [len(short)])  # the padding changes nothing
    assert np.allclose(xy, im.phi_to_xy(np.asarray(unpadded.phi)[0, 0].astype(float), pl.AREA), atol=1e-3)
    assert im.reach_target(phmms[pl.REACH], reach[:1]) is None  # shorter than any path: flagged
    res = st.robot_task(CFG, DEMO, r, phmms)
    # this demonstration is one the robot completes: any failed stage (named in the message) fails the test
    assert res.success and res.failed_stage == "", res.failed_stage
    assert res.upright and res.released and res.stage_sim_s.get("place", 0.0) > 0  # it ran through to the place
    assert np.linalg.norm(np.asarray(res.object_pos)[:2] - CFG.handover_xy) < CFG.place_tolerance_m + 1e-6


def test_bad_input_names_the_argument():
    settings = CFG.video_settings()
    with pytest.raises(ValueError, match="demo.kind"):
        check_demo(DEMO._replace(kind="wave"), settings)
    with pytest.raises(ValueError, match="demo.grasp"):
        check_demo(DEMO._replace(kind="transfer", grasp=3), settings)
    with pytest.raises(ValueError, match="demo.objects_xy"):
        check_demo(DEMO._replace(objects_xy=np.zeros((2, 2))), settings)
    with pytest.raises(ValueError, match="P_left"):
        im.camera_rotation(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="n_demos"):
        Config(n_demos=0)
    with pytest.raises(ValueError, match="median_s"):
        Config(median_s=-0.1)
    assert (CFG.online_window, CFG.median_frames, CFG.merge_gap) == (3, 3, 10)  # 10 fps
    assert Config().median_frames % 2 == 1 and Config().merge_gap == 25  # 25 fps
    with pytest.raises(ValueError, match="approach"):
        Config(approach="teleport")
    with pytest.raises(ValueError, match="grasp_database"):
        Config(grasp_database="internet")
    with pytest.raises(ValueError, match="grasp_window_frac"):
        Config(grasp_window_frac=-0.1)
    with pytest.raises(ValueError, match="grasp_metric"):
        Config(grasp_metric="cosine")
    with pytest.raises(ValueError, match="grasp_metric"):  # LDA is fitted on the demonstrations' crops
        Config(grasp_database="study", grasp_classifier="knn", grasp_metric="lda")
    with pytest.raises(ValueError, match="grasp_lda_shrinkage"):
        Config(grasp_lda_shrinkage=1.5)
    with pytest.raises(ValueError, match="robot_hand"):
        Config(robot_hand="shadow")
    with pytest.raises(ValueError, match="robot_orientation"):
        Config(robot_orientation="upside down")


def test_hand_crop_window_keeps_a_skin_coloured_jacket_out():
    import jax
    import hog_jax
    from experiments.imitation.grasp_stage import hand_crop

    rng = np.random.default_rng(7)
    skin = hog_jax.fit_skin_model(jax.random.key(1), rng.normal([200, 140, 110], 8, (500, 3)).clip(0, 255),
                                  rng.uniform(0, 255, (500, 3)), n_components=2, n_background=2, n_iter=10)
    alone = np.full((120, 160, 3), (40, 90, 160), np.uint8)   # blue background
    alone[60:75, 100:112] = (200, 140, 110)                     # the hand (15 x 12 px)
    frame = alone.copy()
    frame[20:100, 10:80] = (200, 140, 110)                      # a large skin-coloured jacket ...
    frame[63:71, 80:100] = (200, 140, 110)                      # ... joined to the hand by a strip
    iou = lambda a, b: (a & b).sum() / (a | b).sum()            # noqa: E731
    hand = hand_crop(alone[None], (67, 106), skin, 32).masks
    whole = hand_crop(frame[None], (67, 106), skin, 32)
    win = hand_crop(frame[None], (67, 106), skin, 32, window=8)
    assert whole.found.all() and win.found.all()
    assert iou(whole.masks[0], hand[0]) < 0.65 and iou(win.masks[0], hand[0]) > 0.85  # the jacket no longer sets it
    # the window at the frame's edge is padded with background, and the hand is still found there
    edge = np.full((120, 160, 3), (40, 90, 160), np.uint8)
    edge[0:10, 150:160] = (200, 140, 110)
    assert hand_crop(edge[None], (4, 156), skin, 32, window=12).found.all()
