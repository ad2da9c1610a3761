"""lfd_jax: the application on one's own recordings, built on the libraries.

The libraries (`phmm_jax`, `hog_jax`, `hog_jax.video`, `crf_jax`, `sim`) hold the methods; `lfd_jax`
holds what a user runs on a recording: file readers, skin models fitted on one's own labelled pixels,
pictures of results, the grasp recognisers (`lfd_jax.grasp`), the demonstration -> robot pipeline
(`lfd_jax.imitation`) and the `lfd-jax` command (`lfd_jax.cli`).

- Motion capture -> `MarkerRecording(markers (T, M, 3) float64 metres, NaN in gaps, names, rate_hz)`:
  `load_markers` (by suffix: Vicon Nexus .csv, .trc, .c3d; .csv.xz / .trc.xz read through lzma),
  `load_nexus_csv`, `load_trc`, `load_c3d`, `read_text`; `fill_gaps`, `gap_runs`, `select_markers`,
  `drop_untracked_markers`, `resample`, `resample_frames`, `make_recording`.
- 2-D keypoint tracks (OpenPose) -> `KeypointTracks(xy (T, J, 2) float64 pixels, NaN where missed,
  confidence (T, J), names, rate_hz, time_s)`: `load_openpose_folder` (a folder of `*_keypoints.json`, one
  person followed), `read_openpose_frame`, `is_openpose_folder`; the reach-to-grasp release:
  `load_reach_npz` (-> `ReachMovement`s), `load_reach_csv`, `crop_to_reach`; `fill_track_gaps`,
  `select_keypoints`, `drop_untracked_keypoints`, `make_tracks`; names `BODY_25`, `COCO_18`, `HAND_21`,
  `OPENPOSE_PARTS`.
- Images and video -> (T, H, W, 3) uint8 RGB, the frames format of `hog_jax.video`:
  `load_image_folder`, `load_video` (-> `VideoFrames`), `load_stereo_videos` (-> `StereoFrames`);
  streaming, chunk by chunk: `iter_image_folder`, `iter_video` (also animated GIFs),
  `iter_stereo_videos`, and `video_info` (-> `VideoInfo`: size, rate, frame count).
- Skin pixels in the UCI Skin Segmentation layout: `load_uci_pixels`; from photos with skin masks:
  `load_mask_pixels`; `fit_thresholded_skin`
  (the chroma skin model with its threshold chosen on held-out pixels), `best_iou_threshold`.
- Pictures: `overlay` (label maps over frames), `truth_coded`, `grey`, `write_video`, `LABEL_COLOURS`.

Every reader raises `ValueError` naming the argument (`path`, `left`, `right`, ...) for a missing or
unreadable file and for contents that disagree with the format.

Example:
    ```python
    import numpy as np
    from lfd_jax import fill_gaps, make_recording

    markers = np.zeros((50, 2, 3))
    markers[10:13, 0] = np.nan                      # a 3-frame gap in the first marker
    rec = fill_gaps(make_recording(markers, ["wrist", "elbow"], rate_hz=100.0))
    assert np.isfinite(rec.markers).all()
    ```
"""
from lfd_jax._src.frames import (IMAGE_SUFFIXES, StereoFrames, VideoFrames, VideoInfo, iter_image_folder,
                                 iter_stereo_videos, iter_video, load_image_folder, load_stereo_videos, load_video,
                                 video_info)
from lfd_jax._src.marker_files import UNIT_TO_METRES, load_c3d, load_markers, load_nexus_csv, load_trc, read_text
from lfd_jax._src.markers import (MarkerRecording, drop_untracked_markers, fill_gaps, gap_runs, make_recording,
                                  resample, resample_frames, select_markers)
from lfd_jax._src.openpose import (BODY_25, COCO_18, HAND_21, OPENPOSE_PARTS, KeypointTracks, ReachMovement,
                                   crop_to_reach, drop_untracked_keypoints, fill_track_gaps, is_openpose_folder,
                                   load_openpose_folder, load_reach_csv, load_reach_npz, make_tracks,
                                   read_openpose_frame, select_keypoints)
from lfd_jax._src.pictures import LABEL_COLOURS, VideoWriter, grey, overlay, truth_coded, write_video
from lfd_jax._src.skin import (REAL_SKIN_PERSONS, UCI_FILE, ThresholdedSkin, best_iou_threshold, fit_real_skin_model, fit_thresholded_skin,
                               load_mask_pixels, load_uci_pixels)

__all__ = [
    "BODY_25", "COCO_18", "HAND_21", "IMAGE_SUFFIXES", "KeypointTracks", "LABEL_COLOURS", "MarkerRecording",
    "OPENPOSE_PARTS", "REAL_SKIN_PERSONS", "ReachMovement", "StereoFrames", "ThresholdedSkin", "UCI_FILE", "UNIT_TO_METRES",
    "VideoFrames", "VideoInfo", "VideoWriter", "best_iou_threshold", "crop_to_reach",
    "drop_untracked_keypoints", "drop_untracked_markers", "fill_gaps", "fill_track_gaps", "fit_real_skin_model",
    "fit_thresholded_skin", "gap_runs", "grey", "is_openpose_folder", "iter_image_folder", "iter_stereo_videos",
    "iter_video", "load_c3d", "load_image_folder", "load_markers", "load_mask_pixels", "load_nexus_csv",
    "load_openpose_folder", "load_reach_csv", "load_reach_npz", "load_stereo_videos", "load_trc",
    "load_uci_pixels", "load_video", "make_recording", "make_tracks", "overlay", "read_openpose_frame",
    "read_text", "resample", "resample_frames", "select_keypoints", "select_markers", "truth_coded",
    "video_info", "write_video",
]
