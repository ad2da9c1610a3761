"""GRASP's recogniser (Kjellström, Romero & Kragic 2008): the database's HOG pyramids (§IV), optionally
through a learned linear metric, the distance-weighted kNN model (§V, eqs. 3-5) and a tuned hyperplane
LSH index (§V, eq. 2); `recognise` gives the class and orientation of each query crop, optionally with
the class from a trained network instead of eq. 3's vote.

Shapes: V database views, N queries, S x S crops, D (D') (transformed) features, k neighbours.
"""
from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import jax
import numpy as np

import hog_jax
from lfd_common import as_array, check_choice, check_int, check_real, progress
from lfd_jax.grasp._src.classifier import NetClassifier, classify, fit_classifier
from lfd_jax.grasp._src.convnet import ConvClassifier, cached_convnet, classify_crops, fit_convnet
from lfd_jax.grasp._src.crops import Crops
from lfd_jax.grasp._src.knn import hog_features, knn_predict
from sim.grasping import GRASP_CLASSES

CLASSIFIERS = ("knn", "mlp", "cnn", "scene_cnn")


@dataclasses.dataclass(frozen=True)
class RecogniserOptions:
    """How `build_recogniser` builds a recogniser; the defaults are GRASP's method (§IV-V).

    Attributes:
        seed: the seed of the kNN model, the networks and (through `build_recogniser`'s key) LSH.
        k: neighbours of eqs. 3-4.
        n_bins: B, orientation bins of the HOG pyramid (§IV; paper: 4).
        n_levels: L, levels of the HOG pyramid (§IV; paper: 3).
        hog_binning: "hard" or "soft" orientation binning (`hog_jax.HOGConfig`).
        hog_normalize: "global", "cell" or "none" (`hog_jax.HOGConfig`).
        metric: "none" (Euclidean HOG distance, the paper's) or "lda" (whitened LDA fitted on the
            database, `hog_jax.fit_metric`).
        metric_shrinkage: the LDA's covariance shrinkage in [0, 1].
        metric_components: the LDA's output dimensions (0: all D, whitening only).
        classifier: where the class comes from: "knn" (eq. 3's vote), "mlp" (a perceptron on HOG,
            `fit_classifier`), "cnn" (a convnet on the crops, `fit_convnet`, trained on the database) or
            "scene_cnn" (a convnet on the unmasked boxes around the hand, trained by the caller on
            rendered scenes and passed to `build_recogniser`); orientation is eq. 4 within the class.
        classifier_hidden: the perceptron's hidden units.
        classifier_epochs: the perceptron's training epochs.
        cnn_width: the convnet's first layer's channels.
        cnn_epochs: the convnet's training epochs.
        lsh_target_recall: the recall@k the LSH index is tuned to (`hog_jax.tune`).
        lsh_probes: multi-probe LSH: buckets read per table besides the query's.

    Raises:
        ValueError: a field out of range or not one of its choices (the message names it).
    """

    seed: int = 0
    k: int = 10
    n_bins: int = 4
    n_levels: int = 3
    hog_binning: str = "hard"
    hog_normalize: str = "global"
    metric: str = "none"
    metric_shrinkage: float = 0.1
    metric_components: int = 0
    classifier: str = "knn"
    classifier_hidden: int = 512
    classifier_epochs: int = 30
    cnn_width: int = 16
    cnn_epochs: int = 10
    lsh_target_recall: float = 0.9
    lsh_probes: int = 0

    def __post_init__(self):
        check_int(self.seed, "seed", min_value=0)
        for name in ("k", "n_bins", "n_levels", "classifier_hidden", "classifier_epochs", "cnn_width", "cnn_epochs"):
            check_int(getattr(self, name), name, min_value=1)
        for name in ("metric_components", "lsh_probes"):
            check_int(getattr(self, name), name, min_value=0)
        check_choice(self.hog_binning, "hog_binning", ("hard", "soft"))
        check_choice(self.hog_normalize, "hog_normalize", ("global", "cell", "none"))
        check_choice(self.metric, "metric", ("none", "lda"))
        check_choice(self.classifier, "classifier", CLASSIFIERS)
        check_real(self.metric_shrinkage, "metric_shrinkage", min_value=0.0, max_value=1.0)
        check_real(self.lsh_target_recall, "lsh_target_recall", min_value=0.0, max_value=1.0, exclusive_min=True)


