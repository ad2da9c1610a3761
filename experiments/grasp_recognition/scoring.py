"""Scoring recognised test images: accuracy with intervals on X / X' / X'' and the large set, confusion
matrices, geodesic orientation errors (all images with a hand found, and the correctly classified),
LSH recall against exact search on the same queries. One function for the study's own test sets and
for every rung of the ladder."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

import hog_jax
from experiments.data.grasp_tests import GraspTestSet, stage_subsets
from experiments.grasp_recognition.pieces import (accuracy, confusion, orientation_errors_deg, symmetric_errors_deg,
                                                  wilson_interval)
from lfd_jax.grasp import Crops, Recognised, Recogniser, features, net_labels, recognise
from sim.grasping import GRASP_CLASSES


class SetScores(NamedTuple):
    """metrics: flat, keyed like metrics.json; results: set name -> (LSH, exact) `Recognised`;
    features: set name -> (N, D'); mats: subset name -> confusion (6, 7)."""

    metrics: dict
    results: dict
    features: dict
    mats: dict


def lsh_recall(rec: Recogniser, q: np.ndarray) -> float:
    """Recall@k of the recogniser's LSH index against exact search for queries q (Q, D')."""
    exact = hog_jax.exact_search(rec.model.data, q, rec.k)
    approx = hog_jax.query(rec.lsh["index"], q, rec.k, **{k_: v for k_, v in rec.lsh.items() if k_ != "index"})
    return hog_jax.recall_at_k(approx.indices, exact.indices)


def score_sets(rec: Recogniser, tests: dict[str, GraspTestSet], crops: dict[str, Crops]) -> SetScores:
    """Recognise every crop of `tests` ({'X': ..., 'large': ...}; crops: name -> `lfd_jax.grasp.Crops`)
    by the recogniser (its network's class, or eq. 3 by its LSH index) and by eq. 3 with exact search
    (`accuracy_*_exact_knn`), and score them."""
    m, results, feats, mats = {}, {}, {}, {}
    for name, t in tests.items():
        found = crops[name].found
        feats[name] = features(rec, crops[name].images, crops[name].masks, found)
        labels = net_labels(rec, crops[name])
        lsh = recognise(rec, feats[name], found, labels=labels)
        exact = recognise(rec, feats[name], found, exact=True)  # eq. 3 by exact kNN, beside
        results[name] = (lsh, exact)
        n_right = int(np.sum(lsh.labels == t.labels))
        m[f"accuracy_{name}"] = accuracy(lsh.labels, t.labels)
        m[f"accuracy_{name}_ci95_low"], m[f"accuracy_{name}_ci95_high"] = wilson_interval(n_right, len(t.labels))
        m[f"accuracy_{name}_exact_knn"] = accuracy(exact.labels, t.labels)
        m[f"segmentation_found_rate_{name}"] = float(np.mean(found))
        m[f"lsh_recall_at_k_{name}"] = lsh_recall(rec, feats[name][found]) if found.any() else float("nan")
        has = lsh.labels >= 0  # a hand found and an orientation given (an LSH query may find no neighbour)
        m[f"recognised_rate_{name}"] = float(np.mean(has))
        e, g = orientation_errors_deg(lsh.euler[has], t.euler[has], lsh.quat[has], t.quat[has])
        sym = symmetric_errors_deg(lsh.quat[has], t.quat[has], t.labels[has])
        right = lsh.labels[has] == t.labels[has]
        m[f"orientation_geodesic_error_deg_{name}"] = float(g.mean()) if has.any() else float("nan")
        m[f"orientation_geodesic_error_deg_{name}_correct"] = float(g[right].mean()) if right.any() else float("nan")
        m[f"orientation_geodesic_error_deg_{name}_median"] = float(np.median(g)) if has.any() else float("nan")
        m[f"orientation_symmetric_error_deg_{name}_correct"] = (float(sym[right].mean()) if right.any()
                                                                else float("nan"))
        m[f"orientation_euler_error_deg_{name}"] = e.mean(0).tolist() if has.any() else [float("nan")] * 3
        mats[name] = confusion(t.labels, lsh.labels, len(GRASP_CLASSES))
    X = tests["X"]
    for sub, sel in stage_subsets(X.stage).items():
        if sub != "X":
            m[f"accuracy_{sub}"] = accuracy(results["X"][0].labels[sel], X.labels[sel])
            mats[sub] = confusion(X.labels[sel], results["X"][0].labels[sel], len(GRASP_CLASSES))
    return SetScores(m, results, feats, mats)


__all__ = ["Recognised", "SetScores", "score_sets"]
