"""The recogniser of a configuration: its database's HOG (optionally through a learned linear metric),
the kNN model (eqs. 3-5) and the tuned LSH index; `recognise` gives class and orientation per crop."""
from __future__ import annotations

from typing import Any, NamedTuple

import jax
import numpy as np

import hog_jax
from experiments.config import progress
from experiments.grasp_recognition.classifier import classify, fit_classifier
from experiments.grasp_recognition.config import Config
from experiments.grasp_recognition.convnet import ConvClassifier, cached_convnet, classify_crops, fit_convnet
from experiments.data.grasp_database import randomized_scenes
from experiments.grasp_recognition.pieces import Crops, hog_features, knn_predict, segment_frames
from sim.grasping import GRASP_CLASSES


class Recogniser(NamedTuple):
    """hog: the HOG settings; metric: a `hog_jax.LinearMetric` or None (plain HOG distance); model: the
    kNN model on the database's (transformed) features; lsh: `hog_jax.predict`'s index arguments; tune:
    the `hog_jax.TuneResult` they came from; k; db: the database (images, labels, orientations); net: a
    `classifier.NetClassifier` (on HOG) or a `convnet.ConvClassifier` (on the crops) that gives the class
    instead of eq. 3's vote, or None."""

    hog: hog_jax.HOGConfig
    metric: Any
    model: hog_jax.KNNModel
    lsh: dict
    tune: hog_jax.TuneResult
    k: int
    db: Any
    net: Any = None


class Recognised(NamedTuple):
    """labels (N,) (-1: no hand found or no neighbour), euler (N, 3), quat (N, 4), indices and distances
    of the k neighbours (N, k) (-1 / inf where none)."""

    labels: np.ndarray
    euler: np.ndarray
    quat: np.ndarray
    indices: np.ndarray
    distances: np.ndarray


def hog_config(cfg: Config) -> hog_jax.HOGConfig:
    return hog_jax.HOGConfig(n_bins=cfg.n_bins, n_levels=cfg.n_levels, binning=cfg.hog_binning,
                             normalize=cfg.hog_normalize)


def transformed(metric, x: np.ndarray) -> np.ndarray:
    return x if metric is None else np.asarray(hog_jax.apply_metric(metric, x))


def build_recogniser(cfg: Config, key, db, tune_images: Crops | None, skin=None) -> Recogniser:
    """HOG of the database `db` (a `sim.ViewDatabase`-like record), the metric (cfg.metric, fitted on the
    database only), the kNN model and an LSH index tuned for recall@k on `tune_images` (cfg.lsh_tuning
    says whether they are database-like held-out views or query-like images); None: no index (exact
    search only; `lsh` empty, `tune` None). `skin`: the skin model that segments the queries, which
    the scene convnet (cfg.classifier "scene_cnn") segments its training scenes with."""
    hcfg = hog_config(cfg)
    x = hog_features(db.images, db.masks, np.ones(len(db.labels), bool), hcfg)
    metric = (hog_jax.fit_metric(x, db.labels, shrinkage=cfg.metric_shrinkage, n_components=cfg.metric_components or None)
              if cfg.metric == "lda" else None)
    net = None
    if cfg.classifier == "mlp":
        net = fit_classifier(x, db.labels, len(GRASP_CLASSES), cfg.seed, cfg.classifier_hidden, cfg.classifier_epochs,
                             progress=lambda it, total: progress(it, desc="train", total=total))
    elif cfg.classifier == "cnn":
        net = trained_convnet(cfg, db)
    elif cfg.classifier == "scene_cnn":
        if skin is None:
            raise ValueError("skin: the scene convnet needs the skin model that segments the queries")
        net = trained_scene_convnet(cfg, skin)
    x = transformed(metric, x)
    model = hog_jax.fit(x, db.labels, db.euler, n_classes=len(GRASP_CLASSES), seed=cfg.seed)
    if tune_images is None:
        return Recogniser(hcfg, metric, model, {}, None, cfg.k, db, net)
    t = tune_images
    q = transformed(metric, hog_features(t.images, t.masks, t.found, hcfg)[t.found])
    tune = hog_jax.tune(jax.random.fold_in(key, 2), x, q, k=cfg.k,
                        options=hog_jax.TuneOptions(target_recall=cfg.lsh_target_recall, n_probes=cfg.lsh_probes))
    index = hog_jax.build_index(jax.random.fold_in(key, 3), x, tune.n_bits, tune.n_tables)
    lsh = dict(index=index, n_per_table=tune.n_per_table, n_tables=tune.n_tables, max_rerank=tune.max_rerank,
               n_probes=cfg.lsh_probes)
    return Recogniser(hcfg, metric, model, lsh, tune, cfg.k, db, net)


