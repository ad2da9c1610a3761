"""hog_jax: the image side of grasp recognition (GRASP, Kjellström, Romero & Kragic 2008; ECCV 2008; LfD 2009).

Pipeline: frames -> `segment` (skin GMM, median filter, connected component, crop) -> `hog`
(gradient-orientation histogram pyramid) -> `lsh.query` / `exact.exact_search` (k nearest neighbours)
-> `knn.predict` (distance-weighted class vote, eq. 3, and rotation-averaged orientation, eq. 4).

Modules, each importing only those before it: `exact` (exact search and the neighbour result type)
<- `lsh` (hyperplane LSH, tuned against `exact`) <- `knn` (classification on either); `hog` and
`segment` stand alone; all use `lfd_common` (and the private `_checks`: key and feature-range checks).

Public API (shapes: B batch, H x W pixels, D feature length, N database points, Q queries):

* Segmentation: `GMM`, `SkinModel`, `fit_gmm(key, x, n_components)`, `fit_skin_model(key, skin_rgb,
  background_rgb)`, `skin_log_ratio(model, frames)`, `segment(model, frames, ...)` -> `Segmentation`,
  `rgb_to_chroma`, `gmm_log_prob`, `median3`, `crop_components(gray, masks, seed_points, out_size)` (the
  component-and-square-crop steps of `segment` on any masks, e.g. the video pipeline's hand or object),
  `adapt_skin_model(model, frames)` (per-frame MAP-EM adaptation) and `segment_adapted` (`segment` with it),
  `save_skin_model(path, model)` / `load_skin_model(path)`
  (the structure, `SkinStructure`, and the arrays, checked on load, through `lfd_common.save_model`).
* HOG: `HOGConfig` (n_bins=4, n_levels=3, layout="pyramid"|"grid", orientation="grasp"|"abs",
  weighting="magnitude"|"count", binning="hard"|"soft", normalize="global"|"cell"|"none"),
  `hog(images (B, H, W), config, mask=None)` -> (B, D), `hog_dim(config)`.
* LSH: `build_index(key, data (N, D), n_bits, n_tables)` -> `LSHIndex`, `query(index, queries (Q, D), k, n_probes=0)`
  -> `LSHResult(indices, distances, n_scanned)`, `tune(key, data, held_out, k, target_recall)`,
  `recall_at_k`.
* Exact search: `exact_search(data, queries, k)` -> `LSHResult` (the drop-in for `query`).
* Sharded over a `jax.sharding.Mesh` (`mesh=`): `hog`, `exact_search`, `build_index` (a `ShardedLSHIndex`
  that `query` accepts: rows split, queries broadcast, top k merged; `lsh_sharded`), `run_background_batch`
  and `segment_video` (see `lfd_common.sharding`).
* A learned metric: `fit_metric(x (N, D), labels (N,), shrinkage, n_components)` -> `LinearMetric`
  (whitened LDA), `apply_metric(metric, x)` -> (N, D'): index and query the transformed features.
* kNN: `fit(data, labels, orientations)` -> `KNNModel`
  (sigma from eq. 5), `predict(model, queries, k, index=None)` -> `Prediction(label, scores, quat,
  euler, indices, distances, found)`, `intra_class_sigma`, `vote`, `mean_rotation`, `euler_to_quat`,
  `quat_to_euler`.

The video front end is the subpackage `hog_jax.video`.

Example::

    import jax, numpy as np, hog_jax
    x = hog_jax.hog(images)                                  # (B, H, W) -> (B, 84): B=4 bins, L=3 levels
    model = hog_jax.fit(x, labels, orientations)             # sigma from eq. 5
    index = hog_jax.build_index(jax.random.key(0), x, n_bits=12, n_tables=16)
    pred = hog_jax.predict(model, hog_jax.hog(test_images), k=10, index=index)
    pred.label, pred.euler                                   # (Q,), (Q, 3)

Every public function validates its numpy input (outside jit) and raises `ValueError` naming the
argument: empty batch, non-2-D image, all-zero image, NaN pixels, k larger than the database, a query
of the wrong dimension, an orientation array that does not match the labels, an int where a
`jax.random` key is expected, an empty tuning grid, n_tables * n_per_table < k (`n_per_table`), and
features beyond |x| <= 2^60 / sqrt(D) (squared distances would overflow float32).

Edge cases: images whose max |I| is outside [2^-40, 2^60] are rescaled by an exact power of two
(HOG is scale invariant under "global"/"cell" normalisation); a GMM component fitted to one point
(or identical points) gets the floor covariance reg * I (a `UserWarning` for N <= P); eq. 5 sigma = 0
(identical or all-zero features) is floored at eps_32 * max(1, max|x|) with a `UserWarning`.
"Not found": `lsh.query` returns index -1 / distance inf for missing neighbours, and `predict` with
an index marks a query with none at all by `Prediction.found` False, label -1, scores 0 and NaN
orientation (no silent fallback); exact search always finds k. `segment` marks frames without skin
by `Segmentation.found` False.
"""
from hog_jax import video
from hog_jax._src.checks import feature_limit
from hog_jax._src.exact import LSHResult, exact_search
from hog_jax._src.hog import HOGConfig, hog, hog_dim
from hog_jax._src.knn import (KNNModel, Prediction, euler_to_quat, fit, intra_class_sigma, mean_rotation,
                              predict, quat_to_euler, vote)
from hog_jax._src.lsh import LSHIndex, TuneResult, build_index, query, recall_at_k, tune
from hog_jax._src.metric import LinearMetric, apply_metric, fit_metric
from hog_jax._src.segment import (GMM, Segmentation, SkinModel, SkinStructure, crop_components, fit_gmm,
                                  fit_skin_model, gmm_log_prob, load_skin_model, median3, rgb_to_chroma,
                                  save_skin_model, segment, skin_log_ratio)
from hog_jax._src.skin_adapt import adapt_skin_model, segment_adapted

__all__ = [
    "GMM", "HOGConfig", "KNNModel", "LSHIndex", "LSHResult", "LinearMetric", "Prediction", "Segmentation",
    "SkinModel", "SkinStructure", "TuneResult", "adapt_skin_model", "apply_metric", "build_index", "crop_components", "euler_to_quat",
    "exact_search", "feature_limit", "fit", "fit_gmm", "fit_metric", "fit_skin_model", "gmm_log_prob", "hog",
    "hog_dim", "intra_class_sigma", "load_skin_model", "mean_rotation", "median3", "predict", "quat_to_euler", "query",
    "recall_at_k", "rgb_to_chroma", "save_skin_model", "segment", "segment_adapted", "skin_log_ratio", "tune", "vote",
]
