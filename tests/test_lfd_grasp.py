"""lfd_jax.grasp at its boundary: GRASP's recogniser on a small synthetic database, the options agree
with the grasp recognition study's defaults, and bad input is refused naming the argument."""
import dataclasses

import jax
import numpy as np
import pytest

from experiments.data.grasp_database import DatabaseOptions
from experiments.grasp_recognition.config import Config
from lfd_jax import grasp
from sim.grasping import GRASP_CLASSES, ViewDatabase


def _bars(n_per_class: int, seed: int, size: int = 32) -> ViewDatabase:
    """Crops of a bar through the centre, one orientation per class (30 degrees apart), slightly
    jittered; labelled like a view database (euler: the bar's angle as azimuth)."""
    rng = np.random.default_rng(seed)
    labels = np.repeat(np.arange(len(GRASP_CLASSES)), n_per_class).astype(np.int32)
    angles = np.radians(30.0 * labels + rng.uniform(-4.0, 4.0, len(labels)))
    r, c = np.mgrid[:size, :size] - (size - 1) / 2.0
    dist = np.abs(r[None] * np.cos(angles)[:, None, None] - c[None] * np.sin(angles)[:, None, None])
    masks = (dist < 3.0) & (np.hypot(r, c)[None] < size / 2.5)
    images = (masks * rng.uniform(0.5, 1.0, (len(labels), 1, 1))).astype(np.float32)
    euler = np.stack([angles, np.zeros_like(angles), np.zeros_like(angles)], 1).astype(np.float32)
    quat = np.tile(np.array([1.0, 0.0, 0.0, 0.0], np.float32), (len(labels), 1))
    return ViewDatabase(images=images, masks=masks, euler=euler, quat=quat, labels=labels,
                        azimuth_deg=np.degrees(angles), elevation_deg=np.zeros(len(labels)))


def test_options_have_the_grasp_study_s_defaults():
    study = Config()
    for cls in (grasp.RecogniserOptions, DatabaseOptions):
        for f in dataclasses.fields(cls):
            assert getattr(cls(), f.name) == getattr(study, f.name), (cls.__name__, f.name)


def test_recogniser_recognises_held_out_views_by_knn_and_by_lsh():
    db, queries = _bars(12, 0), _bars(4, 1)
    tune = grasp.Crops(queries.images, queries.masks, np.ones(len(queries.labels), bool), queries.images)
    rec = grasp.build_recogniser(grasp.RecogniserOptions(k=3), jax.random.key(0), db, tune)
    found = np.ones(len(queries.labels), bool)
    found[0] = False
    x = grasp.features(rec, queries.images, queries.masks, found)
    assert np.all(x[0] == 0)
    for exact in (True, False):
        out = grasp.recognise(rec, x, found, exact=exact)
        assert out.labels[0] == -1 and np.isnan(out.quat[0]).all()
        assert np.mean(out.labels[1:] == queries.labels[1:]) >= 0.9
    assert grasp.net_labels(rec, tune) is None


def test_bad_input_is_refused_naming_the_argument():
    db = _bars(4, 2)
    images, masks = db.images, db.masks
    found = np.ones(len(images), bool)
    config = grasp.hog_config(grasp.RecogniserOptions())
    with pytest.raises(ValueError, match="classifier"):
        grasp.RecogniserOptions(classifier="svm")
    with pytest.raises(ValueError, match="^k: "):
        grasp.RecogniserOptions(k=0)
    with pytest.raises(ValueError, match="options"):
        grasp.build_recogniser({"k": 3}, jax.random.key(0), db)
    with pytest.raises(ValueError, match="net"):
        grasp.build_recogniser(grasp.RecogniserOptions(classifier="scene_cnn"), jax.random.key(0), db)
    with pytest.raises(ValueError, match="db"):
        grasp.build_recogniser(grasp.RecogniserOptions(), jax.random.key(0), (images, masks))
    with pytest.raises(ValueError, match="db.labels"):
        grasp.build_recogniser(grasp.RecogniserOptions(), jax.random.key(0), db._replace(labels=db.labels + 6))
    with pytest.raises(ValueError, match="masks"):
        grasp.hog_features(images, masks[:, :8], found, config)
    with pytest.raises(ValueError, match="images"):
        grasp.hog_features(np.where(masks, np.nan, images), masks, found, config)
    with pytest.raises(ValueError, match="images"):
        grasp.hog_features(images[:0], masks[:0], found[:0], config)
    with pytest.raises(ValueError, match="found"):
        grasp.hog_features(images, masks, found[1:], config)
    x = grasp.hog_features(images, masks, found, config)
    with pytest.raises(ValueError, match="^x: "):
        grasp.fit_classifier(np.where(x > 0, np.nan, x), db.labels, 6)
    with pytest.raises(ValueError, match="labels"):
        grasp.fit_classifier(x, db.labels + 6, 6)
    with pytest.raises(ValueError, match="ok"):
        grasp.knn_predict(None, x, found[1:], 3)
    with pytest.raises(ValueError, match="frames"):
        grasp.segment_frames(None, np.zeros((2, 16, 16), np.uint8), 32)
    with pytest.raises(ValueError, match="adaptation"):
        grasp.segment_frames(None, np.zeros((2, 16, 16, 3), np.uint8), 32, adaptation="all")
    rec = grasp.build_recogniser(grasp.RecogniserOptions(k=3), jax.random.key(0), db)
    with pytest.raises(ValueError, match="^x: "):
        grasp.recognise(rec, x[0], found)
    with pytest.raises(ValueError, match="rec"):
        grasp.features(rec._asdict(), images, masks, found)
    with pytest.raises(ValueError, match="crops"):
        grasp.net_labels(rec, (images, masks, found))
    clf = grasp.fit_classifier(x, db.labels, 6, hidden=8, epochs=1, batch=8)
    with pytest.raises(ValueError, match="^x: "):
        grasp.classify(clf, x[:, :5])
