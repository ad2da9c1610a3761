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

Video (LEVELSET TR §3-5; LfD 2009 §III-A; T frames, R regions):

* Background (`background`, TR §3.5, eqs. 9-10, Stauffer–Grimson): `BackgroundStructure`,
  `BackgroundOptions`, `BackgroundState`, `init_background`, `run_background(frames (T, H, W, 3),
  no_update_masks)` -> (state, foreground (T, H, W)), `run_background_batch` (B videos);
  `background.update` for one frame, `background.log_density` for eq. 9's P(X).
* Colour models (`colour_models`, TR §3.4, eq. 8): `fit_gmm_bic`, `fit_person_background_models`,
  `region_log_likelihoods`, `bic`, `gmm_n_params`, `ColourFit`, `ColourModels`, `ColourStructure`, `BICScores`.
* Level sets (`levelset`, TR eqs. 5-7, 11, §5): `LevelSetStructure`, `LevelSetOptions`, `LevelSetResult`,
  `evolve(structure, scores (R, H, W))`, `segment_video(structure, scores (T, R, H, W))`,
  `init_level_sets`, `heaviside`, `dirac`, `curvature`, `contour_length`, `signed_distance`;
  `chan_vese_segment` / `chan_vese_scores` (`levelset_grey`: two grey regions, the benchmark's case).
* Blobs, tracking, stereo (`blobs`, `tracking`, `tracks`, `stereo`; TR §3.7): `connected_blobs`, `mask_ellipse`,
  `ellipse_axes`, `weighted_moments`, `track` (α-β, `alpha_beta_gains`), `hand_face_positions` ->
  `HandFacePositions`, `StereoCamera`, `project`, `triangulate`, `camera_matrices`.
* The pipeline (`video`): `fit_skin`, `fit_video_models`, `region_scores`, `segment_recording`,
  `segment_stereo(models, left, right, start, camera)` -> `StereoSegmentation` (labels in `REGIONS`
  order: background, person, skin, object; -1 on boundaries).
* Object around the hand (`phase_segmentation`, LfD 2009 §III-B, eqs. 1-4): `gradient_phase`,
  `temporal_log_ratio` (moves with the hand), `stereo_log_ratio` (at the hand's depth) -> `LogRatio`;
  `object_masks` (threshold, nearest large region, holes, opening: Fig. 3h-j); `segment_objects` from
  grey stereo frames end to end -> `ObjectSegmentation`.
* Temporal segmentation (`events`, LfD §III-D): `filter_in_hand`, `hold_undecided`, `periods_in_hand` -> `Periods`
  (pick-up and put-down frames).

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
from hog_jax.exact import LSHResult, exact_search
from hog_jax.background import (BackgroundOptions, BackgroundState, BackgroundStructure, init_background,
                                run_background, run_background_batch)
from hog_jax.blobs import Blobs, Ellipse, EllipseAxes, connected_blobs, ellipse_axes, mask_ellipse, weighted_moments
from hog_jax.colour_models import (BICScores, ColourFit, ColourModels, ColourStructure, bic, fit_gmm_bic,
                                   fit_person_background_models, gmm_n_params, region_log_likelihoods)
from hog_jax.levelset import (LevelSetOptions, LevelSetResult, LevelSetStructure, contour_length, curvature, dirac,
                              evolve, heaviside, init_level_sets, segment_video, signed_distance)
from hog_jax.levelset_grey import chan_vese_scores, chan_vese_segment
from hog_jax.stereo import StereoCamera, StereoProjection, Triangulation, camera_matrices, project, triangulate
from hog_jax.tracking import INIT_RULES, TrackState, Tracks, alpha_beta_gains, track
from hog_jax.tracks import FACE, HAND, OTHER_HAND, HandFacePositions, hand_face_positions
from hog_jax.video import (REGIONS, StereoSegmentation, VideoModels, VideoOptions, VideoSegmentation, fit_skin,
                           fit_video_models, region_scores, segment_recording, segment_stereo)
from hog_jax.phase_segmentation import (LogRatio, ObjectSegmentation, gradient_phase, object_masks, segment_objects,
                                       stereo_log_ratio, temporal_log_ratio)
from hog_jax.events import Periods, filter_in_hand, hold_undecided, periods_in_hand
from hog_jax.hog import HOGConfig, hog, hog_dim
from hog_jax.knn import (KNNModel, Prediction, euler_to_quat, fit, intra_class_sigma, mean_rotation, predict,
                         quat_to_euler, vote)
from hog_jax.lsh import LSHIndex, TuneResult, build_index, query, recall_at_k, tune
from hog_jax.metric import LinearMetric, apply_metric, fit_metric
from hog_jax.skin_adapt import adapt_skin_model, segment_adapted
from hog_jax.segment import (GMM, Segmentation, SkinModel, SkinStructure, crop_components, fit_gmm, fit_skin_model,
                             gmm_log_prob,
                             load_skin_model, median3, rgb_to_chroma, save_skin_model, segment, skin_log_ratio)

__all__ = [
    "GMM", "Segmentation", "SkinModel", "SkinStructure", "crop_components", "fit_gmm", "fit_skin_model",
    "gmm_log_prob", "load_skin_model",
    "median3", "rgb_to_chroma", "save_skin_model", "segment", "skin_log_ratio",
    "HOGConfig", "KNNModel", "LSHIndex", "LSHResult", "Prediction", "TuneResult", "build_index",
    "euler_to_quat", "exact_search", "fit", "hog", "hog_dim", "intra_class_sigma", "mean_rotation",
    "predict", "query", "quat_to_euler", "recall_at_k", "tune", "vote", "LinearMetric", "apply_metric", "fit_metric",
    "adapt_skin_model", "segment_adapted",
    "BackgroundOptions", "BackgroundState", "BackgroundStructure", "init_background", "run_background",
    "run_background_batch", "Blobs", "Ellipse", "EllipseAxes", "connected_blobs", "ellipse_axes", "mask_ellipse",
    "weighted_moments", "BICScores", "ColourFit", "ColourModels", "ColourStructure", "bic", "fit_gmm_bic",
    "fit_person_background_models", "gmm_n_params", "region_log_likelihoods", "LevelSetOptions", "LevelSetResult",
    "LevelSetStructure", "contour_length", "curvature", "dirac", "evolve", "heaviside", "init_level_sets",
    "segment_video", "signed_distance", "chan_vese_scores", "chan_vese_segment", "StereoCamera", "StereoProjection",
    "Triangulation", "camera_matrices", "project", "triangulate", "INIT_RULES", "TrackState", "Tracks",
    "alpha_beta_gains", "track", "FACE", "HAND", "OTHER_HAND", "HandFacePositions", "hand_face_positions",
    "REGIONS", "StereoSegmentation", "VideoModels", "VideoOptions", "VideoSegmentation", "fit_skin",
    "fit_video_models", "region_scores", "segment_recording", "segment_stereo",
    "LogRatio", "ObjectSegmentation", "gradient_phase", "object_masks", "segment_objects", "stereo_log_ratio",
    "temporal_log_ratio",
    "Periods", "filter_in_hand", "hold_undecided", "periods_in_hand",
]
