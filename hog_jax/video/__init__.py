"""hog_jax.video: the video front end (LEVELSET TR §3-5; LfD 2009 §III).

From RGB (stereo) video to skin / person / object / background masks, the tracked hand-minus-face
position, the object in the hand and the pick-up and put-down frames. Shapes: B videos, T frames,
H x W pixels, R regions.

Public API:

* Front end in one call (LfD 2009 §III-A): `front_end` -> `FrontEndResult` (region labels, hand and
  face, the hand's tracks), `hand_tracks`, `pad_frames`, `stereo_camera_from_matrices`,
  `BackgroundOptions.for_fps`.
* Streaming, chunk by chunk with the state carried (memory holds one chunk): `stream_front_end`,
  `stream_stereo`, `stream_recording`, `segment_chunk` from `init_segment_state` (`SegmentState`),
  `hand_face_chunk` (`HandFaceState`), `track_chunk`, `join_chunks`.
* Pipeline: `fit_video_models` (the one skin model, `hog_jax.SkinModel`, adapted to the person by
  `person_skin`) -> `VideoModels`, `segment_recording` ->
  `VideoSegmentation`, `segment_stereo` -> `StereoSegmentation` (`VideoOptions`; labels in
  `REGIONS` order, -1 on boundaries), `region_scores`, `skin_log_density`, `follow_light`;
  `VideoOptions.real_video()` for real camera video.
* One camera: `stream_mono` / `track_mono` -> `MonoTracks` (labels, the face and hands tracked, the
  hands at the far end of the arm).
* Background (Stauffer–Grimson, TR §3.5): `BackgroundStructure`, `BackgroundOptions`,
  `init_background`, `update`, `run_background`, `run_background_batch`, `log_density`; for real
  camera video `BackgroundOptions.real_video()` with `BackgroundStructure.real_video()`.
* Colour models (TR §3.4, BIC): `fit_gmm_bic`, `fit_person_background_models` (`BICOptions`),
  `region_log_likelihoods`, `bic`, `gmm_n_params`.
* Level sets (TR eqs. 5-7, 11): `LevelSetStructure`, `LevelSetOptions`, `evolve`, `segment_video`,
  `init_level_sets`, `chan_vese_segment`, and the pieces `heaviside`, `dirac`, `curvature`,
  `contour_length`, `signed_distance`.
* Blobs, tracking, stereo (TR §3.7; LfD §III-A): `connected_blobs`, `mask_ellipse`, `track`
  (`TrackOptions`, `alpha_beta_gains`), `hand_face_positions` (`HandFaceOptions`), `held`, `hand_ends`
  (`HandEndOptions`: the hand at the far end of a bare-forearm blob), `StereoCamera`,
  `project`, `triangulate`, `camera_matrices`, `stereo_camera_from_matrices`.
* Object in the hand (LfD §III-B, eqs. 1-4): `gradient_phase`, `temporal_log_ratio`,
  `stereo_log_ratio`, `object_masks`, `segment_objects` (`ObjectOptions`).
* Temporal segmentation (LfD §III-D): `filter_in_hand`, `hold_undecided`, `periods_in_hand`.

Example:
    ```python
    import jax, hog_jax, hog_jax.video as hv
    skin = hog_jax.fit_skin_model(jax.random.key(0), skin_rgb, other_rgb, threshold=1.0, luma=True)
    models, _ = hv.fit_video_models(jax.random.key(1), skin, left, start)
    camera = hv.StereoCamera(focal_px=300.0, baseline_m=0.12, width=320, height=240)
    seg = hv.segment_stereo(models, left, right, start, camera)     # (T, 240, 320, 3) each
    seg.left.labels, seg.positions.xyz                              # (T, H, W), (T, 3)
    options = hv.VideoOptions(background=hv.BackgroundOptions.for_fps(10.0))
    out = hv.front_end(jax.random.key(2), skin, left, right, start, camera, options)
    out.hand_left[out.tracked]                                      # (n, 2) rows, columns
    ```
"""
from hog_jax.video._src.arm import HandEndOptions, hand_ends
from hog_jax.video._src.background import (BackgroundOptions, BackgroundStructure, check_options, init_background,
                                           log_density, run_background, run_background_batch, update)
from hog_jax.video._src.background_kernel import BackgroundState
from hog_jax.video._src.blobs import (Blobs, Ellipse, EllipseAxes, connected_blobs, ellipse_axes,
                                      mask_ellipse, weighted_moments)