class Recogniser(NamedTuple):
    """A built recogniser (`build_recogniser`).

    Attributes:
        hog: the HOG settings (`hog_config`).
        metric: a `hog_jax.LinearMetric`, or None (plain HOG distance).
        model: the kNN model (`hog_jax.KNNModel`, eqs. 3-5) on the database's (transformed) features.
        lsh: `hog_jax.predict`'s index arguments (empty: exact search only).
        tune: the `hog_jax.TuneResult` the index came from, or None.
        k: neighbours of eqs. 3-4.
        db: the database (images, masks, labels, orientations), or None.
        net: a `NetClassifier` (on HOG) or a `ConvClassifier` (on the crops) that gives the class
            instead of eq. 3's vote, or None.
    """

    hog: hog_jax.HOGConfig
    metric: Any
    model: hog_jax.KNNModel
    lsh: dict
    tune: hog_jax.TuneResult
    k: int
    db: Any
    net: Any = None


class Recognised(NamedTuple):
    """What `recognise` gives for N queries.

    Attributes:
        labels: (N,) class indices into `sim.grasping.GRASP_CLASSES` (-1: no hand found or no neighbour).
        euler: (N, 3) orientation as Euler angles (radians; NaN where none).
        quat: (N, 4) orientation as a quaternion (eq. 4; NaN where none).
        indices: (N, k) database indices of the neighbours (-1 where none).
        distances: (N, k) their distances (inf where none).
    """

    labels: np.ndarray
    euler: np.ndarray
    quat: np.ndarray
    indices: np.ndarray
    distances: np.ndarray


def _check_options(options) -> RecogniserOptions:
    if not isinstance(options, RecogniserOptions):
        raise ValueError(f"options: expected a RecogniserOptions, got {type(options).__name__}")
    return options


def hog_config(options: RecogniserOptions) -> hog_jax.HOGConfig:
    """The HOG settings of a recogniser (GRASP §IV).

    Args:
        options: the recogniser's options.

    Returns:
        A `hog_jax.HOGConfig` with B = `n_bins`, L = `n_levels`, the binning and the normalisation.

    Raises:
        ValueError: `options` is not a `RecogniserOptions`.
    """
    cfg = _check_options(options)
    return hog_jax.HOGConfig(n_bins=cfg.n_bins, n_levels=cfg.n_levels, binning=cfg.hog_binning,
                             normalize=cfg.hog_normalize)


def transformed(metric, x: np.ndarray) -> np.ndarray:
    """Features through a learned linear metric.

    Args:
        metric: a `hog_jax.LinearMetric`, or None (the identity).
        x: (N, D) features.

    Returns:
        (N, D') the transformed features (`x` itself when `metric` is None).
    """
    return x if metric is None else np.asarray(hog_jax.apply_metric(metric, x))


def _check_database(db) -> None:
    for name in ("images", "masks", "labels", "euler"):
        if not hasattr(db, name):
            raise ValueError(f"db: expected a view database with images, masks, labels and euler, "
                             f"got {type(db).__name__}")
    images = as_array(db.images, "db.images", ndim=3, dtype=None, finite=False)
    as_array(db.masks, "db.masks", shape=images.shape, dtype=None)
    as_array(db.labels, "db.labels", shape=(len(images),), dtype=np.int64, min_value=0,
             max_value=len(GRASP_CLASSES) - 1)
    as_array(db.euler, "db.euler", shape=(len(images), 3), dtype=None)


def build_recogniser(options: RecogniserOptions, key, db, tune_images: Crops | None = None,
                     net=None) -> Recogniser:
    """Build GRASP's recogniser on a view database (§IV-V).

    The HOG pyramid of every database view (§IV), the metric (`options.metric`, fitted on the database
    only), the network that gives the class (`options.classifier`), the distance-weighted kNN model
    (eqs. 3-5) and an LSH index (§V) tuned for recall@k on `tune_images`.

    Args:
        options: the recogniser's options.
        key: a JAX random key (LSH tuning and hyperplanes).
        db: the view database (a `sim.grasping.ViewDatabase`-like record: images (V, S, S), masks,
            labels (V,) into `GRASP_CLASSES`, euler (V, 3)).
        tune_images: query-like or held-out database-like crops to tune the LSH index on; None: no
            index (exact search only: `lsh` empty, `tune` None).
        net: a trained `NetClassifier` or `ConvClassifier` that gives the class instead of eq. 3's
            vote; None: as `options.classifier` says ("knn": none; "mlp", "cnn": trained here on the
            database, the convnet cached by `cached_convnet`). Required for "scene_cnn", whose
            training scenes come from the caller.

    Returns:
        The `Recogniser`.

    Raises:
        ValueError: `options` is not a `RecogniserOptions`, `db` is not a view database of finite
            arrays of matching shapes, or `net` is missing for "scene_cnn" or of another type (the
            message names the argument).
    """
    cfg = _check_options(options)
    _check_database(db)
    if net is not None and not isinstance(net, (NetClassifier, ConvClassifier)):
        raise ValueError(f"net: expected a NetClassifier, a ConvClassifier or None, got {type(net).__name__}")
    if cfg.classifier == "scene_cnn" and net is None:
        raise ValueError("net: the scene convnet is trained on rendered scenes by the caller; pass it")
    if tune_images is not None and not isinstance(tune_images, Crops):
        raise ValueError(f"tune_images: expected Crops or None, got {type(tune_images).__name__}")
    hcfg = hog_config(cfg)
    x = hog_features(db.images, db.masks, np.ones(len(db.labels), bool), hcfg)
    metric = (hog_jax.fit_metric(x, db.labels, shrinkage=cfg.metric_shrinkage, n_components=cfg.metric_components or None)
              if cfg.metric == "lda" else None)
    if net is None and cfg.classifier == "mlp":
        net = fit_classifier(x, db.labels, len(GRASP_CLASSES), cfg.seed, cfg.classifier_hidden, cfg.classifier_epochs,
                             progress=lambda it, total: progress(it, desc="train", total=total))
    elif net is None and cfg.classifier == "cnn":
        net = trained_convnet(cfg, db)
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


