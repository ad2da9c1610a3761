"""hog_jax: the image side of grasp recognition (GRASP, Kjellström, Romero & Kragic 2008).

Frames -> `segment` (skin GMM, median filter, connected component, square crop; GRASP §III-A) ->
`hog` (gradient-orientation histogram pyramid, eq. 1, §IV) -> `build_index` / `query` (hyperplane
LSH, §V) or `exact_search` (k nearest neighbours) -> `predict` (distance-weighted class vote, eq. 3,
and rotation-averaged orientation, eq. 4, with sigma from eq. 5).

Public API (shapes: B images, H x W pixels, D feature length, N database points, Q queries):

* Segmentation: `fit_skin_model`, `segment` -> `Segmentation`, `adapt_skin_model`,
  `segment_adapted`, `crop_components`; mixtures `GMM`, `fit_gmm`, `gmm_log_prob`; persistence
  `save_skin_model` / `load_skin_model`; one person's skin: `adapt_to_skin`, `adapt_to_face`;
  skin-coloured non-skin: `SkinRules`, `fit_skin_rules`, `skin_rule_mask`, `static_skin`; a scene's
  light: `gray_world_gains`, `balanced_skin_model`; the model's colour (`skin_features`: (Cr, Cb), or with luma (Cr, Cb, Y)).
* HOG: `HOGConfig`, `hog(images (B, H, W))` -> (B, D), `hog_dim`.
* Search: `exact_search`, `build_index` -> `LSHIndex`, `query` -> `LSHResult`, `tune(options=
  TuneOptions(...))` -> `TuneResult`, `recall_at_k`; `mesh=` splits the database over devices.
* Learned metric: `fit_metric` -> `LinearMetric`, `apply_metric`.
* kNN: `fit` -> `KNNModel`, `predict` -> `Prediction`, `vote`, `intra_class_sigma`,
  `mean_rotation`, `euler_to_quat`, `quat_to_euler`.

The video front end is the subpackage `hog_jax.video`. Every public function validates its input
outside jit and raises `ValueError` naming the argument; "not found" is an explicit flag
(`Prediction.found`, `Segmentation.found`, index -1 / distance inf in an `LSHResult`).

Example:
    ```python
    import jax, hog_jax
    x = hog_jax.hog(images)                                 # (B, H, W) -> (B, 84): 4 bins, 3 levels
    model = hog_jax.fit(x, labels, orientations)            # sigma from eq. 5
    index = hog_jax.build_index(jax.random.key(0), x, n_bits=12, n_tables=16)
    pred = hog_jax.predict(model, hog_jax.hog(test_images), k=10, index=index)
    pred.label, pred.euler                                  # (Q,), (Q, 3)
    ```
"""
from hog_jax import video
from hog_jax._src.checks import feature_limit
from hog_jax._src.exact import LSHResult
from hog_jax._src.hands import HandBoxes, HandOptions, find_hands
from hog_jax._src.hog import HOGConfig, hog, hog_dim
from hog_jax._src.knn import (KNNModel, Prediction, euler_to_quat, fit, intra_class_sigma, mean_rotation,
                              predict, quat_to_euler, vote)
from hog_jax._src.lsh import LSHIndex, TuneOptions, TuneResult, recall_at_k, tune
from hog_jax._src.metric import LinearMetric, apply_metric, fit_metric
from hog_jax._src.search import build_index, exact_search, query
from hog_jax._src.segment import (GMM, Segmentation, SkinModel, SkinStructure, crop_components, fit_gmm,
                                  fit_skin_model, gmm_log_prob, load_skin_model, median3, rgb_to_chroma,
                                  save_skin_model, segment, skin_features, skin_log_ratio)
from hog_jax._src.skin_adapt import adapt_skin_model, adapt_to_face, adapt_to_skin, segment_adapted
from hog_jax._src.skin_rules import SkinRules, fit_skin_rules, skin_rule_mask, static_skin
from hog_jax._src.white_balance import balanced_skin_model, gray_world_gains

__all__ = [
    "GMM", "HOGConfig", "HandBoxes", "HandOptions", "KNNModel", "LSHIndex", "LSHResult", "LinearMetric", "Prediction", "Segmentation",
    "SkinModel", "SkinRules", "SkinStructure", "TuneOptions", "TuneResult", "adapt_skin_model", "adapt_to_face",
    "adapt_to_skin", "apply_metric", "balanced_skin_model", "build_index",
    "crop_components", "euler_to_quat", "exact_search", "feature_limit", "find_hands", "fit", "fit_gmm", "fit_metric",
    "fit_skin_model", "fit_skin_rules", "gmm_log_prob", "gray_world_gains", "hog", "hog_dim", "intra_class_sigma", "load_skin_model",
    "mean_rotation",
    "median3", "predict", "quat_to_euler", "query", "recall_at_k", "rgb_to_chroma", "save_skin_model", "segment",
    "segment_adapted", "skin_features", "skin_log_ratio", "skin_rule_mask", "static_skin", "tune", "vote",
]