from hog_jax.video._src.colour_models import (BICOptions, BICScores, ColourFit, ColourModels, ColourStructure, bic,
                                              fit_gmm_bic, fit_person_background_models, gmm_n_params,
                                              region_log_likelihoods)
from hog_jax.video._src.frontend import FrontEndResult, front_end, hand_tracks, pad_frames, stream_front_end
from hog_jax.video._src.events import Periods, filter_in_hand, hold_undecided, periods_in_hand
from hog_jax.video._src.levelset import evolve, init_level_sets, segment_video
from hog_jax.video._src.levelset_evolution import LevelSetOptions, LevelSetResult, LevelSetStructure
from hog_jax.video._src.levelset_grey import VAR_FLOOR, chan_vese_scores, chan_vese_segment
from hog_jax.video._src.levelset_ops import contour_length, curvature, dirac, heaviside, signed_distance
from hog_jax.video._src.phase import crop_phase, gaussian_kernel
from hog_jax.video._src.phase_segmentation import (LogRatio, ObjectOptions, ObjectSegmentation, gradient_phase,
                                                   object_masks, segment_objects, stereo_log_ratio,
                                                   temporal_log_ratio)
from hog_jax.video._src.mono import MonoTracks, stream_mono, track_mono
from hog_jax.video._src.pipeline import (BACKGROUND, OBJECT, PERSON, REGIONS, SKIN, SegmentState,
                                         StereoSegmentation, VideoModels, VideoOptions, VideoSegmentation,
                                         fit_video_models, follow_light, person_skin, init_segment_state, join_chunks,
                                         region_scores, segment_chunk, segment_recording, segment_stereo,
                                         skin_log_density, stream_recording, stream_stereo)
from hog_jax.video._src.stereo import (StereoCamera, StereoProjection, Triangulation, camera_matrices,
                                       project, stereo_camera_from_matrices, triangulate)
from hog_jax.video._src.tracking import (INIT_RULES, TrackOptions, TrackState, Tracks, alpha_beta_gains, track,
                                         track_chunk)
from hog_jax.video._src.tracks import (FACE, HAND, OTHER_HAND, HandFaceOptions, HandFacePositions, HandFaceState,
                                      hand_face_chunk, hand_face_positions, held)

__all__ = [
    "BACKGROUND", "BICOptions", "BICScores", "BackgroundOptions", "BackgroundState", "BackgroundStructure", "Blobs",
    "ColourFit", "ColourModels", "ColourStructure", "Ellipse", "EllipseAxes", "FACE", "FrontEndResult", "HAND",
    "HandEndOptions", "HandFaceOptions", "HandFacePositions", "HandFaceState", "INIT_RULES", "LevelSetOptions", "LevelSetResult", "LevelSetStructure",
    "LogRatio", "MonoTracks", "OBJECT", "OTHER_HAND", "ObjectOptions", "ObjectSegmentation", "PERSON", "Periods", "REGIONS",
    "SKIN", "SegmentState", "StereoCamera", "StereoProjection", "StereoSegmentation", "TrackOptions", "TrackState", "Tracks",
    "Triangulation", "VAR_FLOOR", "VideoModels", "VideoOptions", "VideoSegmentation", "alpha_beta_gains", "bic",
    "camera_matrices", "chan_vese_scores", "chan_vese_segment", "check_options", "connected_blobs",
    "contour_length", "crop_phase", "curvature", "dirac", "ellipse_axes", "evolve", "filter_in_hand", "fit_gmm_bic",
    "fit_person_background_models", "fit_video_models", "follow_light", "front_end", "gaussian_kernel",
    "gmm_n_params", "gradient_phase", "hand_ends", "hand_face_chunk", "hand_face_positions", "hand_tracks", "heaviside", "held", "hold_undecided",
    "init_background", "init_level_sets", "init_segment_state", "join_chunks", "log_density", "mask_ellipse", "object_masks", "pad_frames",
    "periods_in_hand", "person_skin", "project", "region_log_likelihoods", "region_scores", "run_background",
    "run_background_batch", "segment_chunk", "segment_objects", "segment_recording", "segment_stereo", "segment_video",
    "signed_distance", "skin_log_density", "stereo_camera_from_matrices", "stereo_log_ratio", "stream_front_end", "stream_mono", "stream_recording", "stream_stereo", "temporal_log_ratio", "track",
    "track_chunk", "triangulate", "update", "weighted_moments",
]
