"""Config and presets of the video segmentation study."""
from __future__ import annotations

import dataclasses

from experiments.data import video
from lfd_common import check_int, check_real


@dataclasses.dataclass(frozen=True)
class Config:
    """Skin, level-set and tracking segmentation of rendered stereo recordings (LEVELSET TR §3-5, LfD
    2009 §III-A), and the background model on a real video (CDnet highway)."""

    seed: int = 0
    video_preset: str = "paper"          # experiments.data.video preset of the recordings
    n_skin_persons: int = 2              # persons whose hand and face pixels train the skin models
    eval_repetitions: int = 1            # repetitions per person and OAC evaluated (0: all; 1 keeps the paper preset near 30 min)
    max_clips: int = 0                   # 0: every selected clip of the other persons
    pad_frames: int = 50                 # clips are padded to a multiple of this (one compilation per length)
    motion_penalty: float = 4.0          # VideoOptions: nats off the background where it moves
    object_margin: float = 0.0           # VideoOptions: the object's score above the uniform density
    person_frames: int = 10              # frames before the segmentation starts that teach the person model
    cdnet_dir: str = "../shared/data/cdnet_highway"  # the real video; its part is skipped when absent
    cdnet_last: int = 1700               # last CDnet frame used (1700: all; evaluated from 470)
    sheet_frames: int = 12               # frames in the contact sheet

    def __post_init__(self):
        if self.video_preset not in video.PRESETS:
            raise ValueError(f"video_preset: expected one of {sorted(video.PRESETS)}, got {self.video_preset!r}")
        check_int(self.n_skin_persons, "n_skin_persons", min_value=1)
        check_int(self.eval_repetitions, "eval_repetitions", min_value=0)
        check_int(self.max_clips, "max_clips", min_value=0)
        check_int(self.pad_frames, "pad_frames", min_value=1)
        check_real(self.motion_penalty, "motion_penalty", min_value=0.0)
        check_real(self.object_margin, "object_margin")
        check_int(self.person_frames, "person_frames", min_value=1)
        check_int(self.cdnet_last, "cdnet_last", min_value=471, max_value=1700)
        check_int(self.sheet_frames, "sheet_frames", min_value=1, max_value=60)

    def video_settings(self) -> video.VideoSettings:
        return video.preset(self.video_preset, seed=self.seed)


PRESETS = {
    "quick": {"video_preset": "quick", "n_skin_persons": 1, "cdnet_last": 620, "pad_frames": 25},
    "paper": {},
}