def trained_convnet(cfg: Config, db) -> ConvClassifier:
    """The convnet trained on the database `db` (cached by the database's content and the settings)."""
    settings = dict(database=(db.images, db.masks, db.labels), seed=cfg.seed, width=cfg.cnn_width,
                    epochs=cfg.cnn_epochs)
    return cached_convnet(settings, lambda: fit_convnet(
        db.images, db.masks, db.labels, len(GRASP_CLASSES), cfg.seed, cfg.cnn_width, cfg.cnn_epochs,
        progress=lambda it, total: progress(it, desc="train convnet", total=total)))


def trained_scene_convnet(cfg: Config, skin) -> ConvClassifier:
    """The convnet on the unmasked boxes around the hand (`convnet`, context input), trained on
    `cfg.n_scenes` rendered scenes per grasp (`randomized_scenes`, `cfg.n_scene_hands` hands each)
    segmented by `skin` as the queries are (cfg.skin_adaptation); cached by the scenes' settings, the
    skin model's arrays and the training settings (the segmentation runs only to train)."""
    settings = dict(scenes=cfg.n_scenes, hands=cfg.n_scene_hands, frame=cfg.frame_size, skin=skin,
                    adaptation=cfg.skin_adaptation, crop=cfg.crop_size, seed=cfg.seed, width=cfg.cnn_width,
                    epochs=cfg.cnn_epochs)

    def train():
        scenes = randomized_scenes(cfg.n_scenes, cfg.n_scene_hands, cfg.seed, cfg.frame_size,
                                   progress=lambda it, total, d: progress(it, desc=d, total=total))
        crops = segment_frames(skin, scenes.frames, cfg.crop_size, adaptation=cfg.skin_adaptation)
        c = crops.take(crops.found)
        return fit_convnet(c.images, c.masks, scenes.labels[crops.found], len(GRASP_CLASSES), cfg.seed, cfg.cnn_width,
                           cfg.cnn_epochs, progress=lambda it, total: progress(it, desc="train scene convnet",
                                                                               total=total), context=c.context)

    return cached_convnet(settings, train, context=True)


def features(rec: Recogniser, images, masks, found) -> np.ndarray:
    """(N, D') features of crops (N, S, S) with masks; rows where `found` is False are zero (unused)."""
    return transformed(rec.metric, hog_features(images, masks, found, rec.hog)) * found[:, None]


def net_labels(rec: Recogniser, crops: Crops) -> np.ndarray | None:
    """(N,) the network's classes of the crops (-1 where no hand was found), or None without a network."""
    if rec.net is None:
        return None
    labels = np.full(len(crops.found), -1, np.int32)
    if not crops.found.any():
        return labels
    c = crops.take(crops.found)
    if isinstance(rec.net, ConvClassifier):
        labels[crops.found] = classify_crops(rec.net, c.images, c.masks, context=c.context)
    else:
        labels[crops.found] = classify(rec.net, hog_features(c.images, c.masks, c.found, rec.hog))
    return labels


def _class_orientation(rec: Recogniser, x: np.ndarray, labels: np.ndarray) -> Recognised:
    """Eq. 4 for given classes: the k nearest database views of each query's class (exact search within
    the class), their distance-weighted quaternion mean."""
    k = min(rec.k, int(np.bincount(np.asarray(rec.model.labels)).min()))
    out = Recognised(labels.copy(), np.full((len(x), 3), np.nan, np.float32), np.full((len(x), 4), np.nan, np.float32),
                     np.full((len(x), k), -1, np.int32), np.full((len(x), k), np.inf, np.float32))
    db_labels = np.asarray(rec.model.labels)
    for c in np.unique(labels[labels >= 0]):  # one exact search per class (6 at most), not per query
        sel, rows = labels == c, np.flatnonzero(db_labels == c)
        res = hog_jax.exact_search(rec.model.data[rows], x[sel], k)
        idx = rows[np.asarray(res.indices)]
        _, _, quat = hog_jax.vote(np.full(idx.shape, c), res.distances, rec.model.quats[idx], rec.model.sigma,
                                  rec.model.n_classes)
        out.quat[sel], out.indices[sel], out.distances[sel] = np.asarray(quat), idx, np.asarray(res.distances)
        out.euler[sel] = np.asarray(hog_jax.quat_to_euler(quat))
    return out


def recognise(rec: Recogniser, x: np.ndarray, ok: np.ndarray, exact: bool = False,
              labels: np.ndarray | None = None) -> Recognised:
    """Class (eq. 3) and orientation (eq. 4) of the features `x` (N, D') where `ok`; by the LSH index, or
    by exact search when `exact`. With `labels` (N,) from a network (`net_labels`): those classes, and
    eq. 4 from the nearest views of each one's class."""
    if labels is not None:
        return _class_orientation(rec, x, np.where(ok, labels, -1))
    k = min(rec.k, len(rec.model.labels))
    return Recognised(*knn_predict(rec.model, x, ok, k, **({} if exact else rec.lsh)))
