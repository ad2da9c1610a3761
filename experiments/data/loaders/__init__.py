"""Loaders of real recordings, one in-memory format per kind (issue 23).

Marker data -> `MarkerRecording(markers (T, M, 3) float64 metres, NaN in gaps, names, rate_hz)`
    load_markers(path)            by suffix: .csv (Vicon Nexus export), .trc, .c3d (ezc3d, extra `mocap`);
                                  .csv.xz / .trc.xz read through lzma
    load_nexus_csv, load_trc, load_c3d   the same, one format each
    fill_gaps(rec, max_gap_s=0.2, max_gap_frames=None)   linear interpolation over short gaps,
                                  ValueError naming the marker and frames of a longer one
    select_markers(rec, names), drop_untracked_markers(rec), resample(rec, n_frames),
    resample_frames(x (T, ...), n_frames); read_text(path) (plain or .xz)
Images and video -> (T, H, W, 3) uint8 RGB, the frames format of `hog_jax.video`
    load_image_folder(path) / load_video(path) -> VideoFrames(frames, rate_hz)
    load_stereo_videos(left, right) -> StereoFrames(left, right, rate_hz)

Every loader raises `ValueError` naming the argument (`path`, `left`, `right`, ...) for a missing or
unreadable file and for contents that disagree with the format.
"""
from experiments.data.loaders.frames import (IMAGE_SUFFIXES, StereoFrames, VideoFrames, load_image_folder,
                                             load_stereo_videos, load_video)
from experiments.data.loaders.marker_files import (UNIT_TO_METRES, load_c3d, load_markers, load_nexus_csv, load_trc,
                                                   read_text)
from experiments.data.loaders.markers import (MarkerRecording, drop_untracked_markers, fill_gaps, gap_runs,
                                              make_recording, resample, resample_frames, select_markers)

__all__ = [
    "IMAGE_SUFFIXES", "MarkerRecording", "StereoFrames", "UNIT_TO_METRES", "VideoFrames", "drop_untracked_markers",
    "fill_gaps", "gap_runs", "load_c3d", "load_image_folder", "load_markers", "load_nexus_csv", "load_stereo_videos",
    "load_trc", "load_video", "make_recording", "read_text", "resample", "resample_frames", "select_markers",
]
