"""hog_jax.video: the video front end (LEVELSET TR §3-5; LfD 2009 §III-A; T frames, R regions).

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
"""
from hog_jax.video._src.background import (BackgroundOptions, BackgroundState, BackgroundStructure,
                                           check_options, init_background, log_density, run_background,
                                           run_background_batch, update)
from hog_jax.video._src.blobs import (Blobs, Ellipse, EllipseAxes, connected_blobs, ellipse_axes,
                                      mask_ellipse, weighted_moments)
from hog_jax.video._src.colour_models import (BICScores, ColourFit, ColourModels, ColourStructure, bic,
                                              fit_gmm_bic, fit_person_background_models, gmm_n_params,
                                              region_log_likelihoods)
from hog_jax.video._src.events import Periods, filter_in_hand, hold_undecided, periods_in_hand
from hog_jax.video._src.levelset import (LevelSetOptions, LevelSetResult, LevelSetStructure, contour_length,
                                         curvature, dirac, evolve, heaviside, init_level_sets, segment_video,
                                         signed_distance)
from hog_jax.video._src.levelset_grey import VAR_FLOOR, chan_vese_scores, chan_vese_segment
from hog_jax.video._src.phase import crop_phase, gaussian_kernel
from hog_jax.video._src.phase_segmentation import (LogRatio, ObjectSegmentation, gradient_phase, object_masks,
                                                   segment_objects, stereo_log_ratio, temporal_log_ratio)
from hog_jax.video._src.pipeline import (BACKGROUND, OBJECT, PERSON, REGIONS, SKIN, StereoSegmentation,
                                         VideoModels, VideoOptions, VideoSegmentation, fit_skin,
                                         fit_video_models, follow_light, region_scores, segment_recording,
                                         segment_stereo)
from hog_jax.video._src.stereo import (StereoCamera, StereoProjection, Triangulation, camera_matrices,
                                       project, triangulate)
from hog_jax.video._src.tracking import INIT_RULES, TrackState, Tracks, alpha_beta_gains, track
from hog_jax.video._src.tracks import FACE, HAND, HandFacePositions, OTHER_HAND, hand_face_positions

__all__ = [
    "BACKGROUND", "BICScores", "BackgroundOptions", "BackgroundState", "BackgroundStructure", "Blobs", "ColourFit", "ColourModels",
    "ColourStructure", "Ellipse", "EllipseAxes", "FACE", "HAND", "HandFacePositions", "INIT_RULES", "LevelSetOptions",
    "LevelSetResult", "LevelSetStructure", "LogRatio", "OBJECT", "OTHER_HAND", "ObjectSegmentation", "PERSON", "Periods",
    "REGIONS", "SKIN", "StereoCamera", "StereoProjection", "StereoSegmentation", "TrackState", "Tracks", "Triangulation",
    "VAR_FLOOR", "VideoModels", "VideoOptions", "VideoSegmentation", "alpha_beta_gains", "bic", "camera_matrices", "chan_vese_scores",
    "chan_vese_segment", "check_options", "connected_blobs", "contour_length", "crop_phase", "curvature", "dirac", "ellipse_axes",
    "evolve", "filter_in_hand", "fit_gmm_bic", "fit_person_background_models", "fit_skin", "fit_video_models", "follow_light", "gaussian_kernel",
    "gmm_n_params", "gradient_phase", "hand_face_positions", "heaviside", "hold_undecided", "init_background", "init_level_sets", "log_density",
    "mask_ellipse", "object_masks", "periods_in_hand", "project", "region_log_likelihoods", "region_scores", "run_background", "run_background_batch",
    "segment_objects", "segment_recording", "segment_stereo", "segment_video", "signed_distance", "stereo_log_ratio", "temporal_log_ratio", "track",
    "triangulate", "update", "weighted_moments",
]