def trained_convnet(options: RecogniserOptions, db) -> ConvClassifier:
    """The convnet on the hand crops (`fit_convnet`) trained on a view database, cached.

    Cached by `cached_convnet`, keyed by the database's content and the training settings.

    Args:
        options: the recogniser's options (`seed`, `cnn_width`, `cnn_epochs`).
        db: the view database (images (V, S, S) with S a multiple of 16, masks, labels (V,)).

    Returns:
        The trained `ConvClassifier` (hand-only input).

    Raises:
        ValueError: `options` is not a `RecogniserOptions`, or the database's arrays are not what
            `fit_convnet` accepts (the message names the argument).
    """
    cfg = _check_options(options)
    settings = dict(database=(db.images, db.masks, db.labels), seed=cfg.seed, width=cfg.cnn_width,
                    epochs=cfg.cnn_epochs)
    return cached_convnet(settings, lambda: fit_convnet(
        db.images, db.masks, db.labels, len(GRASP_CLASSES), cfg.seed, cfg.cnn_width, cfg.cnn_epochs,
        progress=lambda it, total: progress(it, desc="train convnet", total=total)))


def _check_recogniser(rec) -> Recogniser:
    if not isinstance(rec, Recogniser):
        raise ValueError(f"rec: expected a Recogniser, got {type(rec).__name__}")
    return rec


def features(rec: Recogniser, images, masks, found) -> np.ndarray:
    """The recogniser's features of hand crops: HOG (§IV), through its metric.

    Args:
        rec: the recogniser.
        images: (N, S, S) grey crops times their masks, N >= 1.
        masks: (N, S, S) bool hand masks.
        found: (N,) bool; False where no hand was found.

    Returns:
        (N, D') features; rows where `found` is False are zero (unused).

    Raises:
        ValueError: `rec` is not a `Recogniser`, or the crops are not as `hog_features` accepts them
            (the message names the argument).
    """
    rec = _check_recogniser(rec)
    return transformed(rec.metric, hog_features(images, masks, found, rec.hog)) * found[:, None]


def net_labels(rec: Recogniser, crops: Crops) -> np.ndarray | None:
    """The recogniser's network's classes of hand crops.

    Args:
        rec: the recogniser.
        crops: the N crops (a network trained on context reads their `context`).

    Returns:
        (N,) int32 class indices (-1 where no hand was found), or None when the recogniser has no
        network.

    Raises:
        ValueError: `rec` is not a `Recogniser` or `crops` not `Crops`, or the crops are not what the
            network accepts (the message names the argument).
    """
    rec = _check_recogniser(rec)
    if not isinstance(crops, Crops):
        raise ValueError(f"crops: expected Crops, got {type(crops).__name__}")
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
    """Class (GRASP §V, eq. 3) and orientation (eq. 4) of query features.

    Args:
        rec: the recogniser.
        x: (N, D') query features (`features`).
        ok: (N,) bool; rows where it is False (no hand found) are not queried.
        exact: exact kNN search instead of the recogniser's LSH index.
        labels: optional (N,) classes from a network (`net_labels`): those classes, and eq. 4 from the
            nearest database views of each one's class.

    Returns:
        The `Recognised` classes, orientations and neighbours.

    Raises:
        ValueError: `rec` is not a `Recogniser`, `x` is not a finite (N, D') array, or `ok` / `labels`
            do not match it (the message names the argument).
    """
    rec = _check_recogniser(rec)
    x = as_array(x, "x", ndim=2, dtype=None, nonempty=False)
    ok = as_array(ok, "ok", shape=(len(x),), dtype=bool, nonempty=False)
    if labels is not None:
        labels = as_array(labels, "labels", shape=(len(x),), dtype=None, nonempty=False)
        return _class_orientation(rec, x, np.where(ok, labels, -1))
    k = min(rec.k, len(rec.model.labels))
    return Recognised(*knn_predict(rec.model, x, ok, k, **({} if exact else rec.lsh)))
